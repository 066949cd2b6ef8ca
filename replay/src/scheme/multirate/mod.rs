//! `multirate`: adaptive multi-rate shading of He, Gu and Fatahalian (2014).
//!
//! Coarse fragments come in blocks of four (a 2x2 block of coarse fragments covering 4x4
//! pixels in COARSE2x2, 8x8 in COARSE4x4), emitted for every block with a covered sample.
//! The coarse stage evaluates the lighting terms (diffuse, specular, shadow, local lights) at
//! the block's four sample positions and runs the refinement predicates of §4; the fine stage
//! runs per covered 2x2 quad, samples the albedo, resamples the coarse terms bilinearly and
//! re-evaluates per pixel every effect the block refined. DYNAMIC4x4 shades 4x4 first and
//! re-shades refined blocks at 2x2 (the repeated coarse work is counted).
//!
//! Refining every effect (threshold 0) recomputes all terms per pixel with the same code and
//! summation order as `per-pixel`, so the image is bit-identical to the reference.

mod block;
pub mod config;
mod issue;
mod object_space;
mod predicates;
mod tile_pair_cache;

use glam::{Vec2, Vec3, Vec4};
use shadetrace_formats::Scene;
use wide::f32x4;

use super::shading_cache::{CacheKey, ShadingCache};
use super::{Accounting, LaneAttributes, SchemeJob, ShadeQuad, ShadingScheme, UnitContext};
use crate::cost::{BlockSet, SimdPacker};
use crate::cost_table::Block;
use crate::lanes::Vec3x4;
use crate::memory::AccessLog;
use crate::options::ReplayOptions;
use crate::shader::{
    compose, compose_quad, Effects, LightTerm, LightingInputs, QuadLighting, QuadTexels, Surface, SurfacePoint,
};
use block::{corner_attributes, corner_surfaces, CoarseBlock};
pub use config::{
    CacheConfig, CacheSpace, CoarseMode, MultirateConfig, ReuseTest, Sampling, SimdSchedule, Thresholds,
    DEFAULT_SAMPLING,
};
use object_space::{CellBlock, LaneSource};
use tile_pair_cache::CacheScratch;

pub struct Multirate(pub MultirateConfig);

/// The scheme under `opts`, in the preset's coarse mode unless `--coarse-mode` overrides it,
/// with a shading cache in `space` (none: He et al. as published).
pub fn build(
    preset_mode: Option<CoarseMode>,
    opts: &ReplayOptions,
    space: Option<CacheSpace>,
) -> Box<dyn ShadingScheme> {
    let m = &opts.multirate;
    Box::new(Multirate(MultirateConfig {
        mode: m.mode.or(preset_mode).unwrap_or(CoarseMode::Coarse2x2),
        sampling: m.sampling.unwrap_or(DEFAULT_SAMPLING),
        small_triangle: m.small_triangle.unwrap_or(true),
        thresholds: m.thresholds.scaled(m.threshold_scale),
        schedule: m.schedule,
        cache: space.map(|space| CacheConfig {
            space,
            bytes: m.cache_kb * 1024,
            reuse: m.reuse,
        }),
    }))
}

/// Texel shading needs a unique UV atlas on every mesh; the error names the first mesh
/// without one.
pub fn supports_texel(scene: &Scene) -> Result<(), String> {
    match scene
        .geometry
        .meshes
        .iter()
        .find(|m| m.uvs.is_empty() || !m.uv_atlas_unique)
    {
        Some(mesh) => Err(format!(
            "texel shading needs a unique UV atlas, and mesh `{}` has none",
            mesh.name
        )),
        None => Ok(()),
    }
}

impl ShadingScheme for Multirate {
    fn name(&self) -> &'static str {
        match self.0.cache.map(|c| c.space) {
            None => "multirate",
            Some(CacheSpace::Screen) => "tile-pair-cache",
            Some(CacheSpace::Patch) => "amfs",
            Some(CacheSpace::Texture) => "texel",
        }
    }

    fn edge_receiver_delta(&self) -> Option<f32> {
        Some(self.0.thresholds.edge_delta)
    }

    fn begin_job(&self, lights: usize, simd_width: u32) -> Box<dyn SchemeJob> {
        Box::new(MultirateJob::new(self.0, lights, simd_width))
    }
}

