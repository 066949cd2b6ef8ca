//! Hybrid reprojection stereo (Wißmann et al. 2020). The left view is rendered as `visbuffer`
//! renders it (a deferred pipeline with full-precision inputs: its pixels are `forward`'s),
//! and the right view is made from it by a view pass:
//!
//! 1. the adaptive warping grid ([`grid`]) over the left image, reduced per cell to its
//!    depth bounds (a `DepthBounds` lane per pixel, a `TessFactor` lane per cell);
//! 2. its vertices displaced by the left depth and carried into the right view by the
//!    reprojection matrix (`GridVertex` lanes), its kept triangles rasterized there by the
//!    shared vertex stage and rasterizer (same snapping and fill rules, one sample per pixel,
//!    depth-tested), each fragment taking the left image's colour by a bilinear lookup at 8
//!    sub-texel bits (`WarpFragment` lanes): shading is carried, not recomputed, so the
//!    right view keeps the left view's view-dependent specular (the paper's Lambertian
//!    assumption);
//! 3. the pixels no kept grid triangle covers are the holes, the view pass's work list:
//!    - `repro-rt` traces one primary ray per hole through a BVH of the frame's triangles
//!      (built when there are holes, `BvhBuild` lanes; traversal counted per node and
//!      triangle, SIMD groups running as long as their longest ray; `bvh` traffic) and shades
//!      the hit with the raster path's shader (shadow map included), texture LOD from a ray
//!      cone (Akenine-Möller et al. 2019);
//!    - `repro-reraster` draws the right view again (all geometry: vertex, binning and
//!      raster work counted like any geometry pass) and shades the hole pixels only, as a
//!      stencil would let through: one visibility write per hole pixel and, per distinct
//!      triangle of the pixel, the visibility buffer's shading (`forward`'s pixels).
//!
//! Costs: `warp` (reduction, tessellation factors, vertices, fragments), `bvh_build`,
//! `traversal` and `ray` (hit shading) for `repro-rt`; `visibility` and `fine` for the
//! re-rasterized holes. MSAA: the warp and the rays work per pixel (a reprojected or traced
//! pixel has one colour); re-rasterized holes resolve their samples.

mod grid;
mod trace;

use std::sync::Arc;

use glam::{Vec2, Vec3, Vec4};
use shadetrace_formats::results::{ReprojectionStats, ShadingCost, SpecularError, Traffic, VertexStats};

use super::deferred::{refetched_surface, VISIBILITY};
use super::distinct_triangles;
use super::{
    Accounting, Deferred, FinishedFrame, Lists, Passes, SchemeJob, SchemeStats, ShadeQuad, ShadingScheme, Target,
    TileContext, UnitContext, ViewContext, ViewPass, VisibleQuads, WorkListState,
};
use crate::cost::{dense_lanes, BlockSet, SimdPacker, FINE};
use crate::cost_table::Block;
use crate::memory::{AccessLog, RenderTarget, Stream, LINE_BYTES};
use crate::pipeline::{SampleBuffer, CLEAR_COLOR, NO_PRIMITIVE, VERTEX_BYTES};
use crate::raster::{pixel_center, rasterize, Rect};
use crate::shader::{compose, LightingInputs, SurfacePoint};
use crate::srgb::linear_to_srgb8;
use crate::vertex_stage::setup_clip_triangle;
use grid::{GridParams, SourceImage};
use trace::{primary_ray, RayScene};

/// Cost stages of the view pass.
pub const WARP: &str = "warp";
pub const BVH_BUILD: &str = "bvh_build";
pub const TRAVERSAL: &str = "traversal";
pub const RAY: &str = "ray";

