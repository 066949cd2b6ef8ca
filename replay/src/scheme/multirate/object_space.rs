//! Object-space shading caches: `amfs` (patch space, Clarberg et al. 2014) and `texel`
//! (texture space, Hillesland & Yang 2016), adapted as in the tile-pair paper (§6): a local
//! LRU cache per job and the frequency detection of He et al.
//!
//! Shading points are the corners of a power-of-two lattice on a surface's parameter domain:
//! a patch's (AMFS) or a mesh's UV atlas (texel). A corner is keyed `(surface, level n,
//! lattice index q)`, so every triangle of a patch and both views share it, whichever shaded
//! it first: the right view reuses left-view shading as it is (no cross-view test), and
//! shading work follows the surface's screen area rather than its triangle count. A pixel
//! falls in one lattice cell and interpolates the cell's four corners bilinearly in
//! parameter space; the predicates of He et al. run on those corners and refine effects per
//! pixel, as in `multirate`.
//!
//! A corner outside the triangle being drawn is shaded at that triangle's nearest point (the
//! patch's surface is not in the trace), so neighbouring triangles of a patch disagree
//! slightly at shared corners: the "inconsistent shading across the triangles in the patch"
//! the tile-pair paper observes of AMFS.

use glam::{Mat2, Vec2, Vec3, Vec4};
use wide::bytemuck::cast;
use wide::{f32x4, i32x4};

use super::block::{bilinear_weights, corner_surfaces, CoarseBlock};
use super::config::{CacheSpace, CoarseMode};
use super::MultirateJob;
use crate::cost_table::Block;
use crate::float::floor4;
use crate::memory::AccessLog;
use crate::raster::pixel_center;
use crate::scheme::shading_cache::{CacheEntry, CacheKey};
use crate::scheme::{ShadeQuad, UnitContext};
use crate::shader::{Effects, SurfacePoint};

/// Coarsest lattice level (a cell spans 2^16 parameter units).
const MIN_LEVEL: i32 = -16;
/// Finest lattice level: a cell of 2^-24 parameter units is below f32 resolution near 1.
const MAX_LEVEL: i32 = 24;
/// Texel shading goes one level finer where the unit normal turns by more than this across
/// a cell (Hillesland & Yang select the level by normal variation too).
const TEXEL_NORMAL_CHANGE: f32 = 0.1;

/// Lattice corners of a cell, in the order of [`bilinear_weights`].
const CORNERS: [(i32, i32); 4] = [(0, 0), (1, 0), (0, 1), (1, 1)];

/// How the triangle being drawn maps onto its surface's parameter domain.
pub(super) struct SurfaceFrame {
    /// Cache namespace: a mesh's atlas, a (mesh, patch) pair, or a lone triangle.
    surface: u64,
    /// Parameter at the triangle's three vertices.
    params: [Vec2; 3],
    /// Inverse of the affine map from barycentrics `(b1, b2)` to `param - params[0]`.
    to_bary: Mat2,
    /// Finest level whose lattice indices stay well inside i32 for this triangle.
    max_level: i32,
    /// Coarsest level: a cell never spans more than the parameter range the surface can
    /// have (the whole barycentric domain of a lone triangle), so its corners stay near it.
    min_level: i32,
    /// The surface is the drawn triangle alone (its own barycentric domain).
    lone: bool,
    /// Side of the square of the triangle's area, in parameter units.
    triangle_size: f32,
}