impl MultirateJob {
    /// A job with the worker's lane pools when they are for as many lights.
    fn new(config: MultirateConfig, lights: usize, simd_width: u32) -> MultirateJob {
        let pools = LANE_POOLS
            .take()
            .filter(|pools| pools.lights == lights)
            .unwrap_or_default();
        MultirateJob {
            config,
            lights,
            simd_width,
            coarse_packer: SimdPacker::new(simd_width, lights),
            fine_packer: SimdPacker::new(simd_width, lights),
            blocks: Vec::new(),
            kept_blocks: Vec::new(),
            finer_blocks: Vec::new(),
            coarse_lanes: pools.coarse,
            coarse_used: 0,
            fine_lanes: pools.fine,
            fine_used: 0,
            order: Vec::new(),
            terms: vec![LightTerm::default(); lights],
            spare_terms: pools.terms,
            cache: config.cache.map(|c| (c, ShadingCache::new(c.bytes, lights))),
            cache_scratch: CacheScratch::default(),
            reuse_packer: SimdPacker::new(simd_width, lights),
            cells: Vec::new(),
            quad_params: Vec::new(),
            quad_levels: Vec::new(),
            sources: Vec::new(),
            quad: QuadLighting::default(),
            texels: QuadTexels::default(),
        }
    }
}

/// Stage of coarse-rate shading and the refinement predicates (CoarseInst in the tile-pair
/// paper).
pub const COARSE: &str = "coarse";

/// A fine lane's work, kept for SIMD packing once the unit's quads are shaded.
struct FineLane {
    blocks: BlockSet,
    useful: bool,
    /// Its heat-map id; `u32::MAX` in a frame without a heat map, where nothing reads it.
    pixel: u32,
    /// Refinement bits of its block (the sort key of `TwoPhaseSorted`).
    key: u8,
    /// The coarse lane (fragment) this pixel belongs to (single-thread scheduling).
    coarse_lane: usize,
}

/// A coarse lane's blocks and the pixel its cost is drawn at in the heat map.
struct CoarseLane {
    blocks: BlockSet,
    pixel: u32,
    /// Cache query and reuse-shader lanes are issued in the `reuse` stage.
    reuse: bool,
}

/// A job's lane pools and spare term buffers, kept by each worker thread from one job to the
/// next (a frame's thousands of jobs would otherwise each grow them again, a block set per
/// lane); reused only by a job with as many lights, and reset lane by lane as they are used.
#[derive(Default)]
struct LanePools {
    lights: usize,
    coarse: Vec<CoarseLane>,
    fine: Vec<FineLane>,
    terms: Vec<Vec<LightTerm>>,
}

thread_local! {
    static LANE_POOLS: std::cell::Cell<Option<LanePools>> = const { std::cell::Cell::new(None) };
}

impl Drop for MultirateJob {
    fn drop(&mut self) {
        self.spare_block_terms();
        let pools = LanePools {
            lights: self.lights,
            coarse: std::mem::take(&mut self.coarse_lanes),
            fine: std::mem::take(&mut self.fine_lanes),
            terms: std::mem::take(&mut self.spare_terms),
        };
        // A thread being torn down keeps nothing.
        let _ = LANE_POOLS.try_with(|kept| kept.set(Some(pools)));
    }
}

