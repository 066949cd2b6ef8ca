//! sRGB encoding of linear colour, shared by the pipeline's resolve and the pictures.

/// The sRGB transfer function (OETF) from a linear value to an 8-bit code, rounded to
/// nearest. Values are clamped to [0, 1] first; NaN maps to 0 so a bad shader result
/// shows as black instead of poisoning the image. `libm` keeps the result identical on
/// every platform (ARCHITECTURE.md, Definitions: determinism).
pub fn linear_to_srgb8(c: f32) -> u8 {
    let c = unit(c);
    let encoded = if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * libm::pow(c, 1.0 / 2.4) - 0.055
    };
    // In [0, 255] by construction; `as` saturates anyway.
    (encoded * 255.0).round() as u8
}

/// `c` clamped to [0, 1], with NaN as 0 (`f32::clamp` would keep NaN).
pub(crate) fn unit(c: f32) -> f64 {
    if c.is_nan() {
        0.0
    } else {
        f64::from(c.clamp(0.0, 1.0))
    }
}
