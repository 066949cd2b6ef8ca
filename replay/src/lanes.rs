//! The four lanes of a quad computed together: vectors stored by component as four-lane SIMD
//! registers (`wide`: SSE2, NEON, or arrays elsewhere). Each operation is glam's scalar one, in
//! glam's order, applied lane by lane: IEEE addition, multiplication, division and square root
//! round alike in scalar and SIMD form, and nothing here fuses a multiply-add, so every lane
//! gets the bits the scalar shader would.

use glam::{Mat4, Vec3};
use wide::f32x4;

/// Four `Vec3`s, one per lane, stored by component.
#[derive(Clone, Copy, Debug, Default)]
pub struct Vec3x4 {
    x: f32x4,
    y: f32x4,
    z: f32x4,
}

impl Vec3x4 {
    #[inline]
    pub fn from_lanes(lanes: &[Vec3; 4]) -> Vec3x4 {
        Vec3x4 {
            x: f32x4::new(lanes.map(|v| v.x)),
            y: f32x4::new(lanes.map(|v| v.y)),
            z: f32x4::new(lanes.map(|v| v.z)),
        }
    }

    #[inline]
    pub fn splat(v: Vec3) -> Vec3x4 {
        Vec3x4 {
            x: f32x4::splat(v.x),
            y: f32x4::splat(v.y),
            z: f32x4::splat(v.z),
        }
    }

    #[inline]
    pub fn to_lanes(self) -> [Vec3; 4] {
        let (x, y, z) = (self.x.to_array(), self.y.to_array(), self.z.to_array());
        std::array::from_fn(|l| Vec3::new(x[l], y[l], z[l]))
    }

    /// Lane `l`.
    #[inline]
    pub fn lane(self, l: usize) -> Vec3 {
        Vec3::new(self.x.to_array()[l], self.y.to_array()[l], self.z.to_array()[l])
    }

    /// The x, y and z components of the four lanes.
    #[inline]
    pub fn components(self) -> [f32x4; 3] {
        [self.x, self.y, self.z]
    }

    /// glam's scalar `m * p.extend(1.0)` of each lane `p`: the point's clip xyz and w.
    #[inline]
    pub fn transformed_point(self, m: &Mat4) -> (Vec3x4, f32x4) {
        // Per row: ((x_axis x + y_axis y) + z_axis z) + w_axis * 1, glam's order.
        let row = |c: usize| {
            let (a, b, d, w) = (m.x_axis[c], m.y_axis[c], m.z_axis[c], m.w_axis[c]);
            f32x4::splat(a) * self.x + f32x4::splat(b) * self.y + f32x4::splat(d) * self.z + f32x4::splat(w)
        };
        (
            Vec3x4 {
                x: row(0),
                y: row(1),
                z: row(2),
            },
            row(3),
        )
    }

    /// Each lane divided by its own scalar (glam's `Vec3 / f32`).
    #[inline]
    pub fn unscale(self, s: f32x4) -> Vec3x4 {
        Vec3x4 {
            x: self.x / s,
            y: self.y / s,
            z: self.z / s,
        }
    }

    /// Each lane times its own scalar (glam's `Vec3 * f32`).
    #[inline]
    pub fn scale(self, s: f32x4) -> Vec3x4 {
        Vec3x4 {
            x: self.x * s,
            y: self.y * s,
            z: self.z * s,
        }
    }

    /// glam's `dot`: `(x x' + y y') + z z'`.
    #[inline]
    pub fn dot(self, other: Vec3x4) -> f32x4 {
        self.x * other.x + self.y * other.y + self.z * other.z
    }

    /// glam's `normalize_or`: `self * (1 / sqrt(dot(self, self)))` where that reciprocal is
    /// finite and positive, else `fallback`.
    #[inline]
    pub fn normalize_or(self, fallback: Vec3x4) -> Vec3x4 {
        let (scaled, usable) = self.try_normalize();
        Vec3x4::select(usable, scaled, fallback)
    }

    /// glam's `try_normalize`: `self * (1 / sqrt(dot(self, self)))`, and the mask of the
    /// lanes where that reciprocal is finite and positive (glam's `Some`; the others' lanes
    /// are not for use).
    #[inline]
    pub fn try_normalize(self) -> (Vec3x4, f32x4) {
        let rcp = f32x4::ONE / self.dot(self).sqrt();
        // Finite and positive: below infinity and above zero (NaN is neither).
        let usable = rcp.simd_lt(f32x4::splat(f32::INFINITY)) & rcp.simd_gt(f32x4::ZERO);
        (self.scale(rcp), usable)
    }

    /// `a` in the lanes `mask` sets (all bits), `b` in the others.
    #[inline]
    pub fn select(mask: f32x4, a: Vec3x4, b: Vec3x4) -> Vec3x4 {
        Vec3x4 {
            x: mask.bitselect(a.x, b.x),
            y: mask.bitselect(a.y, b.y),
            z: mask.bitselect(a.z, b.z),
        }
    }