struct MultirateJob {
    config: MultirateConfig,
    lights: usize,
    simd_width: u32,
    coarse_packer: SimdPacker,
    fine_packer: SimdPacker,
    blocks: Vec<CoarseBlock>,
    /// DYNAMIC4x4's lists of the blocks kept and of a refined block's 2x2 blocks, empty
    /// between uses (no allocation per unit or block).
    kept_blocks: Vec<CoarseBlock>,
    finer_blocks: Vec<CoarseBlock>,
    /// Lane pools, reused across units (no per-pixel allocation); `*_used` are live.
    coarse_lanes: Vec<CoarseLane>,
    coarse_used: usize,
    fine_lanes: Vec<FineLane>,
    fine_used: usize,
    order: Vec<usize>,
    terms: Vec<LightTerm>,
    /// The term buffers of the previous unit's blocks, for the next unit's (no allocation
    /// per block).
    spare_terms: Vec<Vec<LightTerm>>,
    cache: Option<(CacheConfig, ShadingCache)>,
    cache_scratch: CacheScratch,
    reuse_packer: SimdPacker,
    /// Object-space schemes: each block's cell, each quad's lane parameters and lattice
    /// levels, and where each quad's lanes read their terms (the blocks are cells, not
    /// screen squares).
    cells: Vec<CellBlock>,
    quad_params: Vec<[Vec2; 4]>,
    quad_levels: Vec<[i32; 4]>,
    sources: Vec<[LaneSource; 4]>,
    /// The coarse stage's four corners, shaded as a quad's lanes ([`ShaderEnv::quad_lighting`]).
    quad: QuadLighting,
    /// A resampled quad's surface maps, sampled four lanes at a time
    /// ([`ShaderEnv::sample_surface_maps`]).
    texels: QuadTexels,
}

impl SchemeJob for MultirateJob {
    /// The shading cache lives for one tile-pair sequence (Yuan et al. §5).
    fn begin_sequence(&mut self) {
        if let Some((_, cache)) = self.cache.as_mut() {
            cache.clear();
        }
    }

    fn shade_unit(
        &mut self,
        ctx: &UnitContext,
        quads: &[ShadeQuad],
        colors: &mut Vec<[Vec4; 4]>,
        acc: &mut Accounting,
    ) {
        self.coarse_used = 0;
        self.fine_used = 0;
        self.spare_block_terms();
        self.terms.resize(self.lights, LightTerm::default());
        self.sources.clear();
        match self.config.cache.map(|c| c.space) {
            Some(space @ (CacheSpace::Patch | CacheSpace::Texture)) => {
                self.shade_object_space(ctx, quads, space, acc.log)
            }
            _ => self.shade_screen_space(ctx, quads, acc.log),
        }
        let mut last_block = 0;
        for (index, quad) in quads.iter().enumerate() {
            colors.push(self.shade_quad(ctx, index, quad, &mut last_block, acc));
        }
        self.issue(acc);
        if let Some((_, cache)) = self.cache.as_mut() {
            acc.cache.add(&std::mem::take(&mut cache.counters));
        }
    }
}

impl MultirateJob {
    /// Screen-space blocks (He et al., tile-pair cache): aligned squares of the coarse mode's
    /// size; DYNAMIC4x4 re-shades refined 4x4 blocks at 2x2 (their first pass still counts).
    fn shade_screen_space(&mut self, ctx: &UnitContext, quads: &[ShadeQuad], log: &mut AccessLog) {
        let first = if self.config.mode == CoarseMode::Coarse2x2 {
            4
        } else {
            8
        };
        let mut blocks = std::mem::take(&mut self.blocks);
        Self::group(quads, first, None, &mut blocks);
        for b in &mut blocks {
            self.shade_block(ctx, b, log);
        }
        if self.config.mode == CoarseMode::Dynamic4x4 {
            // Refined 4x4 blocks are re-shaded at 2x2; their first coarse pass still counts.
            let mut kept = std::mem::take(&mut self.kept_blocks);
            let mut finer = std::mem::take(&mut self.finer_blocks);
            for b in blocks.drain(..) {
                if b.refine.is_empty() {
                    kept.push(b);
                    continue;
                }
                Self::group(quads, 4, Some(&b), &mut finer);
                self.spare_terms.push(b.terms);
                for mut sub in finer.drain(..) {
                    self.shade_block(ctx, &mut sub, log);
                    kept.push(sub);
                }
            }
            // The emptied list keeps its room for the next unit's.
            (self.kept_blocks, self.finer_blocks) = (blocks, finer);
            blocks = kept;
        }
        self.blocks = blocks;
    }