/// Counters the view pass keeps for [`ShadingScheme::finish_frame`].
const CELLS: &str = "repro_cells";
const CELLS_OVER: &str = "repro_cells_over";
const CELLS_TESSELLATED: &str = "repro_cells_tessellated";
const VERTICES: &str = "repro_vertices";
const TRIANGLES: &str = "repro_triangles";
const DISCARDED: &str = "repro_discarded";
const REPROJECTED: &str = "repro_reprojected";
const HOLES: &str = "repro_holes";
const RAYS: &str = "repro_rays";
const HITS: &str = "repro_hits";
const NODE_VISITS: &str = "repro_node_visits";
const TRIANGLE_TESTS: &str = "repro_triangle_tests";
const BVH_NODES: &str = "repro_bvh_nodes";
const BVH_BYTES: &str = "repro_bvh_bytes";
/// Of the one job that makes the view (so the "sum" of the maximum is the maximum).
const SPECULAR_SUM: &str = "repro_specular_sum";
const SPECULAR_MAX: &str = "repro_specular_max";
const SPECULAR_PIXELS: &str = "repro_specular_pixels";

/// Warped vertices' NDC depth stays below the far plane, so that the background (cleared
/// to depth 1) is warped too instead of being clipped away by rounding.
const MAX_WARP_DEPTH: f32 = 1.0 - f32::EPSILON;

/// How the holes of the reprojected view are filled.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HoleFill {
    /// One primary ray per hole pixel (`repro-rt`).
    RayTrace,
    /// The whole geometry drawn again, hole pixels shaded (`repro-reraster`).
    ReRaster,
}

pub struct Reprojection {
    pub fill: HoleFill,
    /// Grid cell edge in pixels.
    pub cell: u32,
    /// θΔ in minutes of arc.
    pub threshold_arcmin: f32,
    /// Measure the specular-only error (`--specular-error`).
    pub specular_error: bool,
}

impl ShadingScheme for Reprojection {
    fn name(&self) -> &'static str {
        match self.fill {
            HoleFill::RayTrace => "repro-rt",
            HoleFill::ReRaster => "repro-reraster",
        }
    }

    fn passes(&self) -> Passes {
        Passes::ShadeAfterVisibility
    }

    fn view_pass(&self) -> Option<ViewPass> {
        Some(ViewPass {
            from: 0,
            to: 1,
            draw_to: self.fill == HoleFill::ReRaster,
        })
    }

    fn begin_job(&self, lights: usize, simd_width: u32) -> Box<dyn SchemeJob> {
        let left = Deferred {
            target: Target::Visibility,
            lists: Lists::None,
        };
        Box::new(ReprojectionJob {
            fill: self.fill,
            cell: self.cell,
            threshold: (self.threshold_arcmin / 60.0).to_radians(),
            specular_error: self.specular_error,
            left: left.begin_job(lights, simd_width),
            simd_width,
            packer: SimdPacker::new(simd_width, lights),
            blocks: BlockSet::new(lights),
            shaded: Vec::new(),
        })
    }

    fn finish_frame(&self, frame: &FinishedFrame, _: [&mut ShadingCost; 2], _: &mut Traffic) -> SchemeStats {
        let count = |name: &str| frame.counters.get(name).copied().unwrap_or(0);
        SchemeStats {
            reprojection: Some(ReprojectionStats {
                grid_cells: count(CELLS),
                cells_over_threshold: count(CELLS_OVER),
                cells_tessellated: count(CELLS_TESSELLATED),
                grid_vertices: count(VERTICES),
                grid_triangles: count(TRIANGLES),
                grid_triangles_discarded: count(DISCARDED),
                reprojected_pixels: count(REPROJECTED),
                hole_pixels: count(HOLES),
                rays: count(RAYS),
                ray_hits: count(HITS),
                node_visits: count(NODE_VISITS),
                triangle_tests: count(TRIANGLE_TESTS),
                bvh_nodes: count(BVH_NODES),
                bvh_bytes: count(BVH_BYTES),
                specular_error: self.specular_error.then(|| SpecularError {
                    sum: count(SPECULAR_SUM),
                    max: count(SPECULAR_MAX),
                    pixels: count(SPECULAR_PIXELS),
                }),
            }),
            ..SchemeStats::default()
        }
    }
}

struct ReprojectionJob {
    fill: HoleFill,
    cell: u32,
    /// θΔ in radians.
    threshold: f32,
    specular_error: bool,
    /// The left view's renderer.
    left: Box<dyn SchemeJob>,
    simd_width: u32,
    packer: SimdPacker,
    blocks: BlockSet,
    /// The current pixel's distinct triangles and their sample masks.
    shaded: Vec<(u32, u32)>,
}

