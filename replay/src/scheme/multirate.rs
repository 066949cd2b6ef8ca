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

mod object_space;

use glam::{Vec2, Vec3, Vec4};

use shadetrace_formats::LightKind;

use super::shading_cache::{CacheEntry, CacheKey, ShadingCache};
use super::{
    Accounting, LaneAttributes, SchemeJob, ShadeQuad, ShadingScheme, UnitContext, REFINED_DIFFUSE, REFINED_SHADOW,
    REFINED_SPECULAR,
};
use crate::cost::{BlockSet, SimdPacker};
use crate::cost_table::Block;
use crate::memory::AccessLog;
use crate::shader::{compose, Effects, LightTerm, LightingInputs};
use crate::shadow::{ReceiverHierarchy, ShadowMap};
use crate::vertex_stage::SUBPIXEL;
use object_space::{CellBlock, LaneSource};

/// Coarse shading rate (§3.1).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CoarseMode {
    Coarse2x2,
    Coarse4x4,
    Dynamic4x4,
}

impl CoarseMode {
    pub fn parse(s: &str) -> Result<CoarseMode, String> {
        match s {
            "2x2" => Ok(CoarseMode::Coarse2x2),
            "4x4" => Ok(CoarseMode::Coarse4x4),
            "dynamic" => Ok(CoarseMode::Dynamic4x4),
            _ => Err(format!("coarse mode `{s}`: expected 2x2, 4x4 or dynamic")),
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            CoarseMode::Coarse2x2 => "2x2",
            CoarseMode::Coarse4x4 => "4x4",
            CoarseMode::Dynamic4x4 => "dynamic",
        }
    }
}

/// Where a block's four coarse samples sit (§3.2).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sampling {
    /// Centres of the four coarse fragments.
    StaticCenter,
    /// Centres of the block's corner pixels.
    StaticCorner,
    /// Corner pixels of the bounding box of the block's covered pixels (the paper's choice).
    CoverageBbox,
}

impl Sampling {
    pub fn parse(s: &str) -> Result<Sampling, String> {
        match s {
            "static-center" => Ok(Sampling::StaticCenter),
            "static-corner" => Ok(Sampling::StaticCorner),
            "coverage-bbox" => Ok(Sampling::CoverageBbox),
            _ => Err(format!(
                "sampling `{s}`: expected static-center, static-corner or coverage-bbox"
            )),
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Sampling::StaticCenter => "static-center",
            Sampling::StaticCorner => "static-corner",
            Sampling::CoverageBbox => "coverage-bbox",
        }
    }
}

/// How coarse and fine work is packed into SIMD groups (§3.3).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SimdSchedule {
    /// One lane per coarse fragment runs its coarse work, then its fine fragments in turn.
    SingleThread,
    /// Coarse blocks in groups of W/4, fine quads buffered and repacked in groups of W/4.
    TwoPhase,
    /// As `TwoPhase`, fine quads sorted by their block's refinement flags before packing.
    TwoPhaseSorted,
}

impl SimdSchedule {
    pub fn parse(s: &str) -> Result<SimdSchedule, String> {
        match s {
            "single-thread" => Ok(SimdSchedule::SingleThread),
            "two-phase" => Ok(SimdSchedule::TwoPhase),
            "two-phase-sorted" => Ok(SimdSchedule::TwoPhaseSorted),
            _ => Err(format!(
                "SIMD schedule `{s}`: expected single-thread, two-phase or two-phase-sorted"
            )),
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            SimdSchedule::SingleThread => "single-thread",
            SimdSchedule::TwoPhase => "two-phase",
            SimdSchedule::TwoPhaseSorted => "two-phase-sorted",
        }
    }
}

/// Refinement thresholds; 0 refines unconditionally, infinity never refines.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Thresholds {
    /// Variation of N·L across the block's samples (§4.1).
    pub diffuse: f32,
    /// Flatness `1 - min(N_i · N_avg)` above which the reflection-cone test runs (§4.1).
    pub specular: f32,
    /// Cone enlargement λ: refine when `L · R_avg >= λ min(R_i · R_avg)`.
    pub lambda: f32,
    /// Occlusion difference across the block's samples (§4.2).
    pub shadow: f32,
    /// Edge-receiver threshold δ on the negative second depth derivative, map depth units.
    pub edge_delta: f32,
}

impl Default for Thresholds {
    fn default() -> Self {
        Thresholds {
            diffuse: 0.1,
            specular: 0.002,
            lambda: 0.9,
            shadow: 0.05,
            edge_delta: 0.002,
        }
    }
}