    /// Places the samples, evaluates the coarse terms and runs the predicates of one block.
    fn shade_block(&mut self, ctx: &UnitContext, b: &mut CoarseBlock, log: &mut AccessLog) {
        let cfg = self.config;
        let (mut xmin, mut ymin, mut xmax, mut ymax) = (u32::MAX, u32::MAX, 0, 0);
        let shift = b.size.trailing_zeros();
        for bit in 0..b.size * b.size {
            if b.coverage & (1 << bit) != 0 {
                let (x, y) = (bit & (b.size - 1), bit >> shift);
                (xmin, ymin, xmax, ymax) = (xmin.min(x), ymin.min(y), xmax.max(x), ymax.max(y));
            }
        }
        let (fx, fy) = (b.x0 as f32, b.y0 as f32);
        // Small-triangle optimization: coverage inside one 2x2 region is shaded at its pixel
        // centres, exactly like quad shading, and never refined.
        let exact = cfg.small_triangle && xmax - xmin <= 1 && ymax - ymin <= 1;
        let (xa, xb, ya, yb) = if exact {
            let (qx, qy) = (xmin.min(b.size - 2), ymin.min(b.size - 2));
            (
                fx + qx as f32 + 0.5,
                fx + qx as f32 + 1.5,
                fy + qy as f32 + 0.5,
                fy + qy as f32 + 1.5,
            )
        } else {
            match cfg.sampling {
                Sampling::StaticCenter => {
                    let q = b.size as f32 / 4.0;
                    (fx + q, fx + 3.0 * q, fy + q, fy + 3.0 * q)
                }
                Sampling::StaticCorner => {
                    let e = b.size as f32 - 0.5;
                    (fx + 0.5, fx + e, fy + 0.5, fy + e)
                }
                Sampling::CoverageBbox => (
                    fx + xmin as f32 + 0.5,
                    fx + xmax as f32 + 0.5,
                    fy + ymin as f32 + 0.5,
                    fy + ymax as f32 + 0.5,
                ),
            }
        };
        b.samples = [
            Vec2::new(xa, ya),
            Vec2::new(xb, ya),
            Vec2::new(xa, yb),
            Vec2::new(xb, yb),
        ];
        if b.terms.capacity() == 0 {
            b.terms = self.spare_terms.pop().unwrap_or_default();
        }
        b.terms.clear();
        b.terms.resize(4 * self.lights, LightTerm::default());
        let mut positions = [Vec3::ZERO; 4];
        let mut normals = [Vec3::ZERO; 4];
        let half = b.size / 2;
        // The coarse fragments' cost is drawn at their centre pixels in the heat map.
        let pixels: [u32; 4] = std::array::from_fn(|i| {
            let (cx, cy) = (
                b.x0 + (i as u32 & 1) * half + half / 2,
                b.y0 + (i as u32 >> 1) * half + half / 2,
            );
            ctx.pixel_id(cx.min(ctx.width - 1), cy.min(ctx.height - 1))
        });
        let corners = corner_attributes(ctx, b.samples);
        for (i, a) in corners.iter().enumerate() {
            positions[i] = a.position;
            normals[i] = a.normal;
        }
        let tangents = match ctx.needs_tangents() {
            true => b.samples.map(|s| {
                let (px, py) = block::sample_fixed(s);
                ctx.tangent_at(px, py)
            }),
            false => [Vec4::ZERO; 4],
        };
        let surfaces = corner_surfaces(ctx, &corners, tangents);
        // The block's own cache keys, computed once for the query and the store.
        let keys: Option<[CacheKey; 4]> = self
            .cache
            .as_ref()
            .filter(|_| !exact)
            .map(|_| std::array::from_fn(|i| Self::key(b, i, ctx.view)));
        if let Some(keys) = &keys {
            if self.reuse_from_cache(ctx, b, keys, &positions, &normals, &pixels) {
                return;
            }
        }
        let corners = (&positions, &normals, &surfaces);
        b.first_lane = self.shade_corners(ctx, [true; 4], pixels, corners, &mut b.terms, log)[0];
        b.refine = if exact {
            Effects::empty()
        } else {
            self.predicates(ctx, b, &positions, &normals)
        };
        if let Some(keys) = &keys {
            self.store_in_cache(ctx, b, keys, &positions, &normals);
        }
    }