impl SchemeJob for ReprojectionJob {
    /// Never called: the scheme shades after visibility.
    fn shade_unit(&mut self, _: &UnitContext, _: &[ShadeQuad], _: &mut Vec<[Vec4; 4]>, _: &mut Accounting) {}

    /// The left view writes its visibility buffer; the right one (drawn for re-rasterized
    /// holes only) writes only where the stencil will let it, charged by the view pass.
    fn visible_quads(&mut self, ctx: &UnitContext, visible: &VisibleQuads, acc: &mut Accounting) {
        if ctx.view == 0 {
            self.left.visible_quads(ctx, visible, acc);
        }
    }

    fn shade_tile(&mut self, ctx: &TileContext, tile: &mut SampleBuffer, acc: &mut Accounting) {
        if tile.view == 0 {
            self.left.shade_tile(ctx, tile, acc);
        }
    }

    fn derive_view(
        &mut self,
        ctx: &ViewContext,
        from: &SampleBuffer,
        to: &mut SampleBuffer,
        work: &mut Vec<u32>,
        acc: &mut Accounting,
    ) -> Option<WorkListState> {
        let source = SourceImage::new(from);
        let params = GridParams {
            cell: self.cell,
            threshold: self.threshold,
            ipd: (ctx.eyes[0] - ctx.eyes[1]).length(),
            depth_range: ctx.depth_range,
        };
        let grid = grid::build(&source, &params);
        let (width, height) = (ctx.width, ctx.height);
        // The reduction reads every left depth, one lane per pixel; then a lane per cell and
        // per vertex.
        for y in 0..height {
            for x in 0..width {
                acc.log
                    .touch(Stream::Depth, ctx.layout.depth_line(from.view, x, y), false);
            }
        }
        self.lanes(WARP, Block::DepthBounds, u64::from(width) * u64::from(height), acc);
        self.lanes(WARP, Block::TessFactor, grid.cells, acc);
        self.lanes(WARP, Block::GridVertex, grid.vertices.len() as u64, acc);
        for (name, n) in [
            (CELLS, grid.cells),
            (CELLS_OVER, grid.cells_over_threshold),
            (CELLS_TESSELLATED, grid.cells_tessellated),
            (VERTICES, grid.vertices.len() as u64),
            (TRIANGLES, grid.triangles.len() as u64 + grid.triangles_discarded),
            (DISCARDED, grid.triangles_discarded),
        ] {
            (acc.count)(name, n);
        }
        let warped = self.warp(ctx, &source, &grid, acc);
        if self.specular_error {
            let e = specular_error(ctx, &warped);
            for (name, n) in [
                (SPECULAR_SUM, e.sum),
                (SPECULAR_MAX, e.max),
                (SPECULAR_PIXELS, e.pixels),
            ] {
                (acc.count)(name, n);
            }
        }
        let samples = to.samples;
        let mut reprojected = 0;
        for (p, pixel) in warped.iter().enumerate() {
            match pixel {
                Some((colour, prim, _)) => {
                    reprojected += 1;
                    to.color[p * samples..(p + 1) * samples].fill(*colour);
                    if self.fill == HoleFill::RayTrace {
                        to.prim[p * samples..(p + 1) * samples].fill(*prim);
                    }
                }
                None => work.push(p as u32),
            }
        }
        (acc.count)(REPROJECTED, reprojected);
        (acc.count)(HOLES, work.len() as u64);
        if work.is_empty() {
            return None;
        }
        match self.fill {
            HoleFill::RayTrace => {
                let scene = RayScene::build(ctx.geometry, ctx.env);
                self.lanes(BVH_BUILD, Block::BvhBuild, ctx.geometry.triangles.len() as u64, acc);
                (acc.count)(BVH_NODES, scene.nodes());
                (acc.count)(BVH_BYTES, scene.bytes());
                Some(Arc::new(scene))
            }
            HoleFill::ReRaster => {
                // The stencil lets the geometry pass write the holes' visibility only.
                for &p in work.iter() {
                    let (x, y) = (p % width, p / width);
                    let line = ctx.layout.line(RenderTarget::Visibility, ctx.view, x, y);
                    acc.log.touch(Stream::Visibility, line, true);
                }
                self.lanes(VISIBILITY, Block::VisibilityWrite, work.len() as u64, acc);
                None
            }
        }
    }

