//! Scalar `f32` operations that the baseline x86-64 target (SSE2, no `roundss`) compiles to
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

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

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