    /// Runs the coarse shader (every effect) at a block's `shaded` corners, in corner order,
    /// each on a new coarse lane of its pixel, writing its light terms (a light's term of
    /// corner `i` at `i * lights + k`); returns the corners' lanes (0 for the others). The
    /// corners' arithmetic runs four at a time where the scene allows it
    /// ([`ShaderEnv::quad_lighting`]); each corner's reads and blocks stay its own.
    #[inline(always)]
    fn shade_corners(
        &mut self,
        ctx: &UnitContext,
        shaded: [bool; 4],
        pixels: [u32; 4],
        (positions, normals, surfaces): (&[Vec3; 4], &[Vec3; 4], &[SurfacePoint; 4]),
        terms: &mut [LightTerm],
        log: &mut AccessLog,
    ) -> [usize; 4] {
        let (n, material) = (self.lights, ctx.triangle.material);
        let (p, nrm) = (Vec3x4::from_lanes(positions), Vec3x4::from_lanes(normals));
        let four_wide = ctx
            .env
            .quad_lighting(material, ctx.eye, p, nrm, Some(surfaces), &mut self.quad);
        let mut lanes = [0; 4];
        for i in (0..4).filter(|&i| shaded[i]) {
            let terms = &mut terms[i * n..(i + 1) * n];
            lanes[i] = match four_wide {
                true => {
                    let lane = self.coarse_lane(pixels[i], false);
                    let blocks = &mut self.coarse_lanes[lane].blocks;
                    ctx.env
                        .lane_terms(&self.quad, i, material, &surfaces[i], terms, blocks, log);
                    lane
                }
                false => {
                    self.shade_coarse_fragment(ctx, pixels[i], (positions[i], normals[i], surfaces[i]), terms, log)
                }
            };
        }
        lanes
    }

    /// Runs the coarse shader (every effect) at one point on a new coarse lane of `pixel`,
    /// writing its light terms; returns the lane.
    fn shade_coarse_fragment(
        &mut self,
        ctx: &UnitContext,
        pixel: u32,
        (position, normal, surface): (Vec3, Vec3, SurfacePoint),
        terms: &mut [LightTerm],
        log: &mut AccessLog,
    ) -> usize {
        let lane = self.coarse_lane(pixel, false);
        ctx.env.light_terms(
            &LightingInputs {
                position,
                normal,
                eye: ctx.eye,
                material: ctx.triangle.material,
                surface,
            },
            Effects::all(),
            terms,
            &mut self.coarse_lanes[lane].blocks,
            log,
        );
        lane
    }

    /// Empties the block list, keeping its blocks' term buffers for the next blocks.
    fn spare_block_terms(&mut self) {
        self.spare_terms.extend(self.blocks.drain(..).map(|b| b.terms));
    }

    fn coarse_lane(&mut self, pixel: u32, reuse: bool) -> usize {
        if self.coarse_used == self.coarse_lanes.len() {
            self.coarse_lanes.push(CoarseLane {
                blocks: BlockSet::new(self.lights),
                pixel,
                reuse,
            });
        }
        let lane = &mut self.coarse_lanes[self.coarse_used];
        lane.blocks.clear();
        lane.pixel = pixel;
        lane.reuse = reuse;
        self.coarse_used += 1;
        self.coarse_used - 1
    }

    #[inline]
    fn fine_lane(&mut self) -> usize {
        if self.fine_used == self.fine_lanes.len() {
            self.fine_lanes.push(FineLane {
                blocks: BlockSet::new(self.lights),
                useful: false,
                pixel: u32::MAX,
                key: 0,
                coarse_lane: 0,
            });
        }
        self.fine_lanes[self.fine_used].blocks.clear();
        self.fine_used += 1;
        self.fine_used - 1
    }

    /// Fine stage of one quad: albedo per pixel, coarse terms resampled, refined effects
    /// recomputed; returns the four lane colours.
    fn shade_quad(
        &mut self,
        ctx: &UnitContext,
        index: usize,
        quad: &ShadeQuad,
        last_block: &mut usize,
        acc: &mut Accounting,
    ) -> [Vec4; 4] {
        let attributes = ctx.quad_attributes(quad.x, quad.y);
        let lanes = attributes.lanes();
        let Some(sources) = self.lane_sources(index, quad, last_block) else {
            return [Vec4::ZERO; 4];
        };
        let points = ctx.quad_surface_points(attributes.uv, quad.x, quad.y);
        let points = points.get();
        match sources.iter().all(|&(block, ..)| self.blocks[block].refine.is_empty()) {
            true => self.shade_quad_resampled(ctx, quad, points, &sources, acc),
            false => self.shade_quad_lanes(ctx, quad, &lanes, points, &sources, acc),
        }
    }

