//! Coarse blocks of screen-space multi-rate shading: a block's geometry and bilinear weights,
//! grouping a unit's quads into blocks, where each fine lane reads its coarse terms, and the
//! placement of a block's coarse samples.

use std::ops::{Mul, Sub};

use glam::{Vec2, Vec4};

use super::MultirateJob;
use crate::float::round_to_i64;
use crate::scheme::{LaneAttributes, ShadeQuad, UnitContext};
use crate::shader::{Effects, LightTerm, SurfacePoint};
use crate::vertex_stage::SUBPIXEL;

/// The bilinear weights of four corners (in corner order: x, then y) at fraction `u` along
/// x and `v` along y: of a pixel centre between a block's samples, of a parameter in its
/// lattice cell; for one point, or four lanes at once (each lane's bits, `one` being 1).
#[inline(always)]
pub(super) fn bilinear_weights<T: Copy + Sub<Output = T> + Mul<Output = T>>(u: T, v: T, one: T) -> [T; 4] {
    [(one - u) * (one - v), u * (one - v), (one - u) * v, u * v]
}

/// One block of four coarse fragments.
pub(super) struct CoarseBlock {
    pub(super) x0: u32,
    pub(super) y0: u32,
    pub(super) size: u32,
    /// Useful pixels, bit `(y - y0) * size + (x - x0)`.
    pub(super) coverage: u64,
    /// Sample positions in pixels (continuous), order (0,0) (1,0) (0,1) (1,1).
    pub(super) samples: [Vec2; 4],
    /// Per sample, per light.
    pub(super) terms: Vec<LightTerm>,
    pub(super) refine: Effects,
    /// Index of the block's first coarse lane (four consecutive lanes).
    pub(super) first_lane: usize,
}

impl CoarseBlock {
    pub(super) fn new(x0: u32, y0: u32, size: u32) -> CoarseBlock {
        CoarseBlock {
            x0,
            y0,
            size,
            coverage: 0,
            samples: [Vec2::ZERO; 4],
            terms: Vec::new(),
            refine: Effects::empty(),
            first_lane: 0,
        }
    }

    pub(super) fn contains(&self, x: u32, y: u32) -> bool {
        x >= self.x0 && y >= self.y0 && x < self.x0 + self.size && y < self.y0 + self.size
    }

    /// The bilinear weight along x of pixel column `x`'s centre between the samples
    /// (extrapolating outside them); 0 where the samples share a column.
    fn u_at(&self, x: u32) -> f32 {
        let s = &self.samples;
        match s[1].x > s[0].x {
            true => (x as f32 + 0.5 - s[0].x) / (s[1].x - s[0].x),
            false => 0.0,
        }
    }

    /// [`Self::u_at`] along y, of pixel row `y`.
    fn v_at(&self, y: u32) -> f32 {
        let s = &self.samples;
        match s[2].y > s[0].y {
            true => (y as f32 + 0.5 - s[0].y) / (s[2].y - s[0].y),
            false => 0.0,
        }
    }

    /// The coarse fragment (0..4) a pixel of the block belongs to (screen blocks, whose
    /// size is a power of two: a shift per axis).
    pub(super) fn fragment_of(&self, x: u32, y: u32) -> usize {
        debug_assert!(self.size.is_power_of_two() && self.size >= 2);
        let half = self.size.trailing_zeros() - 1;
        (((y - self.y0) >> half) * 2 + ((x - self.x0) >> half)) as usize
    }
}

impl MultirateJob {
    /// Groups quads into blocks of `size` pixels, a power of two (skipping pixels outside
    /// `within`).
    pub(super) fn group(quads: &[ShadeQuad], size: u32, within: Option<&CoarseBlock>, out: &mut Vec<CoarseBlock>) {
        debug_assert!(size.is_power_of_two() && size >= 4);
        let align = !(size - 1);
        for quad in quads {
            // A quad's lanes lie in one block (quads are 2x2-aligned, blocks at least 4x4):
            // it is found once, from the newest block back (a quad's block is mostly among
            // the last row's); blocks are unique, so that is the one `position` finds.
            let (x0, y0) = (quad.x & align, quad.y & align);
            let mut index = None;
            for lane in 0..4u32 {
                let (x, y) = (quad.x + (lane & 1), quad.y + (lane >> 1));
                if quad.lanes & (1 << lane) == 0 || within.is_some_and(|w| !w.contains(x, y)) {
                    continue;
                }
                let index = *index.get_or_insert_with(|| match out.iter().rposition(|b| b.x0 == x0 && b.y0 == y0) {
                    Some(i) => i,
                    None => {
                        out.push(CoarseBlock::new(x0, y0, size));
                        out.len() - 1
                    }
                });
                out[index].coverage |= 1 << ((y - y0) * size + (x - x0));
            }
        }
    }