impl SurfaceFrame {
    /// The texture coordinates where the surface shares one parameterization (a mesh's
    /// atlas, a patch of a mesh with UVs), else the triangle's own barycentric domain
    /// (a triangle without patch id, or whose UVs are degenerate, is its own patch).
    pub(super) fn of(ctx: &UnitContext, space: CacheSpace) -> SurfaceFrame {
        let t = ctx.triangle;
        let shared = match space {
            CacheSpace::Texture => Some(t.mesh as u64),
            CacheSpace::Patch if t.patch != u32::MAX => Some((t.mesh as u64) << 32 | t.patch as u64),
            _ => None,
        };
        let uv = t.vertices.map(|v| ctx.geometry.uvs[v as usize]);
        let uv_map = Mat2::from_cols(uv[1] - uv[0], uv[2] - uv[0]);
        let (surface, params, to_bary) = match shared {
            Some(s) if uv_map.determinant().abs() > f32::MIN_POSITIVE && uv_map.determinant().is_finite() => {
                (s, uv, uv_map.inverse())
            }
            // Bit 63 keeps lone triangles apart from every mesh and (mesh, patch) id.
            _ => (
                1 << 63 | ctx.setup.prim as u64,
                [Vec2::ZERO, Vec2::X, Vec2::Y],
                Mat2::IDENTITY,
            ),
        };
        let extent = params.iter().map(|p| p.abs().max_element()).fold(1.0f32, f32::max);
        let max_level = (29 - libm::ceilf(libm::log2f(extent)) as i32).clamp(MIN_LEVEL, MAX_LEVEL);
        let min_level = (-(libm::ceilf(libm::log2f(extent)) as i32)).clamp(MIN_LEVEL, max_level);
        SurfaceFrame {
            surface,
            params,
            to_bary,
            max_level,
            min_level,
            lone: surface >> 63 == 1,
            triangle_size: libm::sqrtf(0.5 * (params[1] - params[0]).perp_dot(params[2] - params[0]).abs()),
        }
    }

    fn param(&self, bary: Vec3) -> Vec2 {
        self.params[0] * bary.x + self.params[1] * bary.y + self.params[2] * bary.z
    }

    fn bary(&self, param: Vec2) -> Vec3 {
        let b = self.to_bary * (param - self.params[0]);
        Vec3::new(1.0 - b.x - b.y, b.x, b.y)
    }

    /// Lattice level of a quad: one cell spans about `rate` pixels (the coarse fragment of
    /// the coarse mode), from the parameter's change per pixel across the quad, rounded to a
    /// power of two (AMFS's quantized resolution, Hillesland & Yang's mip level). Texel
    /// shading goes one level finer where the normal turns fast across a cell.
    fn level(&self, params: &[Vec2; 4], normals: Option<&[Vec3; 4]>, rate: f32) -> i32 {
        let per_pixel = (params[1] - params[0]).length().max((params[2] - params[0]).length());
        if !(per_pixel.is_finite() && per_pixel > 0.0) {
            return 0.clamp(self.min_level, self.max_level);
        }
        let mut level = libm::roundf(-libm::log2f(rate * per_pixel)) as i32;
        if let Some(n) = normals {
            let n = n.map(|n| n.normalize_or(Vec3::Y));
            let turn_per_pixel = (n[1] - n[0]).length().max((n[2] - n[0]).length());
            let cell_pixels = pow2(-level) / per_pixel;
            if turn_per_pixel * cell_pixels > TEXEL_NORMAL_CHANGE {
                level += 1;
            }
        }
        level.clamp(self.min_level, self.max_level)
    }

    /// Barycentrics of the point of the drawn triangle where a corner of a level-`level`
    /// cell is shaded: the corner's own, extrapolated outside the triangle (exact on flat
    /// surfaces, and the patch's best guess on curved ones: the patch surface is not in the
    /// trace). A lone triangle's surface is the triangle itself, so where its cell is larger
    /// than the triangle (small triangles: corners up to a triangle away, into shadow or out
    /// of it, the light leak of small creased triangles), the corner is shaded at the
    /// triangle's nearest point instead (negative weights dropped, the rest renormalized),
    /// as texture-space shading gives texels outside every triangle the attributes of the
    /// nearest one.
    fn shading_bary(&self, param: Vec2, level: i32) -> Vec3 {
        let b = self.bary(param);
        if !self.lone || pow2(-level) <= self.triangle_size {
            return b;
        }
        let b = b.max(Vec3::ZERO);
        let sum = b.x + b.y + b.z;
        if sum > 0.0 {
            b / sum
        } else {
            Vec3::new(1.0, 0.0, 0.0)
        }
    }
}

/// `2^level`: the bits `libm::exp2f(level as f32)` gives (a power of two is exact), built
/// directly where it is a normal number instead of evaluating the function (a lattice cell is
/// looked up a few times per lane).
fn pow2(level: i32) -> f32 {
    match level {
        -126..=127 => f32::from_bits(((level + 127) as u32) << 23),
        _ => libm::exp2f(level as f32),
    }
}

/// [`pow2`] of four levels at once: the exponent bits of all four where every level gives a
/// normal number, as they almost always do.
fn pow2_lanes(levels: [i32; 4]) -> f32x4 {
    let biased = i32x4::new(levels) + i32x4::splat(127);
    match (biased.simd_gt(i32x4::ZERO) & biased.simd_lt(i32x4::splat(255))).all() {
        true => cast(biased << 23),
        false => f32x4::new(levels.map(pow2)),
    }
}