    /// [`Self::shade_quad`] lane by lane.
    fn shade_quad_lanes(
        &mut self,
        ctx: &UnitContext,
        quad: &ShadeQuad,
        lanes: &[LaneAttributes; 4],
        points: &[SurfacePoint; 4],
        sources: &[(usize, [f32; 4], usize); 4],
        acc: &mut Accounting,
    ) -> [Vec4; 4] {
        let material = ctx.triangle.material;
        let mut out = [Vec4::ZERO; 4];
        for (l, lane) in lanes.iter().enumerate() {
            let (x, y) = (quad.x + (l as u32 & 1), quad.y + (l as u32 >> 1));
            let (block, w, coarse_lane) = sources[l];
            let b = &self.blocks[block];
            let refine = b.refine;
            let key = refine.bits();
            for (k, term) in self.terms.iter_mut().enumerate() {
                let s = |i: usize| b.terms[i * self.lights + k];
                let mix =
                    |f: fn(&LightTerm) -> f32| w[0] * f(&s(0)) + w[1] * f(&s(1)) + w[2] * f(&s(2)) + w[3] * f(&s(3));
                *term = LightTerm {
                    scale: mix(|t| t.scale),
                    diffuse: mix(|t| t.diffuse),
                    specular: mix(|t| t.specular),
                };
            }
            let f = self.fine_lane();
            let lane_blocks = &mut self.fine_lanes[f].blocks;
            lane_blocks.take(Block::Resample);
            let at = points[l];
            if !refine.is_empty() {
                let inputs = lane.lighting_inputs(ctx.eye, material, at);
                ctx.env
                    .light_terms(&inputs, refine, &mut self.terms, lane_blocks, acc.log);
            }
            let lighting = ctx.env.combine(&self.terms);
            let surface = ctx.env.surface(material, &at, lane_blocks, acc.log);
            out[l] = compose(&surface, lighting, lane_blocks);
            let useful = quad.lanes & (1 << l) != 0;
            let pixel = ctx.pixel_id(x, y);
            if useful && key != 0 && pixel != u32::MAX {
                (acc.refinement)(pixel, key);
            }
            let lane = &mut self.fine_lanes[f];
            let pixel = acc.heat.pixel(|| pixel);
            (lane.useful, lane.pixel, lane.key, lane.coarse_lane) = (useful, pixel, key, coarse_lane);
        }
        out
    }