    /// glam's `cross`.
    #[inline]
    pub fn cross(self, rhs: Vec3x4) -> Vec3x4 {
        Vec3x4 {
            x: self.y * rhs.z - rhs.y * self.z,
            y: self.z * rhs.x - rhs.z * self.x,
            z: self.x * rhs.y - rhs.x * self.y,
        }
    }

    /// The lanes where `value` is below zero negated, when `enabled`.
    #[inline]
    pub fn negate_where_negative(self, value: f32x4, enabled: bool) -> Vec3x4 {
        if !enabled {
            return self;
        }
        let negative = value.simd_lt(f32x4::ZERO);
        Vec3x4 {
            x: negative.bitselect(-self.x, self.x),
            y: negative.bitselect(-self.y, self.y),
            z: negative.bitselect(-self.z, self.z),
        }
    }
}

impl std::ops::Add for Vec3x4 {
    type Output = Vec3x4;

    #[inline]
    fn add(self, other: Vec3x4) -> Vec3x4 {
        Vec3x4 {
            x: self.x + other.x,
            y: self.y + other.y,
            z: self.z + other.z,
        }
    }
}

impl std::ops::Sub for Vec3x4 {
    type Output = Vec3x4;

    #[inline]
    fn sub(self, other: Vec3x4) -> Vec3x4 {
        Vec3x4 {
            x: self.x - other.x,
            y: self.y - other.y,
            z: self.z - other.z,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn component() -> impl Strategy<Value = f32> {
        prop_oneof![
            -1e3f32..1e3,
            -1e-20f32..1e-20,
            Just(0.0f32),
            Just(-0.0f32),
            Just(f32::INFINITY),
            Just(f32::NAN),
            Just(f32::MAX),
        ]
    }

    fn vec3() -> impl Strategy<Value = Vec3> {
        (component(), component(), component()).prop_map(|(x, y, z)| Vec3::new(x, y, z))
    }

    fn bits(v: Vec3) -> [u32; 3] {
        v.to_array().map(f32::to_bits)
    }

    proptest! {
        /// Every operation gives each lane glam's scalar bits, at zero, tiny, huge and
        /// non-finite inputs too (where normalize falls back).
        #[test]
        fn lanes_are_glams_scalar_operations(
            a in prop::array::uniform4(vec3()),
            b in prop::array::uniform4(vec3()),
            s in prop::array::uniform4(component()),
            enabled in any::<bool>(),
        ) {
            let (va, vb, vs) = (Vec3x4::from_lanes(&a), Vec3x4::from_lanes(&b), f32x4::new(s));
            let normalized = va.normalize_or(vb).to_lanes();
            let dot = va.dot(vb).to_array();
            let difference = (va - vb).to_lanes();
            let sum = (va + vb).to_lanes();
            let scaled = va.scale(vs).to_lanes();
            let flipped = va.negate_where_negative(vs, enabled).to_lanes();
            let unscaled = va.unscale(vs).to_lanes();
            let crossed = va.cross(vb).to_lanes();
            let (tried, usable) = va.try_normalize();
            let (tried, usable) = (tried.to_lanes(), usable.to_array());
            let m = Mat4::from_cols_array(&std::array::from_fn(|i| [a[0], a[1], a[2], a[3], b[0], b[1]][i % 6].to_array()[i % 3]));
            let (clip, w) = va.transformed_point(&m);
            let (clip, w) = (clip.to_lanes(), w.to_array());
            for l in 0..4 {
                prop_assert_eq!(bits(normalized[l]), bits(a[l].normalize_or(b[l])));
                prop_assert_eq!(dot[l].to_bits(), a[l].dot(b[l]).to_bits());
                prop_assert_eq!(bits(difference[l]), bits(a[l] - b[l]));
                prop_assert_eq!(bits(sum[l]), bits(a[l] + b[l]));
                prop_assert_eq!(bits(va.lane(l)), bits(a[l]));
                prop_assert_eq!(bits(scaled[l]), bits(a[l] * s[l]));
                let flip = enabled && s[l] < 0.0;
                prop_assert_eq!(bits(flipped[l]), bits(if flip { -a[l] } else { a[l] }));
                prop_assert_eq!(bits(unscaled[l]), bits(a[l] / s[l]));
                prop_assert_eq!(bits(crossed[l]), bits(a[l].cross(b[l])));
                match a[l].try_normalize() {
                    Some(n) => prop_assert!(usable[l].to_bits() == u32::MAX && bits(tried[l]) == bits(n)),
                    None => prop_assert_eq!(usable[l].to_bits(), 0),
                }
                // A NaN's sign and payload follow the order the compiler gives an addition's
                // operands, which nothing reads: any NaN matches any NaN.
                let same = |a: f32, b: f32| a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan());
                let scalar = m * a[l].extend(1.0);
                let quad = clip[l].extend(w[l]);
                prop_assert!((0..4).all(|c| same(quad[c], scalar[c])), "{quad:?} against {scalar:?}");
            }
        }
    }
}
