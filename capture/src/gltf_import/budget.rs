//! How much an import may decode. Compression (meshopt, Draco, PNG, Basis), accessors
//! without a buffer view and mesh instancing all let a few bytes of file describe
//! gigabytes, so the file's size bounds nothing: each decode is charged here before it
//! allocates, and the import stops with an error naming what went over.

use std::cell::Cell;

use super::{input, Fallible};

/// Bounds on what one import decodes. The defaults hold any scene a trace can carry.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ImportLimits {
    /// Geometry bytes decoded in all: meshopt views, Draco streams, and every accessor's
    /// elements each time they are read (once more for each node instancing a mesh).
    pub geometry_bytes: u64,
    /// One image's pixels as RGBA8 at full size, before they are scaled down to the
    /// texture edge kept.
    pub image_bytes: u64,
}

impl ImportLimits {
    pub const DEFAULT: ImportLimits = ImportLimits {
        // A trace's geometry is one chunk, which readers take up to this size raw.
        geometry_bytes: shadetrace_formats::MAX_CHUNK_RAW_LEN,
        image_bytes: 256 << 20,
    };
}

impl Default for ImportLimits {
    fn default() -> Self {
        ImportLimits::DEFAULT
    }
}

/// What is left of [`ImportLimits::geometry_bytes`] during one import.
pub(super) struct GeometryBudget {
    limit: u64,
    left: Cell<u64>,
}

impl GeometryBudget {
    pub fn new(limit: u64) -> Self {
        GeometryBudget {
            limit,
            left: Cell::new(limit),
        }
    }

    /// Takes `elements` times `element_bytes` (their size in memory) for decoding `what`,
    /// or refuses.
    pub fn charge(&self, elements: u64, element_bytes: u64, what: &str) -> Fallible<()> {
        let left = elements
            .checked_mul(element_bytes)
            .and_then(|bytes| self.left.get().checked_sub(bytes))
            .ok_or_else(|| {
                input(format!(
                    "{what}: decoding {elements} x {element_bytes} bytes would exceed the {} bytes of geometry \
                     capture decodes from one file (mesh instances count again)",
                    self.limit
                ))
            })?;
        self.left.set(left);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn charges_add_up_to_the_limit_and_no_further() {
        let budget = GeometryBudget::new(100);
        assert!(budget.charge(10, 8, "a").is_ok());
        assert!(budget.charge(5, 4, "b").is_ok());
        let refused = budget.charge(1, 1, "mesh 0 POSITION (accessor 3)").unwrap_err();
        assert!(format!("{refused:?}").contains("mesh 0 POSITION (accessor 3)"));
        assert!(budget.charge(0, 8, "c").is_ok(), "nothing to decode is always allowed");
        assert!(
            budget.charge(u64::MAX, 2, "d").is_err(),
            "an overflowing size is refused"
        );
    }
}