    /// [`Self::shade_quad`] of a quad none of whose lanes refines an effect: each lane's fine
    /// lane, blocks and surface reads, in lane order, as there; the resampling, the sum over
    /// lights and the compose four lanes at a time, each lane's operations as there.
    fn shade_quad_resampled(
        &mut self,
        ctx: &UnitContext,
        quad: &ShadeQuad,
        points: &[SurfacePoint; 4],
        sources: &[(usize, [f32; 4], usize); 4],
        acc: &mut Accounting,
    ) -> [Vec4; 4] {
        let material = ctx.triangle.material;
        // (A material without textures reads none: its lanes never ask for a texel.)
        if ctx.env.samples_textures(material) {
            self.texels.clear();
            ctx.env.sample_surface_maps(material, points, false, &mut self.texels);
        }
        let mut surfaces = [Surface::of_albedo(Vec4::ZERO); 4];
        for (l, surface) in surfaces.iter_mut().enumerate() {
            let (x, y) = (quad.x + (l as u32 & 1), quad.y + (l as u32 >> 1));
            let f = self.fine_lane();
            let fine = &mut self.fine_lanes[f];
            fine.blocks.take(Block::Resample);
            *surface = ctx
                .env
                .lane_surface(material, &self.texels, l, &mut fine.blocks, acc.log);
            fine.blocks.take(Block::Compose);
            let useful = quad.lanes & (1 << l) != 0;
            let pixel = acc.heat.pixel(|| ctx.pixel_id(x, y));
            (fine.useful, fine.pixel, fine.key, fine.coarse_lane) = (useful, pixel, 0, sources[l].2);
        }
        // Written out lane by lane: array `map`s here were left out of line.
        let [(b0, w0, _), (b1, w1, _), (b2, w2, _), (b3, w3, _)] = *sources;
        let weight = |i: usize| f32x4::new([w0[i], w1[i], w2[i], w3[i]]);
        let terms = [b0, b1, b2, b3].map(|b| self.blocks[b].terms.as_slice());
        let n = self.lights;
        let lighting = ctx.env.combine_quad(|k| {
            let sample = |i: usize, field: fn(&LightTerm) -> f32| {
                let at = i * n + k;
                f32x4::new([
                    field(&terms[0][at]),
                    field(&terms[1][at]),
                    field(&terms[2][at]),
                    field(&terms[3][at]),
                ])
            };
            let mix = |field: fn(&LightTerm) -> f32| {
                weight(0) * sample(0, field)
                    + weight(1) * sample(1, field)
                    + weight(2) * sample(2, field)
                    + weight(3) * sample(3, field)
            };
            [mix(|t| t.scale), mix(|t| t.diffuse), mix(|t| t.specular)]
        });
        compose_quad(&surfaces, lighting)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cost::CostHeatList;
    use crate::geometry::{FrameGeometry, Triangle};
    use crate::memory::Stream;
    use crate::scheme::StageCosts;
    use crate::shader::{ShaderEnv, ShadingLight};
    use crate::texture::MipTexture;
    use crate::vertex_stage::setup_view;
    use glam::Mat4;
    use proptest::prelude::*;
    use shadetrace_formats::results::ShadingCacheStats;
    use shadetrace_formats::{AlphaMode, LightKind, Material, MaterialMaps, SurfaceMaps, Texture, Wrap};

    /// A light term's value of every kind: ordinary, either zero, infinite and NaN.
    fn any_term() -> impl Strategy<Value = f32> {
        prop_oneof![
            -2.0f32..2.0,
            prop::sample::select(vec![0.0, -0.0, f32::INFINITY, f32::NAN])
        ]
    }

    proptest! {
        /// A quad none of whose lanes refines an effect, resampled four lanes at a time,
        /// gives each lane the colour bits, the fine lane (blocks, pixel, coarse lane) and
        /// the texture reads, in order, of the lane-by-lane fine stage: one or two lights,
        /// lanes from different blocks, a base colour texture, occlusion and emissive maps
        /// or not, and terms and weights of every kind.
        #[test]
        fn resampled_quads_are_each_lanes_own(
            lights in 1usize..3,
            terms in prop::collection::vec((any_term(), any_term(), any_term()), 16),
            weights in prop::array::uniform4(prop::array::uniform4(prop_oneof![-0.5f32..1.5, Just(0.0), Just(f32::NAN)])),
            blocks_of_lanes in prop::array::uniform4(0usize..2),
            maps in prop::array::uniform3(any::<bool>()),
            lanes in 1u8..16,
            (x, y) in (0u32..15, 0u32..11),
        ) {
            let [textured, occlusion, emissive] = maps;
            let geometry = FrameGeometry {
                positions: vec![Vec3::new(-3.0, -3.0, -2.0), Vec3::new(3.0, -3.0, -2.5), Vec3::new(0.0, 3.0, -3.0)],
                normals: vec![Vec3::Z, Vec3::new(0.3, 0.1, 1.0), Vec3::Y],
                uvs: vec![Vec2::ZERO, Vec2::new(2.0, 0.0), Vec2::new(0.0, 2.0)],
                tangents: Vec::new(),
                triangles: vec![Triangle { vertices: [0, 1, 2], material: 0, patch: u32::MAX, mesh: 0 }],
            };
            let view_projection = Mat4::perspective_rh(1.2, 32.0 / 24.0, 0.1, 10.0);
            let (setups, _) = setup_view(&geometry, &[true], view_projection, 32, 24);
            let material = Material {
                name: String::new(),
                base_color: [0.8, 0.5, 0.3, 1.0],
                base_color_texture: textured.then_some(0),
                specular_exponent: 16.0,
                specular_strength: 0.5,
                alpha: AlphaMode::Opaque,
                double_sided: true,
            };
            let texture = Texture {
                name: String::new(),
                width: 8,
                height: 8,
                wrap_u: Wrap::Repeat,
                wrap_v: Wrap::Repeat,
                rgba8: (0..8 * 8 * 4).map(|i: u32| (i.wrapping_mul(37) % 251) as u8).collect(),
            };
            let (texture, _) = MipTexture::build(&texture, 0, true);
            let maps = SurfaceMaps {
                materials: vec![MaterialMaps {
                    normal: None,
                    metallic_roughness: None,
                    occlusion: occlusion.then_some((0, 0.8)),
                    emissive: [0.2, 0.1, 0.0],
                    emissive_texture: emissive.then_some(0),
                }],
                tangents: Vec::new(),
                linear_textures: Vec::new(),
            };
            let radiance = [Vec3::new(1.0, 0.9, 0.8), Vec3::splat(0.5)];
            let lights: Vec<ShadingLight> = radiance[..lights]
                .iter()
                .map(|&r| ShadingLight::new(LightKind::Directional { direction: Vec3::NEG_Y }, r, false))
                .collect();
            let env = ShaderEnv {
                materials: std::slice::from_ref(&material),
                textures: std::slice::from_ref(&texture),
                lights: &lights,
                shadow: None,
                receivers: None,
                maps: &maps,
            };
            let ctx = crate::scheme::test_unit(&geometry, &env, &setups, view_projection, (32, 24));
            let mut job = MultirateJob::new(MultirateConfig::default(), lights.len(), 16);
            job.terms.resize(lights.len(), LightTerm::default());
            job.blocks = (0..2)
                .map(|b| {
                    let mut block = CoarseBlock::new(0, 0, 4);
                    block.terms = terms[8 * b..8 * b + 4 * lights.len()]
                        .iter()
                        .map(|&(scale, diffuse, specular)| LightTerm { scale, diffuse, specular })
                        .collect();
                    block
                })
                .collect();
            let sources = std::array::from_fn(|l| (blocks_of_lanes[l], weights[l], l));
            let quad = ShadeQuad { x: 2 * x, y: 2 * y, lanes };
            let quad_attributes = ctx.quad_attributes(quad.x, quad.y);
            let attributes = quad_attributes.lanes();
            // The textures' levels of detail found once for the quad, then by each lane.
            let points = *ctx.quad_surface_points(quad_attributes.uv, quad.x, quad.y).get();
            let own_points = points.map(|at| SurfacePoint { lods: None, ..at });
            let mut shade = |resampled: bool| {
                let (mut cost, mut heat, mut cache) = (StageCosts::default(), CostHeatList::new(false), ShadingCacheStats::default());
                let mut log = AccessLog::new();
                let mut acc = Accounting {
                    cost: &mut cost,
                    log: &mut log,
                    heat: &mut heat,
                    refinement: &mut |_, _| panic!("no lane refines"),
                    cache: &mut cache,
                    traffic: &mut |_, _| {},
                    count: &mut |_, _| {},
                };
                job.fine_used = 0;
                let colours = match resampled {
                    true => job.shade_quad_resampled(&ctx, &quad, &points, &sources, &mut acc),
                    false => job.shade_quad_lanes(&ctx, &quad, &attributes, &own_points, &sources, &mut acc),
                };
                let fine: Vec<_> = job.fine_lanes[..4]
                    .iter()
                    .map(|f| (f.blocks.clone(), f.useful, f.pixel, f.key, f.coarse_lane))
                    .collect();
                (colours.map(|c| c.to_array().map(f32::to_bits)), fine, log.expanded(0, Stream::Texture))
            };
            let (together, lane_by_lane) = (shade(true), shade(false));
            prop_assert_eq!(together.0, lane_by_lane.0);
            prop_assert_eq!(together.1, lane_by_lane.1);
            prop_assert_eq!(together.2, lane_by_lane.2);
        }
    }
}
