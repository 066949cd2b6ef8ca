//! 32-bit LogLuv (Larson 1998), the format DAIS's multi-rate variant stores its shading
//! samples in: a sign bit and 15 bits of log2 luminance (1/256 steps), then CIE u' and v'
//! in 8 bits each. Relative luminance error is at most 2^(1/512) - 1 (0.14%).

use glam::{Mat3, Vec3};

/// Linear Rec. 709 RGB to CIE XYZ (D65), and back.
const RGB_TO_XYZ: Mat3 = Mat3::from_cols_array(&[
    0.412_456_4,
    0.212_672_9,
    0.019_333_9,
    0.357_576_1,
    0.715_152_2,
    0.119_192,
    0.180_437_5,
    0.072_175,
    0.950_304_1,
]);

pub fn encode(rgb: Vec3) -> u32 {
    let xyz = RGB_TO_XYZ * rgb.max(Vec3::ZERO);
    let y = xyz.y;
    if y.is_nan() || y <= 0.0 || y.is_infinite() {
        return 0;
    }
    let le = (256.0 * (y.log2() + 64.0)).floor().clamp(1.0, 32767.0) as u32;
    let d = xyz.x + 15.0 * xyz.y + 3.0 * xyz.z;
    let (u, v) = (4.0 * xyz.x / d, 9.0 * xyz.y / d);
    let q = |c: f32| (410.0 * c).floor().clamp(0.0, 255.0) as u32;
    le << 16 | q(u) << 8 | q(v)
}

pub fn decode(bits: u32) -> Vec3 {
    let le = bits >> 16 & 0x7fff;
    if le == 0 {
        return Vec3::ZERO;
    }
    let y = ((le as f32 + 0.5) / 256.0 - 64.0).exp2();
    let u = ((bits >> 8 & 0xff) as f32 + 0.5) / 410.0;
    let v = ((bits & 0xff) as f32 + 0.5) / 410.0;
    let d = 6.0 * u - 16.0 * v + 12.0;
    let (x, yc) = (9.0 * u / d, 4.0 * v / d);
    let xyz = Vec3::new(x / yc * y, y, (1.0 - x - yc) / yc * y);
    (RGB_TO_XYZ.inverse() * xyz).max(Vec3::ZERO)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips_within_the_format_steps() {
        for rgb in [
            Vec3::splat(0.2),
            Vec3::new(1.0, 0.5, 0.25),
            Vec3::new(0.02, 0.9, 0.3),
            Vec3::new(12.0, 3.0, 7.0),
        ] {
            let back = decode(encode(rgb));
            let lum = |c: Vec3| (RGB_TO_XYZ * c).y;
            assert!((lum(back) / lum(rgb) - 1.0).abs() < 2e-3, "{rgb} -> {back}");
            // u', v' steps of 1/410 move each channel by a few percent at most.
            assert!(
                (back - rgb).abs().max_element() < 0.05 * rgb.max_element(),
                "{rgb} -> {back}"
            );
        }
        assert_eq!(decode(encode(Vec3::ZERO)), Vec3::ZERO);
    }
}