/// A lattice cell at one level: the block of an object-space scheme.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Cell {
    pub level: i32,
    pub qx: i32,
    pub qy: i32,
}

impl Cell {
    /// Per lane of a quad, the cell holding its parameter at its level and the lane's
    /// [`Self::weights`] in it, four lanes at a time.
    #[inline]
    fn containing_quad(params: [Vec2; 4], levels: [i32; 4]) -> [(Cell, [f32; 4]); 4] {
        let scale = pow2_lanes(levels);
        let (x, y) = (
            f32x4::new(params.map(|p| p.x)) * scale,
            f32x4::new(params.map(|p| p.y)) * scale,
        );
        let (qx, qy) = (floor4(x), floor4(y));
        let weights = bilinear_weights(x - qx, y - qy, f32x4::ONE).map(f32x4::to_array);
        // Truncated as `as i32` truncates: saturated, NaN to zero.
        let (qx, qy) = (qx.trunc_int().to_array(), qy.trunc_int().to_array());
        std::array::from_fn(|l| {
            let cell = Cell {
                level: levels[l],
                qx: qx[l],
                qy: qy[l],
            };
            (cell, weights.map(|w| w[l]))
        })
    }

    /// Bilinear weights of a point at `frac` (fraction of the cell) between the corners.
    fn weights(frac: Vec2) -> [f32; 4] {
        bilinear_weights(frac.x, frac.y, 1.0)
    }

    /// Weights of `param` against this cell (extrapolated when it lies outside).
    fn weights_of(&self, param: Vec2) -> [f32; 4] {
        let scaled = param * pow2(self.level);
        Cell::weights(scaled - Vec2::new(self.qx as f32, self.qy as f32))
    }

    fn corner_param(&self, corner: usize) -> Vec2 {
        let (dx, dy) = CORNERS[corner];
        let (qx, qy) = (self.qx.saturating_add(dx), self.qy.saturating_add(dy));
        Vec2::new(qx as f32, qy as f32) * pow2(-self.level)
    }

    fn key(&self, corner: usize, surface: u64) -> CacheKey {
        let (dx, dy) = CORNERS[corner];
        CacheKey {
            qx: self.qx.saturating_add(dx),
            qy: self.qy.saturating_add(dy),
            n: (self.level - MIN_LEVEL) as u32,
            view: 0,
            surface,
        }
    }
}

/// Where a fine lane of an object-space block reads its coarse terms: the block (its cell)
/// and the lane's bilinear weights in the cell.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct LaneSource {
    pub block: usize,
    pub weights: [f32; 4],
}

/// An object-space block's cell and the pixel its coarse lanes are drawn at in the heat map.
pub(super) struct CellBlock {
    pub cell: Cell,
    pub pixel: u32,
}

impl MultirateJob {
    /// Shades one unit's cells in object space and fills `blocks`, `cells` and `sources`
    /// (one entry per quad) for the fine stage. DYNAMIC4x4 shades at 4-pixel cells first and
    /// moves the lanes of refined cells one level finer (the coarser pass still counts).
    pub(super) fn shade_object_space(
        &mut self,
        ctx: &UnitContext,
        quads: &[ShadeQuad],
        space: CacheSpace,
        log: &mut AccessLog,
    ) {
        let frame = SurfaceFrame::of(ctx, space);
        let rate = if self.config.mode == CoarseMode::Coarse2x2 {
            2.0
        } else {
            4.0
        };
        self.blocks.clear();
        self.cells.clear();
        self.quad_params.clear();
        // Taken from the job so that its allocation is reused from unit to unit.
        let mut levels = std::mem::take(&mut self.quad_levels);
        levels.clear();
        for quad in quads {
            // The lanes' barycentrics four at a time (each lane's bits).
            let (px, py) = pixel_center(quad.x, quad.y);
            let barys = ctx.setup.original_barys(ctx.setup.quad_edges(px, py));
            let params: [Vec2; 4] =
                std::array::from_fn(|l| frame.param(Vec3::new(barys[0][l], barys[1][l], barys[2][l])));
            // Texel shading also picks its level by the normal's variation.
            let normals = (space == CacheSpace::Texture)
                .then(|| ctx.quad_attributes(quad.x, quad.y).lanes().map(|lane| lane.normal));
            levels.push([frame.level(&params, normals.as_ref(), rate); 4]);
            self.quad_params.push(params);
        }
        self.assign_cells(ctx, quads, &levels);
        self.shade_cells(ctx, &frame, 0, log);
        if self.config.mode == CoarseMode::Dynamic4x4 {
            for (sources, quad_levels) in self.sources.iter().zip(&mut levels) {
                for (source, level) in sources.iter().zip(quad_levels) {
                    if !self.blocks[source.block].refine.is_empty() {
                        *level = (*level + 1).min(frame.max_level);
                    }
                }
            }
            let first_new = self.blocks.len();
            self.assign_cells(ctx, quads, &levels);
            self.shade_cells(ctx, &frame, first_new, log);
        }
        self.quad_levels = levels;
    }