    fn shade_pixels(
        &mut self,
        ctx: &ViewContext,
        view: &SampleBuffer,
        pixels: &[u32],
        shared: Option<&WorkListState>,
        colors: &mut Vec<Vec4>,
        acc: &mut Accounting,
    ) {
        match (self.fill, shared.and_then(|s| s.downcast_ref::<RayScene>())) {
            (HoleFill::RayTrace, Some(scene)) => self.trace(ctx, scene, pixels, colors, acc),
            (HoleFill::RayTrace, None) => colors.extend(pixels.iter().map(|_| CLEAR_COLOR)),
            (HoleFill::ReRaster, _) => {
                for &p in pixels {
                    let colour = self.reshade(ctx, view, p, acc);
                    colors.push(colour);
                }
                self.packer.flush(acc.cost.stage_mut(FINE), acc.heat);
            }
        }
    }
}

impl ReprojectionJob {
    /// `n` lanes of `block` in stage `stage`, packed densely (no heat: per-pixel work is
    /// shown by the fragments' and rays' lanes).
    fn lanes(&self, stage: &'static str, block: Block, n: u64, acc: &mut Accounting) {
        acc.cost.stage_mut(stage).add(&dense_lanes(block, n, self.simd_width));
    }

    /// Rasterizes the kept grid triangles into the right view: per pixel the nearest
    /// fragment's colour (bilinear from the left image) and the left primitive it came
    /// from, or None for a hole.
    fn warp(
        &mut self,
        ctx: &ViewContext,
        source: &SourceImage,
        grid: &grid::Grid,
        acc: &mut Accounting,
    ) -> Vec<Option<(Vec4, u32, Vec2)>> {
        let (width, height) = (ctx.width, ctx.height);
        let pixels = (width * height) as usize;
        let mut depth = vec![f32::INFINITY; pixels];
        let mut out: Vec<Option<(Vec4, u32, Vec2)>> = vec![None; pixels];
        // The reprojection matrix: the left view's inverse view-projection, then the right's.
        let reproject = ctx.view_projections[1].as_dmat4() * ctx.view_projections[0].as_dmat4().inverse();
        let clip: Vec<Vec4> = grid
            .vertices
            .iter()
            .map(|v| {
                let ndc = glam::DVec4::new(
                    2.0 * f64::from(v.source.x) / f64::from(width) - 1.0,
                    1.0 - 2.0 * f64::from(v.source.y) / f64::from(height),
                    f64::from(v.depth.min(MAX_WARP_DEPTH)),
                    1.0,
                );
                (reproject * ndc).as_vec4()
            })
            .collect();
        let rect = Rect {
            x0: 0,
            y0: 0,
            x1: width,
            y1: height,
        };
        let stage = acc.cost.stage_mut(WARP);
        self.blocks.clear();
        self.blocks.take(Block::WarpFragment);
        let mut setups = Vec::new();
        let mut stats = VertexStats::default();
        for (k, tri) in grid.triangles.iter().enumerate() {
            setups.clear();
            setup_clip_triangle(
                k as u32,
                tri.map(|v| clip[v as usize]),
                true,
                (width, height),
                &mut setups,
                &mut stats,
            );
            let sources = tri.map(|v| grid.vertices[v as usize].source);
            for setup in &setups {
                rasterize(setup, rect, &[[8, 8]], |q| {
                    for lane in 0..4u32 {
                        let covered = q.coverage >> lane & 1 != 0;
                        let (x, y) = (q.x + (lane & 1), q.y + (lane >> 1));
                        self.packer
                            .lane(&self.blocks, covered, pixel_id(ctx, x, y), stage, acc.heat);
                        if !covered {
                            continue;
                        }
                        let (px, py) = pixel_center(x, y);
                        let e = setup.edges(px, py);
                        let z = setup.depth(e);
                        let p = (y * width + x) as usize;
                        acc.log
                            .touch(Stream::Depth, ctx.layout.depth_line(ctx.view, x, y), true);
                        if z >= depth[p] {
                            continue;
                        }
                        depth[p] = z;
                        let b = setup.original_bary(e);
                        let at = sources[0] * b.x + sources[1] * b.y + sources[2] * b.z;
                        let (colour, prim) = bilinear(source, at, ctx, acc.log);
                        out[p] = Some((colour, prim, at));
                        acc.log
                            .touch(Stream::Color, ctx.layout.color_line(ctx.view, x, y), true);
                    }
                });
            }
        }
        self.packer.flush(stage, acc.heat);
        out
    }

