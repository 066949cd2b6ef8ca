//! Scalar float operations that the baseline x86-64 target (SSE2, no `roundss`) compiles to
//! a libm call, written out exactly: the same value, sign of zero and NaN for every input.

use wide::f32x4;

/// `x.floor()`: truncation through an integer, one down where that rounded up (negative
/// fractions), the sign of a zero result kept from `x`. Where `|x| >= 2^23` (always an
/// integer), infinite or NaN, `x` itself, as `floorf` returns it.
#[inline]
pub fn floor(x: f32) -> f32 {
    if x.is_nan() || x.abs() >= 8_388_608.0 {
        return x;
    }
    let truncated = x as i32 as f32;
    let floor = if truncated > x { truncated - 1.0 } else { truncated };
    match floor == 0.0 {
        true => 0.0f32.copysign(x),
        false => floor,
    }
}

/// [`floor`] of four lanes at once, the same steps in SIMD: each lane's bits are `floor`'s.
#[inline]
pub fn floor4(x: f32x4) -> f32x4 {
    let kept = x.is_nan() | x.abs().simd_ge(f32x4::splat(8_388_608.0));
    // Lanes kept as they are may overflow the conversion; their result is dropped.
    let truncated = x.fast_trunc_int().round_float();
    let floor = truncated - (truncated.simd_gt(x) & f32x4::ONE);
    // A zero result takes `x`'s sign: the sign bit of `x` alone.
    let signed_zero = x & f32x4::splat(-0.0);
    let floor = floor.simd_eq(f32x4::ZERO).select(signed_zero, floor);
    kept.select(x, floor)
}

/// `x.round() as i64` (halves away from zero, saturating), without the library call that
/// `round` is on x86-64's baseline: below 2^52 the truncation and the fraction it leaves
/// are exact, and above it every f64 is already an integer. Of an f32 widened to f64, it
/// is also `x.round() as i64` of the f32 (the same value, rounded the same way).
#[inline]
pub fn round_to_i64(x: f64) -> i64 {
    if x.abs() < (1u64 << 52) as f64 {
        let whole = x as i64;
        let fraction = x - whole as f64;
        whole + i64::from(fraction >= 0.5) - i64::from(fraction <= -0.5)
    } else {
        x as i64
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// The inline rounding is `round`'s: halves, their neighbours, integers, the range
        /// where the fraction is exact and past it, and the saturating and NaN extremes.
        #[test]
        fn round_to_i64_is_rounds(
            whole in prop_oneof![-1000i64..1000, -(1i64 << 53)..(1i64 << 53)],
            offset in prop_oneof![Just(0.5f64), Just(-0.5), Just(0.0), -1.0f64..1.0],
            ulps in -2i64..=2,
            special in prop_oneof![
                Just(None), Just(Some(f64::NAN)), Just(Some(f64::INFINITY)), Just(Some(f64::NEG_INFINITY)),
                Just(Some(1e19)), Just(Some(-1e19)), Just(Some(-0.0)), Just(Some(0.49999999999999994)),
                Just(Some(4503599627370495.5)), Just(Some(-4503599627370495.5)),
            ],
        ) {
            let x = special.unwrap_or_else(|| {
                let x = whole as f64 + offset;
                f64::from_bits((x.to_bits() as i64 + ulps) as u64)
            });
            prop_assert_eq!(round_to_i64(x), x.round() as i64, "{}", x);
        }

        /// So is it of an f32 widened, `roundf`'s, for any bits.
        #[test]
        fn round_to_i64_is_roundfs(bits in any::<u32>(), whole in -100_000i32..100_000, half in any::<bool>()) {
            for x in [f32::from_bits(bits), whole as f32 + if half { 0.5 } else { 0.25 }] {
                prop_assert_eq!(round_to_i64(f64::from(x)), x.round() as i64, "{}", x);
            }
        }
    }

    proptest! {
        /// The bits of `f32::floor`, for any bit pattern: both zeros, subnormals, fractions
        /// either side of zero, integers, values past 2^23, infinities and NaN payloads.
        #[test]
        fn floor_is_f32_floor(bits in any::<u32>(), small in -4.0f32..4.0) {
            for x in [f32::from_bits(bits), small, small.trunc(), -small.fract()] {
                prop_assert_eq!(floor(x).to_bits(), x.floor().to_bits(), "{}", x);
            }
        }

        /// The same for four lanes at once, each lane its own bit pattern.
        #[test]
        fn floor4_is_each_lanes_floor(bits in prop::array::uniform4(any::<u32>()), small in prop::array::uniform4(-4.0f32..4.0)) {
            for lanes in [bits.map(f32::from_bits), small, small.map(f32::trunc), small.map(|x| -x.fract())] {
                let got = floor4(f32x4::new(lanes)).to_array();
                for (got, x) in got.into_iter().zip(lanes) {
                    prop_assert_eq!(got.to_bits(), x.floor().to_bits(), "{}", x);
                }
            }
        }
    }

    #[test]
    fn floor_at_the_edges() {
        for x in [
            0.0f32,
            -0.0,
            0.5,
            -0.5,
            -1.0,
            1.0,
            8_388_607.5,
            -8_388_607.5,
            8_388_608.0,
            f32::MIN_POSITIVE,
            -f32::MIN_POSITIVE,
            f32::from_bits(1),
            -f32::from_bits(1),
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            -f32::NAN,
        ] {
            assert_eq!(floor(x).to_bits(), x.floor().to_bits(), "{x}");
            let lanes = floor4(f32x4::new([x, -x, 0.25, x])).to_array();
            assert_eq!(
                lanes.map(f32::to_bits),
                [x, -x, 0.25, x].map(|x| x.floor().to_bits()),
                "{x}"
            );
        }
    }
}
