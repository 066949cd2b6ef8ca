//! sRGB encoding of linear colour, shared by the pipeline's resolve and the pictures.
//!
//! The transfer function is defined once ([`encode_exact`], `libm` so that it is the same on
//! every platform); what runs per channel is a count of the 255 code boundaries it implies
//! (found once by bisection) up to the value: a table gives the count at the start of the
//! value's bucket of floats, and one compare with the boundary that may lie inside it. The
//! function is monotonic, so the count gives exactly its bytes (checked on every boundary in
//! the tests, and over every `f32` in [0, 1] by an ignored test), at a fraction of a `pow`.

use std::sync::OnceLock;

/// The sRGB transfer function (OETF) from a linear value to an 8-bit code, rounded to
/// nearest. Values are clamped to [0, 1] first; NaN maps to 0 so a bad shader result
/// shows as black instead of poisoning the image.
#[inline]
pub fn linear_to_srgb8(c: f32) -> u8 {
    let c = if c.is_nan() { 0.0 } else { c.clamp(0.0, 1.0) };
    // The number of codes 1..=255 whose boundary `c` has reached: those below its bucket's
    // first float, then the few inside the bucket up to `c`.
    let (boundaries, buckets) = tables();
    // (-0.0, which the clamp keeps, is 0.0's bucket.)
    let code = buckets[((c.to_bits() & !(1 << 31)) >> BUCKET_SHIFT) as usize] as usize;
    // At most one boundary lies inside a bucket ([`tables`] checks): one compare, with no
    // branch on the data (a loop's exit was one a channel, and mispredicted often).
    (code + usize::from(boundaries[code] <= c)) as u8
}

/// Floats in [0, 1] sharing their bits above this shift share a bucket: 2^16 consecutive
/// floats, spanning at most 0.8%, so at most one boundary falls in one (they are 0.9% apart
/// or more; [`tables`] checks).
const BUCKET_SHIFT: u32 = 16;

/// The boundaries (then one that no value reaches, the compare at code 255), and per bucket
/// of floats the number of boundaries below its first float.
fn tables() -> &'static ([f32; 256], Vec<u8>) {
    static TABLES: OnceLock<([f32; 256], Vec<u8>)> = OnceLock::new();
    TABLES.get_or_init(|| {
        let codes = boundaries();
        let buckets: Vec<u8> = (0..=1.0f32.to_bits() >> BUCKET_SHIFT)
            .map(|bucket| {
                let first = f32::from_bits(bucket << BUCKET_SHIFT);
                codes.partition_point(|&b| b <= first) as u8
            })
            .collect();
        // What `linear_to_srgb8`'s one compare relies on: from one bucket's first float to
        // the next's, at most one boundary.
        assert!(
            buckets.windows(2).all(|w| w[1] - w[0] <= 1),
            "two sRGB boundaries in a bucket"
        );
        let mut boundaries = [f32::INFINITY; 256];
        boundaries[..255].copy_from_slice(&codes);
        (boundaries, buckets)
    })
}

/// The definition [`linear_to_srgb8`] reproduces.
fn encode_exact(c: f32) -> u8 {
    let c = unit(c);
    let encoded = if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * libm::pow(c, 1.0 / 2.4) - 0.055
    };
    // In [0, 255] by construction; `as` saturates anyway.
    (encoded * 255.0).round() as u8
}

/// `boundaries()[k - 1]` is the smallest `f32` in [0, 1] that encodes to code `k` or more.
fn boundaries() -> [f32; 255] {
    // Non-negative floats order like their bit patterns: bisect on the bits.
    std::array::from_fn(|i| {
        let code = i as u8 + 1;
        let (mut lo, mut hi) = (0u32, 1.0f32.to_bits());
        while lo < hi {
            let mid = lo + (hi - lo) / 2;
            if encode_exact(f32::from_bits(mid)) >= code {
                hi = mid;
            } else {
                lo = mid + 1;
            }
        }
        f32::from_bits(lo)
    })
}

/// `c` clamped to [0, 1], with NaN as 0 (`f32::clamp` would keep NaN).
pub(crate) fn unit(c: f32) -> f64 {
    if c.is_nan() {
        0.0
    } else {
        f64::from(c.clamp(0.0, 1.0))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_table_gives_the_exact_bytes_on_every_boundary() {
        let b = &tables().0[..255];
        for (i, &x) in b.iter().enumerate() {
            let code = i as u8 + 1;
            assert_eq!(linear_to_srgb8(x), encode_exact(x), "at the boundary of {code}");
            assert_eq!(encode_exact(x), code);
            let below = f32::from_bits(x.to_bits() - 1);
            assert_eq!(
                linear_to_srgb8(below),
                encode_exact(below),
                "below the boundary of {code}"
            );
            assert_eq!(encode_exact(below), code - 1);
        }
        for c in [
            f32::NAN,
            f32::NEG_INFINITY,
            -1.0,
            -0.0,
            0.0,
            1.0,
            2.0,
            f32::INFINITY,
            f32::MIN_POSITIVE,
        ] {
            assert_eq!(linear_to_srgb8(c), encode_exact(c), "{c}");
        }
        // And on a million values spread over [0, 1].
        for n in 0..1_000_000u32 {
            let c = n as f32 / 999_999.0;
            assert_eq!(linear_to_srgb8(c), encode_exact(c), "{c}");
        }
    }

    /// Every `f32` in [0, 1] (about 10⁹ values; `cargo test --release -- --ignored`).
    #[test]
    #[ignore]
    fn the_table_gives_the_exact_bytes_on_every_float_in_the_unit_interval() {
        for bits in 0..=1.0f32.to_bits() {
            let c = f32::from_bits(bits);
            assert_eq!(linear_to_srgb8(c), encode_exact(c), "{c}");
        }
    }
}