    /// Traces the holes `pixels`, one ray each, in SIMD groups that run until their longest
    /// traversal ends.
    fn trace(
        &mut self,
        ctx: &ViewContext,
        scene: &RayScene,
        pixels: &[u32],
        colors: &mut Vec<Vec4>,
        acc: &mut Accounting,
    ) {
        let size = (ctx.width, ctx.height);
        let view_projection = ctx.view_projections[ctx.view as usize];
        // The cone's spread: the angle between two vertically adjacent pixels' rays.
        let (cx, cy) = ((ctx.width / 2) as f32, (ctx.height / 2) as f32);
        let spread = primary_ray(view_projection, size, cx, cy)
            .1
            .angle_between(primary_ray(view_projection, size, cx, cy + 1.0).1);
        let (node, test) = (Block::NodeVisit.cost(), Block::TriangleTest.cost());
        let mut hits = 0u64;
        let (mut visits, mut tests) = (0u64, 0u64);
        for group in pixels.chunks(self.simd_width.max(1) as usize) {
            let (mut most_nodes, mut most_tests) = (0u32, 0u32);
            let mut lanes = Vec::with_capacity(group.len());
            for &p in group {
                let (x, y) = (p % ctx.width, p / ctx.width);
                let (origin, dir) = primary_ray(view_projection, size, x as f32, y as f32);
                let (hit, work) = scene.trace(origin, dir, acc.log);
                most_nodes = most_nodes.max(work.nodes);
                most_tests = most_tests.max(work.tests);
                visits += u64::from(work.nodes);
                tests += u64::from(work.tests);
                self.blocks.clear();
                self.blocks.take(Block::RayGen);
                let colour = match hit {
                    Some(hit) => {
                        hits += 1;
                        self.shade_hit(ctx, hit, dir, spread, acc)
                    }
                    None => CLEAR_COLOR,
                };
                self.packer.lane(
                    &self.blocks,
                    true,
                    pixel_id(ctx, x, y),
                    acc.cost.stage_mut(RAY),
                    acc.heat,
                );
                colors.push(colour);
                lanes.push(pixel_id(ctx, x, y));
            }
            // The group's traversal: as long as its longest ray's.
            let issued = u64::from(most_nodes) * u64::from(node.alu) + u64::from(most_tests) * u64::from(test.alu);
            let stage = acc.cost.stage_mut(TRAVERSAL);
            stage.groups += 1;
            stage.alu += issued;
            stage.useful_lanes += group.len() as u64;
            for pixel in lanes {
                acc.heat.add(pixel, issued as u32);
            }
        }
        let stage = acc.cost.stage_mut(TRAVERSAL);
        stage.useful_lane_alu += visits * u64::from(node.alu) + tests * u64::from(test.alu);
        self.packer.flush(acc.cost.stage_mut(RAY), acc.heat);
        for (name, n) in [
            (RAYS, pixels.len() as u64),
            (HITS, hits),
            (NODE_VISITS, visits),
            (TRIANGLE_TESTS, tests),
        ] {
            (acc.count)(name, n);
        }
    }