    /// Puts every covered lane in the cell holding its parameter at its level, creating a
    /// block for each new cell; helper lanes read their quad's first covered lane's cell.
    fn assign_cells(&mut self, ctx: &UnitContext, quads: &[ShadeQuad], levels: &[[i32; 4]]) {
        self.sources.clear();
        for (q, quad) in quads.iter().enumerate() {
            let params = self.quad_params[q];
            let mut sources = [LaneSource::default(); 4];
            let anchor = quad.lanes.trailing_zeros().min(3) as usize;
            let containing = Cell::containing_quad(params, levels[q]);
            for l in (0..4).filter(|&l| quad.lanes & (1 << l) != 0 || l == anchor) {
                let (cell, weights) = containing[l];
                let block = match self.cells.iter().rposition(|c| c.cell == cell) {
                    Some(b) => b,
                    None => {
                        let (x, y) = (quad.x + (l as u32 & 1), quad.y + (l as u32 >> 1));
                        self.blocks.push(CoarseBlock::new(x, y, 0));
                        self.cells.push(CellBlock {
                            cell,
                            pixel: ctx.pixel_id(x, y),
                        });
                        self.blocks.len() - 1
                    }
                };
                sources[l] = LaneSource { block, weights };
            }
            for l in (0..4).filter(|&l| quad.lanes & (1 << l) == 0 && l != anchor) {
                let block = sources[anchor].block;
                sources[l] = LaneSource {
                    block,
                    weights: self.cells[block].cell.weights_of(params[l]),
                };
            }
            self.sources.push(sources);
        }
    }
    /// Shades blocks `first..`: per cell, four cache queries (reuse stage); each corner
    /// missing from the cache is shaded at its parameter (coarse stage, one lane per corner,
    /// so corners pack densely into SIMD groups) and stored; then the predicates run on the
    /// four corners, charged to the query lanes (flags belong to a cell, not to a cached
    /// corner, so they are evaluated at every visit).
    fn shade_cells(&mut self, ctx: &UnitContext, frame: &SurfaceFrame, first: usize, log: &mut AccessLog) {
        let Some((config, mut cache)) = self.cache.take() else {
            return;
        };
        let n = self.lights;
        let mut blocks = std::mem::take(&mut self.blocks);
        for (index, b) in blocks.iter_mut().enumerate().skip(first) {
            let (cell, pixel) = (self.cells[index].cell, self.cells[index].pixel);
            if b.terms.capacity() == 0 {
                b.terms = self.spare_terms.pop().unwrap_or_default();
            }
            b.terms.clear();
            b.terms.resize(4 * n, Default::default());
            let mut positions = [Vec3::ZERO; 4];
            let mut normals = [Vec3::ZERO; 4];
            let mut missing = [false; 4];
            for i in 0..4 {
                let lane = self.coarse_lane(pixel, true);
                if i == 0 {
                    b.first_lane = lane;
                }
                self.coarse_lanes[lane].blocks.take(Block::CacheQuery);
                cache.counters.queries += 1;
                match cache.get(&cell.key(i, frame.surface)) {
                    Some(e) => {
                        b.terms[i * n..(i + 1) * n].copy_from_slice(e.terms);
                        (positions[i], normals[i]) = (e.position, e.normal);
                        if e.view == ctx.view {
                            cache.counters.local_hits += 1;
                        } else {
                            cache.counters.cross_view_hits += 1;
                        }
                    }
                    None => missing[i] = true,
                }
            }
            if missing.iter().any(|&m| m) {
                cache.counters.blocks_shaded += 1;
            } else {
                cache.counters.blocks_skipped += 1;
            }
            let barys: [Vec3; 4] = std::array::from_fn(|i| frame.shading_bary(cell.corner_param(i), cell.level));
            // Where the corners sample the surface maps; nothing to interpolate without any.
            let surfaces = match ctx.env.maps.of(ctx.triangle.material).is_empty() {
                true => [SurfacePoint::default(); 4],
                false => {
                    let tangents = match ctx.needs_tangents() {
                        true => barys.map(|b| ctx.tangent_at_bary(b)),
                        false => [Vec4::ZERO; 4],
                    };
                    corner_surfaces(ctx, &barys.map(|b| ctx.interpolate(b)), tangents)
                }
            };
            let [a, c, d] = ctx.triangle.vertices.map(|v| v as usize);
            let g = ctx.geometry;
            for i in (0..4).filter(|&i| missing[i]) {
                let bary = barys[i];
                positions[i] = g.positions[a] * bary.x + g.positions[c] * bary.y + g.positions[d] * bary.z;
                normals[i] =
                    (g.normals[a] * bary.x + g.normals[c] * bary.y + g.normals[d] * bary.z).normalize_or(Vec3::Y);
            }
            // Shading reads nothing the cache holds, so the corners are shaded before they are
            // stored.
            if missing.contains(&true) {
                let corners = (&positions, &normals, &surfaces);
                self.shade_corners(ctx, missing, [pixel; 4], corners, &mut b.terms, log);
            }
            for i in (0..4).filter(|&i| missing[i]) {
                cache.put(
                    cell.key(i, frame.surface),
                    CacheEntry {
                        position: positions[i],
                        normal: normals[i],
                        r_dot_l: &[],
                        terms: &b.terms[i * n..(i + 1) * n],
                        refine: Effects::empty(),
                        view: ctx.view,
                    },
                );
            }
            b.refine = self.predicates(ctx, b, &positions, &normals);
        }
        self.blocks = blocks;
        self.cache = Some((config, cache));
    }
}