impl Thresholds {
    /// All refinement thresholds multiplied by `k` (λ and δ unchanged): the sweep knob.
    pub fn scaled(self, k: f32) -> Thresholds {
        // 0 x inf must stay 0 (refine everything), not NaN.
        let mul = |t: f32| if k == 0.0 || t == 0.0 { 0.0 } else { t * k };
        Thresholds {
            diffuse: mul(self.diffuse),
            specular: mul(self.specular),
            shadow: mul(self.shadow),
            ..self
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MultirateConfig {
    pub mode: CoarseMode,
    pub sampling: Sampling,
    pub small_triangle: bool,
    pub thresholds: Thresholds,
    pub schedule: SimdSchedule,
    /// The tile-pair paper's shading cache (`tile-pair-cache`); None for plain He et al.
    pub cache: Option<CacheConfig>,
}

/// Where cached coarse shading lives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CacheSpace {
    /// Screen space per view, reused across views after a reuse test (tile-pair).
    Screen,
    /// Patch space: (patch, parametric grid cell), view-independent, never across patches
    /// (AMFS as adapted in the tile-pair paper; a triangle is its own patch without ids).
    Patch,
    /// Texture space: (mesh, UV texel cell at a level from screen derivatives and normal
    /// variation), view-independent; needs a unique UV atlas (texel shading).
    Texture,
}

/// Shading-cache space and size, and the reuse shader's thresholds (screen space only).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CacheConfig {
    pub space: CacheSpace,
    pub bytes: u32,
    pub reuse: ReuseTest,
}

/// Thresholds of the tile-pair reuse shader (Algorithm 2's THRESHOLD0..2, which the paper
/// leaves open): looser reuses more and costs quality, mostly in the right view.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReuseTest {
    /// Largest position difference, as a fraction of the distance to the eye.
    pub position: f32,
    /// Largest difference of unit normals.
    pub normal: f32,
    /// Largest difference of `R · L` between the views (cross-view reuse only).
    pub r_dot_l: f32,
}

impl Default for ReuseTest {
    fn default() -> Self {
        ReuseTest {
            position: 0.01,
            normal: 0.1,
            r_dot_l: 0.05,
        }
    }
}

impl Default for MultirateConfig {
    fn default() -> Self {
        MultirateConfig {
            mode: CoarseMode::Coarse2x2,
            sampling: Sampling::CoverageBbox,
            small_triangle: true,
            thresholds: Thresholds::default(),
            schedule: SimdSchedule::TwoPhase,
            cache: None,
        }
    }
}

pub struct Multirate(pub MultirateConfig);

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
        Box::new(MultirateJob {
            config: self.0,
            lights,
            simd_width,
            coarse_packer: SimdPacker::new(simd_width, lights),
            fine_packer: SimdPacker::new(simd_width, lights),
            blocks: Vec::new(),
            coarse_lanes: Vec::new(),
            coarse_used: 0,
            fine_lanes: Vec::new(),
            fine_used: 0,
            order: Vec::new(),
            terms: vec![LightTerm::default(); lights],
            cache: self.0.cache.map(|c| (c, ShadingCache::new(c.bytes, lights))),
            sequence: 0,
            reuse_packer: SimdPacker::new(simd_width, lights),
            cells: Vec::new(),
            quad_params: Vec::new(),
            quad_levels: Vec::new(),
            sources: Vec::new(),
        })
    }
}

/// One block of four coarse fragments.
struct CoarseBlock {
    x0: u32,
    y0: u32,
    size: u32,
    /// Useful pixels, bit `(y - y0) * size + (x - x0)`.
    coverage: u64,
    /// Sample positions in pixels (continuous), order (0,0) (1,0) (0,1) (1,1).
    samples: [Vec2; 4],
    /// Per sample, per light.
    terms: Vec<LightTerm>,
    refine: Effects,
    /// Index of the block's first coarse lane (four consecutive lanes).
    first_lane: usize,
}

impl CoarseBlock {
    fn new(x0: u32, y0: u32, size: u32) -> CoarseBlock {
        CoarseBlock {
            x0,
            y0,
            size,
            coverage: 0,
            samples: [Vec2::ZERO; 4],
            terms: Vec::new(),
            refine: NONE,
            first_lane: 0,
        }
    }

    fn contains(&self, x: u32, y: u32) -> bool {
        x >= self.x0 && y >= self.y0 && x < self.x0 + self.size && y < self.y0 + self.size
    }