    /// The hit's colour: its attributes from the barycentrics, then the raster path's
    /// shader, the texture LOD from the ray cone.
    fn shade_hit(&mut self, ctx: &ViewContext, hit: trace::Hit, dir: Vec3, spread: f32, acc: &mut Accounting) -> Vec4 {
        let g = ctx.geometry;
        let triangle = &g.triangles[hit.prim as usize];
        let [i, j, k] = triangle.vertices.map(|v| v as usize);
        for v in [i, j, k] {
            acc.log
                .touch(Stream::TriangleData, v as u64 * VERTEX_BYTES / LINE_BYTES, false);
        }
        let w = 1.0 - hit.u - hit.v;
        let position = g.positions[i] * w + g.positions[j] * hit.u + g.positions[k] * hit.v;
        let normal = g.normals[i] * w + g.normals[j] * hit.u + g.normals[k] * hit.v;
        let uv = g.uvs[i] * w + g.uvs[j] * hit.u + g.uvs[k] * hit.v;
        self.blocks.take(Block::HitAttributes);
        self.blocks.take(Block::RayCone);
        // Ray cone: the footprint's width at the hit, widened by the incidence, in uv units
        // by the triangle's uv-to-world area ratio (Δ0 of Eq. 4).
        let (e1, e2) = (g.positions[j] - g.positions[i], g.positions[k] - g.positions[i]);
        let world_area = e1.cross(e2).length();
        let (t1, t2) = (g.uvs[j] - g.uvs[i], g.uvs[k] - g.uvs[i]);
        let uv_area = (t1.x * t2.y - t1.y * t2.x).abs();
        let incidence = (e1.cross(e2).normalize_or_zero().dot(dir)).abs().max(1e-3);
        let footprint = spread * (position - ctx.eye).length() / incidence;
        let scale = if world_area > 0.0 {
            footprint * (uv_area / world_area).sqrt()
        } else {
            0.0
        };
        let material = triangle.material;
        let at = SurfacePoint {
            uv,
            duv_dx: Vec2::new(scale, 0.0),
            duv_dy: Vec2::new(0.0, scale),
            tangent: g.tangent(triangle.vertices, Vec3::new(w, hit.u, hit.v)),
            lods: None,
        };
        let surface = ctx.env.surface(material, &at, &mut self.blocks, acc.log);
        let inputs = LightingInputs {
            position,
            normal,
            eye: ctx.eye,
            material,
            surface: at,
        };
        let lighting = ctx.env.lighting(&inputs, &mut self.blocks, acc.log);
        compose(&surface, lighting, &mut self.blocks)
    }

    /// A hole pixel re-rasterized: each distinct triangle among its samples shaded once as
    /// the visibility buffer shades it, the samples averaged.
    fn reshade(&mut self, ctx: &ViewContext, view: &SampleBuffer, p: u32, acc: &mut Accounting) -> Vec4 {
        let (x, y) = (p % ctx.width, p / ctx.width);
        let samples = view.samples;
        let first = p as usize * samples;
        let mut shaded = std::mem::take(&mut self.shaded);
        distinct_triangles(&view.tri[first..first + samples], &mut shaded);
        // Weighted by coverage, after the background's share.
        let covered: u32 = shaded.iter().map(|&(_, mask)| mask.count_ones()).sum();
        let mut sum = CLEAR_COLOR * (samples as u32 - covered) as f32;
        for &(tri, mask) in &shaded {
            let setup = &ctx.setups[tri as usize];
            let unit = UnitContext {
                view_ctx: *ctx,
                setup,
                triangle: &ctx.geometry.triangles[setup.prim as usize],
            };
            self.blocks.clear();
            let material = unit.triangle.material;
            let own = unit.attributes(x, y);
            let (surface, at) = refetched_surface(&unit, &own, (x, y), &mut self.blocks, acc.log);
            let inputs = LightingInputs {
                position: own.position,
                normal: own.normal,
                eye: ctx.eye,
                material,
                surface: at,
            };
            let lighting = ctx.env.lighting(&inputs, &mut self.blocks, acc.log);
            let colour = compose(&surface, lighting, &mut self.blocks);
            self.packer.lane(
                &self.blocks,
                true,
                pixel_id(ctx, x, y),
                acc.cost.stage_mut(FINE),
                acc.heat,
            );
            sum += colour * mask.count_ones() as f32;
        }
        self.shaded = shaded;
        acc.log
            .touch(Stream::Color, ctx.layout.color_line(ctx.view, x, y), true);
        if covered == 0 {
            CLEAR_COLOR
        } else {
            sum / samples as f32
        }
    }
}

