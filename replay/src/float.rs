//! Scalar `f32` operations that the baseline x86-64 target (SSE2, no `roundss`) compiles to
//! a libm call, written out exactly: the same value, sign of zero and NaN for every input.

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
        }
    }
}
