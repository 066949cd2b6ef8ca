//! sRGB encoding of linear colour, shared by the pipeline's resolve and the pictures.
//!
//! The transfer function is defined once ([`encode_exact`], `libm` so that it is the same on
//! every platform); what runs per channel is a search of the 255 code boundaries it implies,
//! found once by bisection. The function is monotonic, so the search gives exactly its bytes
//! (checked on every boundary in the tests, and over every `f32` in [0, 1] by an ignored
//! test), at a fraction of a `pow` per channel.

use std::sync::OnceLock;

/// The sRGB transfer function (OETF) from a linear value to an 8-bit code, rounded to
/// nearest. Values are clamped to [0, 1] first; NaN maps to 0 so a bad shader result
/// shows as black instead of poisoning the image.
#[inline]
pub fn linear_to_srgb8(c: f32) -> u8 {
    let c = if c.is_nan() { 0.0 } else { c.clamp(0.0, 1.0) };
    // The number of codes 1..=255 whose boundary `c` has reached.
    boundaries().partition_point(|&b| b <= c) as u8
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
fn boundaries() -> &'static [f32; 255] {
    static BOUNDARIES: OnceLock<[f32; 255]> = OnceLock::new();
    BOUNDARIES.get_or_init(|| {
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
        let b = boundaries();
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
