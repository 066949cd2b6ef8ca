//! Light lists (RTR4 §20.3-20.4): which lights can reach a screen rectangle between two
//! depths. A light with a range is a sphere tested against the six planes of the region's
//! frustum, with a small margin so the test never drops a light that reaches a point of the
//! region (a culled light's term is zero, so lighting with the list gives the pixels of
//! lighting with every light). Lights without a range (directional, or a point light
//! without one) are in every list.

use glam::{Mat4, Vec3, Vec4};
use shadetrace_formats::LightKind;

use super::Accounting;
use crate::cost::{BlockSet, CostHeatList, SimdPacker};
use crate::cost_table::Block;
use crate::pipeline::{SampleBuffer, NO_PRIMITIVE};
use crate::raster::Rect;
use crate::shader::ShadingLight;

/// Screen tiles of tiled shading, in pixels (RTR4 §20.3's usual 16x16).
pub const TILED_TILE: u32 = 16;
/// Clustered shading: screen tiles of this many pixels and this many exponential depth
/// slices between the near and far planes (Persson's 64x64 x 16 in Just Cause 3, RTR4 §20.4).
pub const CLUSTER_TILE: u32 = 64;
pub const CLUSTER_SLICES: u32 = 16;
/// Cost stage and traffic class of light-list building and storage.
pub const LIGHT_LISTS: &str = "light_lists";
/// Bytes of a light list: offset and count, then one 32-bit light index per entry.
pub const LIST_HEADER_BYTES: u64 = 8;
pub const LIST_ENTRY_BYTES: u64 = 4;

/// The lights of a frame, as spheres to cull and lights every list holds.
pub struct LightCuller {
    spheres: Vec<(u32, Vec3, f32)>,
    everywhere: Vec<u32>,
}

impl LightCuller {
    pub fn new(lights: &[ShadingLight]) -> LightCuller {
        let mut spheres = Vec::new();
        let mut everywhere = Vec::new();
        for (i, light) in lights.iter().enumerate() {
            match light.kind {
                LightKind::Point {
                    position,
                    range: Some(r),
                }
                | LightKind::Spot {
                    position,
                    range: Some(r),
                    ..
                } if r > 0.0 => spheres.push((i as u32, position, r)),
                _ => everywhere.push(i as u32),
            }
        }
        LightCuller { spheres, everywhere }
    }

    /// The lights a list tests one by one (one lane each when it is built).
    pub fn tested(&self) -> usize {
        self.spheres.len()
    }

    /// Writes into `out`, ascending, the lights that can reach pixels `rect` of a
    /// `width` x `height` view between NDC depths `z0..=z1`, seen through `view_projection`.
    pub fn cull(&self, view_projection: &Mat4, size: (u32, u32), rect: Rect, z: (f32, f32), out: &mut Vec<u32>) {
        out.clear();
        let (w, h) = (size.0 as f32, size.1 as f32);
        let m = view_projection;
        let row = |i: usize| Vec4::new(m.x_axis[i], m.y_axis[i], m.z_axis[i], m.w_axis[i]);
        let (r0, r1, r2, r3) = (row(0), row(1), row(2), row(3));
        let (left, right) = (2.0 * rect.x0 as f32 / w - 1.0, 2.0 * rect.x1 as f32 / w - 1.0);
        let (top, bottom) = (1.0 - 2.0 * rect.y0 as f32 / h, 1.0 - 2.0 * rect.y1 as f32 / h);
        let planes = [
            r0 - left * r3,
            right * r3 - r0,
            r1 - bottom * r3,
            top * r3 - r1,
            r2 - z.0 * r3,
            z.1 * r3 - r2,
        ]
        .map(|p| {
            let n = p.truncate().length();
            if n > 0.0 {
                p / n
            } else {
                p
            }
        });
        let mut spheres = self.spheres.iter().filter(|&&(_, c, r)| {
            let margin = r * 1.001 + 1e-3;
            planes.iter().all(|p| p.truncate().dot(c) + p.w >= -margin)
        });
        // Both inputs ascend: merge them.
        let mut next = spheres.next();
        for &i in &self.everywhere {
            while let Some(&(j, _, _)) = next.filter(|s| s.0 < i) {
                out.push(j);
                next = spheres.next();
            }
            out.push(i);
        }
        while let Some(&(j, _, _)) = next {
            out.push(j);
            next = spheres.next();
        }
    }
}

/// NDC depth of view-space distance `d` for near and far planes `(n, f)` (the rig's
/// projection maps `n` to 0 and `f` to 1).
pub fn ndc_depth(d: f32, (n, f): (f32, f32)) -> f32 {
    f * (d - n) / ((f - n) * d)
}

/// The view-space distance of NDC depth `z` between near `n` (0) and far `f` (1).
pub fn view_distance(z: f32, (n, f): (f32, f32)) -> f32 {
    n * f / (f - z * (f - n))
}

/// The exponential depth slice of NDC depth `z` (0 at the near plane).
pub fn slice_of(z: f32, range: (f32, f32)) -> u32 {
    let (n, f) = range;
    let d = view_distance(z.clamp(0.0, 1.0), range).max(n);
    let t = libm::logf(d / n) / libm::logf(f / n);
    ((t * CLUSTER_SLICES as f32) as u32).min(CLUSTER_SLICES - 1)
}