#[cfg(test)]
mod tests {
    use super::{pow2, Cell};
    use glam::Vec2;
    use proptest::prelude::*;

    proptest! {
        /// Each lane's cell and weights are those of its own parameter and level, bit for
        /// bit (NaN for NaN): fractions either side of zero, huge and tiny parameters,
        /// infinities and NaN, at levels from subnormal scales to overflowing ones.
        #[test]
        fn quad_cells_are_each_lanes_own(
            params in prop::array::uniform4((any::<u32>(), -64.0f32..64.0, any::<bool>())),
            levels in prop::array::uniform4(-160i32..140),
        ) {
            let params = params.map(|(bits, small, raw)| match raw {
                true => Vec2::new(f32::from_bits(bits), small),
                false => Vec2::new(small, -small),
            });
            let got = Cell::containing_quad(params, levels);
            for l in 0..4 {
                let scaled = params[l] * pow2(levels[l]);
                let q = scaled.floor();
                let cell = Cell { level: levels[l], qx: q.x as i32, qy: q.y as i32 };
                prop_assert_eq!(got[l].0, cell);
                // A NaN weight's sign and payload are not the program's to fix (operands of a
                // product may be swapped): any NaN matches any NaN.
                let bits = |w: [f32; 4]| w.map(|w| if w.is_nan() { f32::NAN.to_bits() } else { w.to_bits() });
                prop_assert_eq!(bits(got[l].1), bits(Cell::weights(scaled - q)));
            }
        }
    }

    /// Four levels at once give each level's `pow2`, also where one of them leaves the
    /// normal range.
    #[test]
    fn pow2_lanes_are_each_levels_pow2() {
        for level in -160..=140 {
            let levels = [level, 0, -level, level / 2];
            let got = super::pow2_lanes(levels).to_array().map(f32::to_bits);
            assert_eq!(got, levels.map(|l| pow2(l).to_bits()), "level {level}");
        }
    }

    /// The shortcut gives `exp2f`'s bits at every level, normal, subnormal or overflowing.
    #[test]
    fn pow2_is_exp2f_at_integers() {
        for level in -160..=140 {
            assert_eq!(
                pow2(level).to_bits(),
                libm::exp2f(level as f32).to_bits(),
                "level {level}"
            );
        }
    }
}