/// The left image at source point `at` (pixels), bilinear at 8 sub-texel bits as texture
/// units filter, clamped to the edge; with the source pixel's primitive nearest to it.
fn bilinear(source: &SourceImage, at: Vec2, ctx: &ViewContext, log: &mut AccessLog) -> (Vec4, u32) {
    let quantize = |c: f32| (c * 256.0).round() / 256.0;
    let (x, y) = (quantize(at.x - 0.5), quantize(at.y - 0.5));
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let clamp = |v: f32, n: u32| (v.max(0.0) as u32).min(n - 1);
    let (w, h) = (source.width, source.height);
    let (xa, xb) = (clamp(x0, w), clamp(x0 + 1.0, w));
    let (ya, yb) = (clamp(y0, h), clamp(y0 + 1.0, h));
    let mut texel = |x: u32, y: u32| {
        log.touch(Stream::Color, ctx.layout.color_line(0, x, y), false);
        source.color[(y * w + x) as usize]
    };
    let top = texel(xa, ya) * (1.0 - fx) + texel(xb, ya) * fx;
    let bottom = texel(xa, yb) * (1.0 - fx) + texel(xb, yb) * fx;
    let colour = if fy == 0.0 { top } else { top * (1.0 - fy) + bottom * fy };
    let near = |f: f32, a: u32, b: u32| if f < 0.5 { a } else { b };
    let prim = source.prim[(near(fy, ya, yb) * w + near(fx, xa, xb)) as usize];
    (colour, prim)
}

/// The view-dependent error of the carried shading: each reprojected pixel's surface (the
/// left view's primitive, where the left eye's ray through its source point meets it)
/// shaded from both eyes with the same albedo, compared in 8-bit sRGB. A measurement: its
/// instructions and accesses are not counted.
fn specular_error(ctx: &ViewContext, warped: &[Option<(Vec4, u32, Vec2)>]) -> SpecularError {
    let mut log = AccessLog::new();
    let mut blocks = BlockSet::new(ctx.env.lights.len());
    let g = ctx.geometry;
    let mut error = SpecularError::default();
    let surfaces = warped.iter().flatten().filter(|w| w.1 != NO_PRIMITIVE);
    for (n, &(_, prim, at)) in surfaces.enumerate() {
        if n % 4096 == 0 {
            log.clear();
        }
        let (origin, dir) = trace::ray_through(ctx.view_projections[0], (ctx.width, ctx.height), at.x, at.y);
        let triangle = &g.triangles[prim as usize];
        let [i, j, k] = triangle.vertices.map(|v| v as usize);
        let Some(hit) = trace::plane_hit([g.positions[i], g.positions[j], g.positions[k]], origin, dir) else {
            continue;
        };
        let w = 1.0 - hit.u - hit.v;
        let position = g.positions[i] * w + g.positions[j] * hit.u + g.positions[k] * hit.v;
        let normal = g.normals[i] * w + g.normals[j] * hit.u + g.normals[k] * hit.v;
        let uv = g.uvs[i] * w + g.uvs[j] * hit.u + g.uvs[k] * hit.v;
        let material = triangle.material;
        let at = SurfacePoint {
            uv,
            tangent: g.tangent(triangle.vertices, Vec3::new(w, hit.u, hit.v)),
            ..SurfacePoint::default()
        };
        let surface = ctx.env.surface(material, &at, &mut blocks, &mut log);
        let mut colours = [[0u8; 3]; 2];
        for (colour, eye) in colours.iter_mut().zip(ctx.eyes) {
            let inputs = LightingInputs {
                position,
                normal,
                eye,
                material,
                surface: at,
            };
            let lighting = ctx.env.lighting(&inputs, &mut blocks, &mut log);
            let c = compose(&surface, lighting, &mut blocks);
            *colour = [c.x, c.y, c.z].map(linear_to_srgb8);
        }
        let d = (0..3).map(|c| colours[0][c].abs_diff(colours[1][c])).max().unwrap_or(0);
        error.sum += u64::from(d);
        error.max = error.max.max(u64::from(d));
        error.pixels += u64::from(d > 0);
    }
    error
}

/// Heat-map id of pixel (x, y) of the pass's view (`u32::MAX` outside it: a helper lane).
fn pixel_id(ctx: &ViewContext, x: u32, y: u32) -> u32 {
    if x < ctx.width && y < ctx.height {
        (ctx.view as u32) << 30 | (y * ctx.width + x)
    } else {
        u32::MAX
    }
}