    /// Per lane of quad `index`: its block, bilinear weights and coarse lane. Screen blocks
    /// are found by position (a quad lies in one block); object-space lanes were assigned to
    /// cells, and belong to the coarse lane of their nearest corner.
    ///
    /// `last` is the screen block of the quad before: blocks do not overlap, so the one that
    /// holds the quad is found by trying it first (its neighbours along a row share it).
    pub(super) fn lane_sources(
        &self,
        index: usize,
        quad: &ShadeQuad,
        last: &mut usize,
    ) -> Option<[(usize, [f32; 4], usize); 4]> {
        if let Some(sources) = self.sources.get(index) {
            return Some(sources.map(|s| {
                let nearest = (0..4).fold(0, |m, i| if s.weights[i] > s.weights[m] { i } else { m });
                (s.block, s.weights, self.blocks[s.block].first_lane + nearest)
            }));
        }
        let block = match self.blocks.get(*last) {
            Some(b) if b.contains(quad.x, quad.y) => *last,
            _ => self.blocks.iter().position(|b| b.contains(quad.x, quad.y))?,
        };
        *last = block;
        let b = &self.blocks[block];
        // A quad's two columns and two rows, each worked out once for the lanes that share it.
        let (u, v) = (
            [b.u_at(quad.x), b.u_at(quad.x + 1)],
            [b.v_at(quad.y), b.v_at(quad.y + 1)],
        );
        // The block holds the whole quad, in one coarse fragment: blocks are aligned squares
        // of at least 4x4 pixels, fragments of at least 2x2, and quads 2x2-aligned.
        debug_assert!(b.contains(quad.x + 1, quad.y + 1) && b.size >= 4);
        let coarse_lane = b.first_lane + b.fragment_of(quad.x, quad.y);
        Some(std::array::from_fn(|l| {
            (block, bilinear_weights(u[l & 1], v[l >> 1], 1.0), coarse_lane)
        }))
    }
}

/// Fixed-point screen position of a coarse sample (pixel coordinates).
pub(super) fn sample_fixed(s: Vec2) -> (i64, i64) {
    (
        round_to_i64(f64::from(s.x * SUBPIXEL as f32)),
        round_to_i64(f64::from(s.y * SUBPIXEL as f32)),
    )
}

/// Interpolated attributes at a block's four coarse samples, four at a time.
pub(super) fn corner_attributes(ctx: &UnitContext, samples: [Vec2; 4]) -> [LaneAttributes; 4] {
    ctx.attributes_at_four(samples.map(sample_fixed)).lanes()
}

/// Where a block's four shading points (in corner order: x, then y) sample the surface
/// maps: each point's footprint is the spacing of the points, the rate it shades at (so the
/// four share their textures' levels of detail, found once). A material without textures
/// reads nothing of them.
pub(super) fn corner_surfaces(
    ctx: &UnitContext,
    corners: &[LaneAttributes; 4],
    tangents: [Vec4; 4],
) -> [SurfacePoint; 4] {
    if !ctx.env.samples_textures(ctx.triangle.material) {
        return [SurfacePoint::UNTEXTURED; 4];
    }
    let (duv_dx, duv_dy) = (corners[1].uv - corners[0].uv, corners[2].uv - corners[0].uv);
    let lods = ctx.env.texture_lods(ctx.triangle.material, duv_dx, duv_dy);
    std::array::from_fn(|i| SurfacePoint {
        uv: corners[i].uv,
        duv_dx,
        duv_dy,
        tangent: tangents[i],
        lods,
    })
}