    /// Bilinear weights of a pixel centre between the samples (extrapolating outside them).
    fn weights(&self, x: u32, y: u32) -> [f32; 4] {
        let p = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
        let s = &self.samples;
        let u = if s[1].x > s[0].x {
            (p.x - s[0].x) / (s[1].x - s[0].x)
        } else {
            0.0
        };
        let v = if s[2].y > s[0].y {
            (p.y - s[0].y) / (s[2].y - s[0].y)
        } else {
            0.0
        };
        [(1.0 - u) * (1.0 - v), u * (1.0 - v), (1.0 - u) * v, u * v]
    }

    /// The coarse fragment (0..4) a pixel of the block belongs to.
    fn fragment_of(&self, x: u32, y: u32) -> usize {
        let half = self.size / 2;
        (((y - self.y0) / half) * 2 + (x - self.x0) / half) as usize
    }
}

/// A fine lane's work, kept for SIMD packing once the unit's quads are shaded.
struct FineLane {
    blocks: BlockSet,
    useful: bool,
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

struct MultirateJob {
    config: MultirateConfig,
    lights: usize,
    simd_width: u32,
    coarse_packer: SimdPacker,
    fine_packer: SimdPacker,
    blocks: Vec<CoarseBlock>,
    /// Lane pools, reused across units (no per-pixel allocation); `*_used` are live.
    coarse_lanes: Vec<CoarseLane>,
    coarse_used: usize,
    fine_lanes: Vec<FineLane>,
    fine_used: usize,
    order: Vec<usize>,
    terms: Vec<LightTerm>,
    cache: Option<(CacheConfig, ShadingCache)>,
    /// Tile-pair sequence of the last unit (the cache is cleared when it changes).
    sequence: u32,
    reuse_packer: SimdPacker,
    /// Object-space schemes: each block's cell, each quad's lane parameters and lattice
    /// levels, and where each quad's lanes read their terms (the blocks are cells, not
    /// screen squares).
    cells: Vec<CellBlock>,
    quad_params: Vec<[Vec2; 4]>,
    quad_levels: Vec<[i32; 4]>,
    sources: Vec<[LaneSource; 4]>,
}

const NONE: Effects = Effects {
    diffuse: false,
    specular: false,
    shadow: false,
};

fn union(a: Effects, b: Effects) -> Effects {
    Effects {
        diffuse: a.diffuse || b.diffuse,
        specular: a.specular || b.specular,
        shadow: a.shadow || b.shadow,
    }
}

fn effects_bits(e: Effects) -> u8 {
    (if e.diffuse { REFINED_DIFFUSE } else { 0 })
        | (if e.specular { REFINED_SPECULAR } else { 0 })
        | (if e.shadow { REFINED_SHADOW } else { 0 })
}

fn min_max(v: impl Iterator<Item = f32>) -> (f32, f32) {
    v.fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), x| (lo.min(x), hi.max(x)))
}

impl MultirateJob {
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