/// The NDC depth range of slice `k`.
pub fn slice_depths(k: u32, range: (f32, f32)) -> (f32, f32) {
    let (n, f) = range;
    let at = |k: u32| n * libm::powf(f / n, k as f32 / CLUSTER_SLICES as f32);
    (ndc_depth(at(k), range), ndc_depth(at(k + 1), range))
}

/// Bytes of a light list of `entries` lights.
pub fn list_bytes(entries: usize) -> u64 {
    LIST_HEADER_BYTES + LIST_ENTRY_BYTES * entries as u64
}

/// The NDC depth bounds of the covered samples of `rect` inside `buffer`, charging the
/// reduction (a `DepthBounds` lane per pixel) to the `light_lists` stage; None when no
/// sample is covered.
pub fn depth_bounds(
    buffer: &SampleBuffer,
    rect: Rect,
    packer: &mut SimdPacker,
    blocks: &mut BlockSet,
    acc: &mut Accounting,
) -> Option<(f32, f32)> {
    let samples = buffer.samples;
    let mut bounds: Option<(f32, f32)> = None;
    let stage = acc.cost.stage_mut(LIGHT_LISTS);
    blocks.clear();
    blocks.take(Block::DepthBounds);
    for y in rect.y0..rect.y1 {
        for x in rect.x0..rect.x1 {
            let first = buffer.index(x, y, 0);
            for i in first..first + samples {
                if buffer.tri[i] != NO_PRIMITIVE {
                    let z = buffer.depth[i];
                    bounds = Some(bounds.map_or((z, z), |(a, b)| (a.min(z), b.max(z))));
                }
            }
            packer.lane(blocks, true, u32::MAX, stage, &mut CostHeatList::default());
        }
    }
    packer.flush(stage, &mut CostHeatList::default());
    bounds
}

/// One list build's cost: a `LightCull` lane per light tested, in the `light_lists` stage.
pub fn charge_culling(tested: usize, packer: &mut SimdPacker, blocks: &mut BlockSet, acc: &mut Accounting) {
    let stage = acc.cost.stage_mut(LIGHT_LISTS);
    blocks.clear();
    blocks.take(Block::LightCull);
    for _ in 0..tested {
        packer.lane(blocks, true, u32::MAX, stage, &mut CostHeatList::default());
    }
    packer.flush(stage, &mut CostHeatList::default());
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Mat4;

    fn point(position: Vec3, range: Option<f32>) -> ShadingLight {
        ShadingLight::new(LightKind::Point { position, range }, Vec3::ONE, false)
    }

    #[test]
    fn lists_hold_lights_that_reach_the_region_and_those_without_range() {
        // Looking down -z from the origin, 90 degrees, near 0.1, far 100.
        let proj = Mat4::perspective_rh(std::f32::consts::FRAC_PI_2, 1.0, 0.1, 100.0);
        let lights = [
            point(Vec3::new(0.0, 0.0, -5.0), Some(1.0)),  // centre
            point(Vec3::new(0.0, 0.0, 5.0), Some(1.0)),   // behind the eye
            point(Vec3::new(-4.0, 0.0, -5.0), Some(1.0)), // left edge
            point(Vec3::new(0.0, 0.0, -50.0), None),      // everywhere
        ];
        let culler = LightCuller::new(&lights);
        let mut out = Vec::new();
        let all = Rect {
            x0: 0,
            y0: 0,
            x1: 64,
            y1: 64,
        };
        culler.cull(&proj, (64, 64), all, (0.0, 1.0), &mut out);
        assert_eq!(out, [0, 2, 3]);
        let right_half = Rect {
            x0: 32,
            y0: 0,
            x1: 64,
            y1: 64,
        };
        culler.cull(&proj, (64, 64), right_half, (0.0, 1.0), &mut out);
        assert_eq!(
            out,
            [0, 3],
            "the left light is culled, the centre one touches the middle"
        );
        // Depth bounds nearer than the lights drop them all but the rangeless one.
        culler.cull(&proj, (64, 64), all, (0.0, ndc(1.0)), &mut out);
        assert_eq!(out, [3]);
    }

    fn ndc(d: f32) -> f32 {
        // perspective_rh maps to [0, 1] too (glam's is depth-zero-to-one).
        ndc_depth(d, (0.1, 100.0))
    }

    #[test]
    fn slices_are_exponential_and_cover_near_to_far() {
        let range = (0.1, 100.0);
        assert_eq!(slice_of(0.0, range), 0);
        assert_eq!(slice_of(1.0, range), CLUSTER_SLICES - 1);
        let (z0, z1) = slice_depths(3, range);
        assert_eq!(slice_of((z0 + z1) / 2.0, range), 3);
        assert!(
            (slice_depths(0, range).0).abs() < 1e-6 && (slice_depths(CLUSTER_SLICES - 1, range).1 - 1.0).abs() < 1e-5
        );
    }
}