    /// Runs the coarse shader (every effect) at one point on a new coarse lane of `pixel`,
    /// writing its light terms; returns the lane.
    fn shade_coarse_fragment(
        &mut self,
        ctx: &UnitContext,
        pixel: u32,
        position: Vec3,
        normal: Vec3,
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
            },
            Effects::ALL,
            terms,
            &mut self.coarse_lanes[lane].blocks,
            log,
        );
        lane
    }

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

    /// Groups quads into blocks of `size` pixels (skipping pixels outside `within`).
    fn group(quads: &[ShadeQuad], size: u32, within: Option<&CoarseBlock>, out: &mut Vec<CoarseBlock>) {
        for quad in quads {
            for lane in 0..4u32 {
                let (x, y) = (quad.x + (lane & 1), quad.y + (lane >> 1));
                if quad.lanes & (1 << lane) == 0 || within.is_some_and(|w| !w.contains(x, y)) {
                    continue;
                }
                let (x0, y0) = (x / size * size, y / size * size);
                let index = match out.iter().position(|b| b.x0 == x0 && b.y0 == y0) {
                    Some(i) => i,
                    None => {
                        out.push(CoarseBlock::new(x0, y0, size));
                        out.len() - 1
                    }
                };
                out[index].coverage |= 1 << ((y - y0) * size + (x - x0));
            }
        }
    }

    /// Places the samples, evaluates the coarse terms and runs the predicates of one block.
    fn shade_block(&mut self, ctx: &UnitContext, b: &mut CoarseBlock, log: &mut AccessLog) {
        let cfg = self.config;
        let (mut xmin, mut ymin, mut xmax, mut ymax) = (u32::MAX, u32::MAX, 0, 0);
        for bit in 0..b.size * b.size {
            if b.coverage & (1 << bit) != 0 {
                let (x, y) = (bit % b.size, bit / b.size);
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
        for (i, &s) in b.samples.iter().enumerate() {
            let a = sample_attributes(ctx, s);
            positions[i] = a.position;
            normals[i] = a.normal;
        }
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
        let n = self.lights;
        for i in 0..4 {
            let lane = self.shade_coarse_fragment(
                ctx,
                pixels[i],
                positions[i],
                normals[i],
                &mut b.terms[i * n..(i + 1) * n],
                log,
            );
            if i == 0 {
                b.first_lane = lane;
            }
        }
        b.refine = if exact {
            NONE
        } else {
            self.predicates(ctx, b, &positions, &normals)
        };
        if let Some(keys) = &keys {
            self.store_in_cache(ctx, b, keys, &positions, &normals);
        }
    }

    /// Cache key of coarse fragment `i` of a block in `view`: the rate-`n` cell holding its
    /// sample (the rule a cross-view query uses for a projected sample too).
    fn key(b: &CoarseBlock, i: usize, view: u8) -> CacheKey {
        let n = b.size / 2;
        CacheKey {
            qx: (b.samples[i].x / n as f32).floor() as i32,
            qy: (b.samples[i].y / n as f32).floor() as i32,
            n,
            view,
            surface: 0,
        }
    }

    /// Queries the cache for the block's four fragments, own view first, then the other view
    /// (the fragment projected there, its footprint quantized along x); every hit runs the
    /// reuse shader (Algorithm 2), all in the `reuse` stage. Returns true when all four were
    /// reused: the block's terms and flags then come from the cache and its coarse shader is
    /// skipped.
    fn reuse_from_cache(
        &mut self,
        ctx: &UnitContext,
        b: &mut CoarseBlock,
        keys: &[CacheKey; 4],
        positions: &[Vec3; 4],
        normals: &[Vec3; 4],
        pixels: &[u32; 4],
    ) -> bool {
        let Some((config, mut cache)) = self.cache.take() else {
            return false;
        };
        let test = config.reuse;
        let n = self.lights;
        let other = 1 - ctx.view;
        let project = |p: Vec3, view: u8| {
            let c = ctx.view_projections[view as usize] * p.extend(1.0);
            (
                (c.x / c.w * 0.5 + 0.5) * ctx.width as f32,
                (0.5 - c.y / c.w * 0.5) * ctx.height as f32,
            )
        };
        // Footprint in the other view, along x: the only axis the disparity distorts.
        let span_here = (b.samples[1].x - b.samples[0].x).abs();
        let span_there = (project(positions[1], other).0 - project(positions[0], other).0).abs();
        let ratio = if span_here > 0.0 && span_there.is_finite() {
            span_there / span_here
        } else {
            1.0
        };
        // Power-of-two quantization, rounded so that an unchanged footprint keeps its rate.
        let n_other = 1u32 << (((b.size / 2) as f32 * ratio).max(1.0).log2().round() as u32).min(3);
        let mut reused: [Option<(Vec<LightTerm>, Effects)>; 4] = [None, None, None, None];
        for i in 0..4 {
            let lane = self.coarse_lane(pixels[i], true);
            if i == 0 {
                b.first_lane = lane;
            }
            self.coarse_lanes[lane].blocks.take(Block::CacheQuery);
            cache.counters.queries += 1;
            let normal = normals[i].normalize_or(Vec3::Y);
            let distance = (positions[i] - ctx.eye).length();
            let fits = |e: &CacheEntry| {
                (positions[i] - e.position).length() <= test.position * distance
                    && (normal - e.normal).length() <= test.normal
            };
            if let Some(e) = cache.get(&keys[i]) {
                self.coarse_lanes[lane].blocks.take(Block::ReuseTest);
                if fits(e) {
                    reused[i] = Some((e.terms.clone(), e.refine));
                    cache.counters.local_hits += 1;
                    continue;
                }
                cache.counters.rejected += 1;
            }
            let (x, y) = project(positions[i], other);
            if !(x.is_finite() && y.is_finite()) {
                continue;
            }
            let there = CacheKey {
                qx: (x / n_other as f32).floor() as i32,
                qy: (y / n_other as f32).floor() as i32,
                n: n_other,
                view: other,
                surface: 0,
            };
            if let Some(e) = cache.get(&there) {
                self.coarse_lanes[lane].blocks.take(Block::ReuseCrossView);
                let r = r_dot_l(ctx, positions[i], normal);
                let reusable =
                    |e: &CacheEntry| fits(e) && r.iter().zip(&e.r_dot_l).all(|(a, c)| (a - c).abs() <= test.r_dot_l);
                if reusable(e) {
                    let nearest = (e.terms.clone(), e.refine);
                    // The projected fragment rarely sits on a cached one: interpolate the four
                    // cached neighbours bilinearly when all are there and reusable, else take
                    // the one it falls in.
                    let (u, v) = (x / n_other as f32 - 0.5, y / n_other as f32 - 0.5);
                    let (cu, cv) = (u.floor(), v.floor());
                    let (fu, fv) = (u - cu, v - cv);
                    let corners = [(0, 0), (1, 0), (0, 1), (1, 1)].map(|(dx, dy)| CacheKey {
                        qx: cu as i32 + dx,
                        qy: cv as i32 + dy,
                        ..there
                    });
                    let weights = [(1.0 - fu) * (1.0 - fv), fu * (1.0 - fv), (1.0 - fu) * fv, fu * fv];
                    let mut mixed = vec![LightTerm::default(); n];
                    let mut refine = NONE;
                    let mut complete = true;
                    for (key, w) in corners.iter().zip(weights) {
                        match cache.get(key) {
                            Some(c) if reusable(c) => {
                                for (m, t) in mixed.iter_mut().zip(&c.terms) {
                                    m.scale += w * t.scale;
                                    m.diffuse += w * t.diffuse;
                                    m.specular += w * t.specular;
                                }
                                refine = union(refine, c.refine);
                            }
                            _ => complete = false,
                        }
                    }
                    reused[i] = Some(if complete { (mixed, refine) } else { nearest });
                    cache.counters.cross_view_hits += 1;
                    continue;
                }
                cache.counters.rejected += 1;
            }
        }
        let all = reused.iter().all(Option::is_some);
        if all {
            cache.counters.blocks_skipped += 1;
            let mut refine = NONE;
            for (i, r) in reused.into_iter().enumerate() {
                let (terms, flags) = r.expect("all four reused");
                b.terms[i * n..(i + 1) * n].copy_from_slice(&terms);
                refine = union(refine, flags);
            }
            b.refine = refine;
        } else {
            cache.counters.blocks_shaded += 1;
        }
        self.cache = Some((config, cache));
        all
    }

    /// Stores the four freshly shaded fragments of a block under their own view's keys.
    fn store_in_cache(
        &mut self,
        ctx: &UnitContext,
        b: &CoarseBlock,
        keys: &[CacheKey; 4],
        positions: &[Vec3; 4],
        normals: &[Vec3; 4],
    ) {
        let n = self.lights;
        if let Some((_, cache)) = self.cache.as_mut() {
            for i in 0..4 {
                let normal = normals[i].normalize_or(Vec3::Y);
                cache.put(
                    keys[i],
                    CacheEntry {
                        position: positions[i],
                        normal,
                        r_dot_l: r_dot_l(ctx, positions[i], normal),
                        terms: b.terms[i * n..(i + 1) * n].to_vec(),
                        refine: b.refine,
                        view: ctx.view,
                    },
                );
            }
        }
    }

    /// The refinement predicates of §4, charged to the block's four coarse lanes.
    fn predicates(
        &mut self,
        ctx: &UnitContext,
        b: &CoarseBlock,
        positions: &[Vec3; 4],
        normals: &[Vec3; 4],
    ) -> Effects {
        let t = self.config.thresholds;
        let n = self.lights;
        let term = |i: usize, l: usize| b.terms[i * n + l];
        let material = &ctx.env.materials[ctx.triangle.material as usize];
        let mut charged = vec![Block::PredicateDiffuse, Block::PredicateSpecular];

        // Directional lights: the variation of N·L itself (§4.1). Local lights: the variation
        // of their falloff-weighted Lambert term, relative to the block's mean lighting, so a
        // dim light at the edge of its range does not force refinement on its own.
        let luminance = |c: Vec3| c.dot(Vec3::new(0.2126, 0.7152, 0.0722));
        let mean_lighting = (0..4)
            .map(|i| luminance(ctx.env.combine(&b.terms[i * n..(i + 1) * n])))
            .sum::<f32>()
            / 4.0;
        let mut diffuse_variation = 0.0f32;
        for (l, light) in ctx.env.lights.iter().enumerate() {
            let variation = match light.kind {
                LightKind::Directional { .. } => {
                    let (lo, hi) = min_max((0..4).map(|i| term(i, l).diffuse));
                    hi - lo
                }
                _ => {
                    let (lo, hi) = min_max((0..4).map(|i| term(i, l).scale * term(i, l).diffuse));
                    (hi - lo) * luminance(light.radiance) / mean_lighting.max(1e-6)
                }
            };
            diffuse_variation = diffuse_variation.max(variation);
        }
        let diffuse = t.diffuse == 0.0 || diffuse_variation >= t.diffuse;
        let specular =
            t.specular == 0.0 || (material.specular_strength > 0.0 && near_highlight(ctx, t, positions, normals));

        let mut shadow = false;
        if let (Some(k), Some(map)) = (ctx.env.lights.iter().position(|l| l.shadowed), ctx.env.shadow) {
            charged.push(Block::PredicateShadow);
            if (0..4).any(|i| term(i, k).diffuse > 0.0) {
                let (lo, hi) = min_max((0..4).map(|i| term(i, k).scale));
                shadow = t.shadow == 0.0 || hi - lo >= t.shadow;
                // An infinite shadow threshold turns the whole shadow predicate off.
                if let (false, true, Some(receivers)) = (shadow, t.shadow.is_finite(), ctx.env.receivers) {
                    shadow = receives_edge(map, receivers, positions);
                }
            }
        }
        for lane in b.first_lane..b.first_lane + 4 {
            for &block in &charged {
                self.coarse_lanes[lane].blocks.take(block);
            }
        }
        Effects {
            diffuse,
            specular,
            shadow,
        }
    }

    /// Fine stage of one quad: albedo per pixel, coarse terms resampled, refined effects
    /// recomputed; returns the four lane colours.
    fn shade_quad(&mut self, ctx: &UnitContext, index: usize, quad: &ShadeQuad, acc: &mut Accounting) -> [Vec4; 4] {
        let lanes = [0u32, 1, 2, 3].map(|l| ctx.attributes(quad.x + (l & 1), quad.y + (l >> 1)));
        let duv_dx = lanes[1].uv - lanes[0].uv;
        let duv_dy = lanes[2].uv - lanes[0].uv;
        let Some(sources) = self.lane_sources(index, quad) else {
            return [Vec4::ZERO; 4];
        };
        let material = ctx.triangle.material;
        let mut out = [Vec4::ZERO; 4];
        for (l, lane) in lanes.iter().enumerate() {
            let (x, y) = (quad.x + (l as u32 & 1), quad.y + (l as u32 >> 1));
            let (block, w, coarse_lane) = sources[l];
            let b = &self.blocks[block];
            let refine = b.refine;
            let key = effects_bits(refine);
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
            if refine.any() {
                let inputs = LightingInputs {
                    position: lane.position,
                    normal: lane.normal,
                    eye: ctx.eye,
                    material,
                };
                ctx.env
                    .light_terms(&inputs, refine, &mut self.terms, lane_blocks, acc.log);
            }
            let lighting = ctx.env.combine(&self.terms);
            let albedo = ctx.env.albedo(material, lane.uv, duv_dx, duv_dy, lane_blocks, acc.log);
            out[l] = compose(albedo, lighting, lane_blocks);
            let useful = quad.lanes & (1 << l) != 0;
            let pixel = ctx.pixel_id(x, y);
            if useful && key != 0 && pixel != u32::MAX {
                (acc.refinement)(pixel, key);
            }
            let lane = &mut self.fine_lanes[f];
            (lane.useful, lane.pixel, lane.key, lane.coarse_lane) = (useful, pixel, key, coarse_lane);
        }
        out
    }

    /// Per lane of quad `index`: its block, bilinear weights and coarse lane. Screen blocks
    /// are found by position (a quad lies in one block); object-space lanes were assigned to
    /// cells, and belong to the coarse lane of their nearest corner.
    fn lane_sources(&self, index: usize, quad: &ShadeQuad) -> Option<[(usize, [f32; 4], usize); 4]> {
        if let Some(sources) = self.sources.get(index) {
            return Some(sources.map(|s| {
                let nearest = (0..4).fold(0, |m, i| if s.weights[i] > s.weights[m] { i } else { m });
                (s.block, s.weights, self.blocks[s.block].first_lane + nearest)
            }));
        }
        let block = self.blocks.iter().position(|b| b.contains(quad.x, quad.y))?;
        let b = &self.blocks[block];
        Some(std::array::from_fn(|l| {
            let (x, y) = (quad.x + (l as u32 & 1), quad.y + (l as u32 >> 1));
            let coarse_lane = if b.contains(x, y) {
                b.first_lane + b.fragment_of(x, y)
            } else {
                b.first_lane
            };
            (block, b.weights(x, y), coarse_lane)
        }))
    }

    /// Issues coarse lanes (coarse stage) and cache-query lanes (reuse stage) of a range as
    /// SIMD groups, each stage packed separately.
    fn issue_coarse(&mut self, lanes: std::ops::Range<usize>, acc: &mut Accounting) {
        for lane in &self.coarse_lanes[lanes] {
            if lane.reuse {
                self.reuse_packer
                    .lane(&lane.blocks, true, lane.pixel, &mut acc.cost.reuse, acc.heat);
            } else {
                self.coarse_packer
                    .lane(&lane.blocks, true, lane.pixel, &mut acc.cost.coarse, acc.heat);
            }
        }
        self.coarse_packer.flush(&mut acc.cost.coarse, acc.heat);
        self.reuse_packer.flush(&mut acc.cost.reuse, acc.heat);
    }

    /// Issues the unit's coarse and fine lanes as SIMD groups under the configured schedule.
    fn issue(&mut self, acc: &mut Accounting) {
        match self.config.schedule {
            SimdSchedule::TwoPhase | SimdSchedule::TwoPhaseSorted => {
                self.issue_coarse(0..self.coarse_used, acc);
                self.order.clear();
                self.order.extend(0..self.fine_used / 4);
                if self.config.schedule == SimdSchedule::TwoPhaseSorted {
                    let lanes = &self.fine_lanes;
                    self.order.sort_by_key(|&q| lanes[4 * q].key);
                }
                for &q in &self.order {
                    for lane in &self.fine_lanes[4 * q..4 * q + 4] {
                        self.fine_packer
                            .lane(&lane.blocks, lane.useful, lane.pixel, &mut acc.cost.fine, acc.heat);
                    }
                }
                self.fine_packer.flush(&mut acc.cost.fine, acc.heat);
            }
            SimdSchedule::SingleThread => self.issue_single_thread(acc),
        }
    }

    /// Single thread of control: W coarse fragments per group; each lane then loops over
    /// its own covered pixels, so the group issues as many fine iterations as its busiest
    /// lane has pixels, each the union of the blocks of the lanes still looping.
    fn issue_single_thread(&mut self, acc: &mut Accounting) {
        let w = self.simd_width.max(1) as usize;
        let mut per_lane: Vec<Vec<usize>> = vec![Vec::new(); self.coarse_used];
        for (i, f) in self.fine_lanes[..self.fine_used].iter().enumerate() {
            if f.useful {
                per_lane[f.coarse_lane].push(i);
            }
        }
        // Each group and each fine iteration is issued as one (possibly partial) SIMD group.
        for start in (0..self.coarse_used).step_by(w) {
            let group = start..(start + w).min(self.coarse_used);
            self.issue_coarse(group.clone(), acc);
            let iterations = per_lane[group.clone()].iter().map(Vec::len).max().unwrap_or(0);
            for it in 0..iterations {
                for fragments in &per_lane[group.clone()] {
                    if let Some(&f) = fragments.get(it) {
                        let lane = &self.fine_lanes[f];
                        self.fine_packer
                            .lane(&lane.blocks, true, lane.pixel, &mut acc.cost.fine, acc.heat);
                    }
                }
                self.fine_packer.flush(&mut acc.cost.fine, acc.heat);
            }
        }
    }
}

/// Fixed-point screen position of a coarse sample (pixel coordinates).
fn sample_fixed(s: Vec2) -> (i64, i64) {
    (
        (s.x * SUBPIXEL as f32).round() as i64,
        (s.y * SUBPIXEL as f32).round() as i64,
    )
}

/// Interpolated attributes at a coarse sample.
fn sample_attributes(ctx: &UnitContext, s: Vec2) -> LaneAttributes {
    let (px, py) = sample_fixed(s);
    ctx.attributes_at(px, py)
}

/// Per light, the cosine between the reflected view direction and the light direction at a
/// point seen from this unit's eye (the cross-view check of Algorithm 2).
fn r_dot_l(ctx: &UnitContext, position: Vec3, normal: Vec3) -> Vec<f32> {
    let v = (ctx.eye - position).normalize_or(Vec3::Z);
    let r = (2.0 * normal.dot(v) * normal - v).normalize_or(normal);
    ctx.env
        .lights
        .iter()
        .map(|light| {
            let l = match light.kind {
                LightKind::Directional { direction } => -direction.normalize_or(Vec3::NEG_Y),
                LightKind::Point { position: p, .. } | LightKind::Spot { position: p, .. } => {
                    (p - position).normalize_or(Vec3::Y)
                }
            };
            r.dot(l)
        })
        .collect()
}

/// Flatness test, then whether some light lies in the block's enlarged reflection cone
/// (`L · R_avg >= λ min(R_i · R_avg)`).
fn near_highlight(ctx: &UnitContext, t: Thresholds, positions: &[Vec3; 4], normals: &[Vec3; 4]) -> bool {
    let n: [Vec3; 4] = normals.map(|n| n.normalize_or(Vec3::Y));
    let n_avg = (n[0] + n[1] + n[2] + n[3]).normalize_or(n[0]);
    let flatness = 1.0 - n.iter().map(|v| v.dot(n_avg)).fold(f32::INFINITY, f32::min);
    if flatness < t.specular || flatness.is_nan() {
        return false;
    }
    let r: [Vec3; 4] = std::array::from_fn(|i| {
        let v = (ctx.eye - positions[i]).normalize_or(Vec3::Z);
        (2.0 * n[i].dot(v) * n[i] - v).normalize_or(n[i])
    });
    let r_avg = (r[0] + r[1] + r[2] + r[3]).normalize_or(r[0]);
    let cone = r.iter().map(|v| v.dot(r_avg)).fold(f32::INFINITY, f32::min);
    let center = (positions[0] + positions[1] + positions[2] + positions[3]) * 0.25;
    ctx.env.lights.iter().any(|light| {
        let l = match light.kind {
            LightKind::Directional { direction } => -direction.normalize_or(Vec3::NEG_Y),
            LightKind::Point { position, .. } | LightKind::Spot { position, .. } => {
                (position - center).normalize_or(Vec3::Y)
            }
        };
        l.dot(r_avg) >= t.lambda * cone
    })
}

/// Whether a shadow edge may fall inside the block: its light-space depth range overlaps
/// the receivers under its (PCF-widened) shadow-map footprint, unless that footprint lies
/// within 2x2 texels, where every lookup reads the same texels (§4.2).
fn receives_edge(map: &ShadowMap, receivers: &ReceiverHierarchy, positions: &[Vec3; 4]) -> bool {
    let mut p = [(0.0f32, 0.0f32, 0.0f32); 4];
    for (i, &pos) in positions.iter().enumerate() {
        match map.project(pos) {
            Some(q) => p[i] = q,
            None => return false,
        }
    }
    let (tx0, tx1) = min_max(p.iter().map(|q| q.0.floor()));
    let (ty0, ty1) = min_max(p.iter().map(|q| q.1.floor()));
    if tx1 - tx0 <= 1.0 && ty1 - ty0 <= 1.0 {
        return false;
    }
    let (rmin, rmax) = receivers.range(tx0 as i64 - 2, ty0 as i64 - 2, tx1 as i64 + 2, ty1 as i64 + 2);
    let (zmin, zmax) = min_max(p.iter().map(|q| q.2));
    rmin <= zmax && rmax >= zmin
}

impl SchemeJob for MultirateJob {
    fn shade_unit(
        &mut self,
        ctx: &UnitContext,
        quads: &[ShadeQuad],
        colors: &mut Vec<[Vec4; 4]>,
        acc: &mut Accounting,
    ) {
        self.coarse_used = 0;
        self.fine_used = 0;
        if ctx.sequence != self.sequence {
            self.sequence = ctx.sequence;
            if let Some((_, cache)) = self.cache.as_mut() {
                cache.clear();
            }
        }
        self.terms.resize(self.lights, LightTerm::default());
        self.sources.clear();
        match self.config.cache.map(|c| c.space) {
            Some(space @ (CacheSpace::Patch | CacheSpace::Texture)) => {
                self.shade_object_space(ctx, quads, space, acc.log)
            }
            _ => self.shade_screen_space(ctx, quads, acc.log),
        }
        for (index, quad) in quads.iter().enumerate() {
            colors.push(self.shade_quad(ctx, index, quad, acc));
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
        blocks.clear();
        Self::group(quads, first, None, &mut blocks);
        for b in &mut blocks {
            self.shade_block(ctx, b, log);
        }
        if self.config.mode == CoarseMode::Dynamic4x4 {
            // Refined 4x4 blocks are re-shaded at 2x2; their first coarse pass still counts.
            let mut kept = Vec::with_capacity(blocks.len());
            for b in blocks.drain(..) {
                if !b.refine.any() {
                    kept.push(b);
                    continue;
                }
                let mut finer = Vec::new();
                Self::group(quads, 4, Some(&b), &mut finer);
                for mut sub in finer {
                    self.shade_block(ctx, &mut sub, log);
                    kept.push(sub);
                }
            }
            blocks = kept;
        }
        self.blocks = blocks;
    }
}
