//! `deferred` (RTR4 §20.1): a geometry pass writes a G-buffer, then a screen pass lights
//! each tile from it. The G-buffer is the layout of Schied and Dachsbacher's comparison, 20
//! bytes per sample with depth ([`RenderTarget::GBuffer`]): albedo as sRGB RGBA8, triangle
//! id, linear depth, the normal octahedrally encoded in 2x16 bits (Cigolle et al. 2014) and
//! the material id. Both quantizations reach the image, so SSIM against `forward` measures
//! them.
//!
//! The geometry pass shades every fragment that passes the depth test (overdraw included,
//! unless `--z-prepass`) with the G-buffer shader in 2x2 quads, helper lanes included, as
//! forward does. The lighting pass shades, per pixel, each distinct triangle among its
//! samples once (MSAA deduplicated by triangle id, as the paper's baseline) in SIMD groups
//! of pixels: no helper lanes. The position is the triangle's at the pixel centre, which the
//! 32-bit linear depth reconstructs to within float rounding.
//!
//! `tiled` and `clustered` (RTR4 §20.3-20.4) light from culled light lists
//! ([`light_lists`](super::light_lists)): per 16x16 screen tile from the depth bounds of its
//! samples, or per cluster (64x64 px x 16 exponential depth slices, every cluster built, by
//! the raster tile holding its column's first pixel) and looked up per pixel. A list is
//! written to memory once and read once per tile that uses it (`light_lists` traffic; a
//! compute shader that fuses culling and lighting would keep a tile's list on chip), and its
//! build is the `light_lists` cost stage. Lists are conservative, so the pixels equal
//! `deferred`'s.
//!
//! [`RenderTarget::GBuffer`]: crate::memory::RenderTarget::GBuffer

use std::collections::{BTreeMap, BTreeSet};

use glam::{Vec3, Vec4};

use super::distinct_triangles;
use super::light_lists::{
    charge_culling, depth_bounds, list_bytes, slice_depths, slice_of, LightCuller, CLUSTER_SLICES, CLUSTER_TILE,
    LIGHT_LISTS, TILED_TILE,
};
use super::{
    Accounting, LaneAttributes, Passes, SchemeJob, ShadeQuad, ShadingScheme, TileContext, UnitContext, VisibleQuads,
};
use crate::cost::{BlockSet, SimdPacker, FINE};
use crate::cost_table::Block;
use crate::memory::{AccessLog, RenderTarget, Stream, LINE_BYTES};
use crate::pipeline::VERTEX_BYTES;
use crate::pipeline::{SampleBuffer, NO_PRIMITIVE};
use crate::raster::Rect;
use crate::shader::{compose, LightingInputs, Surface, SurfacePoint};
use crate::srgb::linear_to_srgb8;
use crate::texture::srgb_to_linear;

/// Cost stage of the G-buffer pass (the lighting pass is [`FINE`]).
pub const GBUFFER: &str = "gbuffer";
/// Cost stage of the visibility buffer's geometry pass.
pub const VISIBILITY: &str = "visibility";

/// Which lights a pixel's lighting loops over.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Lists {
    /// Every light.
    None,
    /// The list of the pixel's 16x16 screen tile.
    Tiled,
    /// The list of the pixel's cluster.
    Clustered,
}

/// What the geometry pass stores per sample.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Target {
    /// The 20-byte G-buffer: the shading inputs, quantized.
    GBuffer,
    /// The visibility buffer (RTR4 §20.5, deferred texturing): triangle and instance ids
    /// only; the shading pass fetches the triangle, interpolates its attributes and samples
    /// the textures itself, so the pixels are `forward`'s.
    Visibility,
}

pub struct Deferred {
    pub target: Target,
    pub lists: Lists,
}

impl ShadingScheme for Deferred {
    fn name(&self) -> &'static str {
        match (self.target, self.lists) {
            (Target::Visibility, _) => "visbuffer",
            (Target::GBuffer, Lists::None) => "deferred",
            (Target::GBuffer, Lists::Tiled) => "tiled",
            (Target::GBuffer, Lists::Clustered) => "clustered",
        }
    }

    fn passes(&self) -> Passes {
        Passes::ShadeAfterVisibility
    }

    fn begin_job(&self, lights: usize, simd_width: u32) -> Box<dyn SchemeJob> {
        Box::new(DeferredJob {
            target: self.target,
            lists: self.lists,
            packer: SimdPacker::new(simd_width, lights),
            blocks: BlockSet::new(lights),
            tiles: BTreeMap::new(),
            shaded: Vec::new(),
            culler: None,
            list: Vec::new(),
            clusters: BTreeMap::new(),
            slices: Vec::new(),
        })
    }
}

/// One G-buffer sample's shading inputs (the ids and depth are the tile's own).
#[derive(Clone, Copy, Default)]
struct GSample {
    albedo: [u8; 4],
    normal: [u16; 2],
}

struct DeferredJob {
    target: Target,
    lists: Lists,
    packer: SimdPacker,
    blocks: BlockSet,
    /// The G-buffer of every tile this job touches, by (view, tile), in the tile's sample order.
    tiles: BTreeMap<(u8, u32), Vec<GSample>>,
    /// The current pixel's distinct triangles and their sample masks (MSAA deduplication).
    shaded: Vec<(u32, u32)>,
    /// The frame's lights as cull volumes (made at the job's first tile).
    culler: Option<LightCuller>,
    /// The current tiled list.
    list: Vec<u32>,
    /// Cluster lists by (view, column x, column y, slice), made as pixels need them.
    clusters: BTreeMap<(u8, u32, u32, u32), Vec<u32>>,
    /// Every slice's NDC depth range ([`slice_depths`], two `powf` each), made once.
    slices: Vec<(f32, f32)>,
}

impl SchemeJob for DeferredJob {
    /// Never called: the scheme shades after visibility.
    fn shade_unit(&mut self, _: &UnitContext, _: &[ShadeQuad], _: &mut Vec<[Vec4; 4]>, _: &mut Accounting) {}

    fn visible_quads(&mut self, ctx: &UnitContext, visible: &VisibleQuads, acc: &mut Accounting) {
        if self.target == Target::Visibility {
            let stage = acc.cost.stage_mut(VISIBILITY);
            self.blocks.clear();
            self.blocks.take(Block::VisibilityWrite);
            for &(quad, passed) in visible.quads {
                for l in 0..4u32 {
                    let (x, y) = (quad.x + (l & 1), quad.y + (l >> 1));
                    let useful = passed >> (l as usize * visible.samples) & ((1 << visible.samples) - 1) != 0;
                    if useful {
                        acc.log.touch(
                            Stream::Visibility,
                            visible.layout.line(RenderTarget::Visibility, ctx.view, x, y),
                            true,
                        );
                    }
                    self.packer
                        .lane(&self.blocks, useful, ctx.pixel_id(x, y), stage, acc.heat);
                }
            }
            self.packer.flush(stage, acc.heat);
            return;
        }
        let samples = visible.samples;
        let rect = visible.rect;
        let tile = self.tiles.entry((ctx.view, visible.tile)).or_insert_with(|| {
            vec![GSample::default(); ((rect.x1 - rect.x0) * (rect.y1 - rect.y0)) as usize * samples]
        });
        let material = ctx.triangle.material;
        let stage = acc.cost.stage_mut(GBUFFER);
        for &(quad, passed) in visible.quads {
            let lanes = ctx.quad_attributes(quad.x, quad.y).lanes();
            let duv_dx = lanes[1].uv - lanes[0].uv;
            let duv_dy = lanes[2].uv - lanes[0].uv;
            for (l, lane) in lanes.iter().enumerate() {
                self.blocks.clear();
                let albedo = ctx
                    .env
                    .albedo(material, lane.uv, duv_dx, duv_dy, &mut self.blocks, acc.log);
                self.blocks.take(Block::GBufferWrite);
                let (x, y) = (quad.x + (l as u32 & 1), quad.y + (l as u32 >> 1));
                let lane_samples = passed >> (l * samples) & ((1 << samples) - 1);
                if lane_samples != 0 {
                    let sample = GSample {
                        albedo: encode_albedo(albedo),
                        normal: octahedral_encode(lane.normal),
                    };
                    let first = ((y - rect.y0) * (rect.x1 - rect.x0) + (x - rect.x0)) as usize * samples;
                    for s in (0..samples).filter(|s| lane_samples & (1 << s) != 0) {
                        tile[first + s] = sample;
                    }
                    acc.log.touch(
                        Stream::GBuffer,
                        visible.layout.line(RenderTarget::GBuffer, ctx.view, x, y),
                        true,
                    );
                }
                self.packer
                    .lane(&self.blocks, lane_samples != 0, ctx.pixel_id(x, y), stage, acc.heat);
            }
        }
        self.packer.flush(stage, acc.heat);
    }

    fn shade_tile(&mut self, ctx: &TileContext, buffer: &mut SampleBuffer, acc: &mut Accounting) {
        // The G-buffer targets have a tile wherever something is visible; the visibility
        // buffer has none (its ids are the tile's own).
        let gbuffer = match (self.target, self.tiles.remove(&(buffer.view, ctx.tile))) {
            (Target::GBuffer, None) => return,
            (_, tile) => tile.unwrap_or_default(),
        };
        let culler = self.culler.get_or_insert_with(|| LightCuller::new(ctx.env.lights));
        let rect = buffer.rect;
        match self.lists {
            Lists::None => self.light(ctx, buffer, &gbuffer, rect, acc),
            Lists::Tiled => {
                let mut list = std::mem::take(&mut self.list);
                for y0 in (rect.y0..rect.y1).step_by(TILED_TILE as usize) {
                    for x0 in (rect.x0..rect.x1).step_by(TILED_TILE as usize) {
                        let sub = Rect {
                            x0,
                            y0,
                            x1: (x0 + TILED_TILE).min(rect.x1),
                            y1: (y0 + TILED_TILE).min(rect.y1),
                        };
                        let Some(bounds) = depth_bounds(buffer, sub, &mut self.packer, &mut self.blocks, acc) else {
                            continue;
                        };
                        let culler = self.culler.as_ref().unwrap_or_else(|| unreachable!("made above"));
                        culler.cull(&view_projection(ctx), (ctx.width, ctx.height), sub, bounds, &mut list);
                        charge_culling(culler.tested(), &mut self.packer, &mut self.blocks, acc);
                        (acc.traffic)(LIGHT_LISTS, 2 * list_bytes(list.len()));
                        self.list = list;
                        self.light(ctx, buffer, &gbuffer, sub, acc);
                        list = std::mem::take(&mut self.list);
                    }
                }
                self.list = list;
            }
            Lists::Clustered => {
                let tested = culler.tested();
                // The raster tile holding a column's first pixel builds all its clusters (a
                // column whose first tile holds no geometry, and so has no tile pass, goes
                // uncharged).
                let columns = |a: u32, b: u32| a.div_ceil(CLUSTER_TILE)..b.div_ceil(CLUSTER_TILE);
                for cy in columns(rect.y0, rect.y1) {
                    for cx in columns(rect.x0, rect.x1) {
                        for slice in 0..CLUSTER_SLICES {
                            let n = self.cluster(ctx, buffer.view, cx, cy, slice).len();
                            (acc.traffic)(LIGHT_LISTS, list_bytes(n));
                            charge_culling(tested, &mut self.packer, &mut self.blocks, acc);
                        }
                    }
                }
                self.light(ctx, buffer, &gbuffer, rect, acc);
            }
        }
    }
}

impl DeferredJob {
    /// Lights the pixels of `rect` (inside `buffer`) from the G-buffer: per pixel, each
    /// distinct triangle among its samples once, with every light, the current tiled list or
    /// the sample's cluster list.
    fn light(
        &mut self,
        ctx: &TileContext,
        buffer: &mut SampleBuffer,
        gbuffer: &[GSample],
        rect: Rect,
        acc: &mut Accounting,
    ) {
        let samples = buffer.samples;
        let (width, origin) = (buffer.width(), (buffer.rect.x0, buffer.rect.y0));
        // Cluster lists read by this tile, each once.
        let mut read: BTreeSet<(u32, u32, u32)> = BTreeSet::new();
        for y in rect.y0..rect.y1 {
            for x in rect.x0..rect.x1 {
                let first = ((y - origin.1) * width + (x - origin.0)) as usize * samples;
                if buffer.tri[first..first + samples].iter().all(|&t| t == NO_PRIMITIVE) {
                    continue;
                }
                let (stream, line) = match self.target {
                    Target::GBuffer => (
                        Stream::GBuffer,
                        ctx.layout.line(RenderTarget::GBuffer, buffer.view, x, y),
                    ),
                    Target::Visibility => (
                        Stream::Visibility,
                        ctx.layout.line(RenderTarget::Visibility, buffer.view, x, y),
                    ),
                };
                acc.log.touch(stream, line, false);
                acc.log
                    .touch(Stream::Color, ctx.layout.color_line(buffer.view, x, y), true);
                let mut shaded = std::mem::take(&mut self.shaded);
                distinct_triangles(&buffer.tri[first..first + samples], &mut shaded);
                for &(tri, mask) in &shaded {
                    // The triangle's first sample: its G-buffer entry and depth.
                    let i = first + mask.trailing_zeros() as usize;
                    let unit = ctx.unit(tri);
                    let material = unit.triangle.material;
                    let own = unit.attributes(x, y);
                    self.blocks.clear();
                    // The G-buffer has no channels for surface maps (the registry refuses
                    // traces with them); the visibility buffer samples them as forward does.
                    let (normal, surface, at) = match self.target {
                        Target::GBuffer => {
                            self.blocks.take(Block::GBufferRead);
                            let g = gbuffer[i];
                            let albedo = Surface::of_albedo(decode_albedo(g.albedo));
                            (octahedral_decode(g.normal), albedo, SurfacePoint::default())
                        }
                        Target::Visibility => {
                            let (surface, at) = refetched_surface(&unit, &own, (x, y), &mut self.blocks, acc.log);
                            (own.normal, surface, at)
                        }
                    };
                    let inputs = LightingInputs {
                        position: own.position,
                        normal,
                        eye: ctx.eye,
                        material,
                        surface: at,
                    };
                    let lighting = match self.lists {
                        Lists::None => ctx.env.lighting(&inputs, &mut self.blocks, acc.log),
                        Lists::Tiled => ctx.env.lighting_listed(&inputs, &self.list, &mut self.blocks, acc.log),
                        Lists::Clustered => {
                            self.blocks.take(Block::ClusterLookup);
                            let key = (
                                x / CLUSTER_TILE,
                                y / CLUSTER_TILE,
                                slice_of(buffer.depth[i], ctx.depth_range),
                            );
                            let n = self.cluster(ctx, buffer.view, key.0, key.1, key.2).len();
                            if read.insert(key) {
                                (acc.traffic)(LIGHT_LISTS, list_bytes(n));
                            }
                            // Made just above; borrowed beside the block set, not copied.
                            let list = &self.clusters[&(buffer.view, key.0, key.1, key.2)];
                            ctx.env.lighting_listed(&inputs, list, &mut self.blocks, acc.log)
                        }
                    };
                    let colour = compose(&surface, lighting, &mut self.blocks);
                    let stage = acc.cost.stage_mut(FINE);
                    self.packer
                        .lane(&self.blocks, true, unit.pixel_id(x, y), stage, acc.heat);
                    for s in (0..samples).filter(|s| mask & (1 << s) != 0) {
                        buffer.color[first + s] = colour;
                    }
                }
                self.shaded = shaded;
            }
        }
        self.packer.flush(acc.cost.stage_mut(FINE), acc.heat);
    }

    /// The list of cluster (`cx`, `cy`, `slice`) of `view`, made on first use.
    fn cluster(&mut self, ctx: &TileContext, view: u8, cx: u32, cy: u32, slice: u32) -> &[u32] {
        let culler = self.culler.get_or_insert_with(|| LightCuller::new(ctx.env.lights));
        if self.slices.is_empty() {
            self.slices = (0..CLUSTER_SLICES).map(|k| slice_depths(k, ctx.depth_range)).collect();
        }
        let depths = self.slices[slice as usize];
        self.clusters.entry((view, cx, cy, slice)).or_insert_with(|| {
            let rect = Rect {
                x0: cx * CLUSTER_TILE,
                y0: cy * CLUSTER_TILE,
                x1: ((cx + 1) * CLUSTER_TILE).min(ctx.width),
                y1: ((cy + 1) * CLUSTER_TILE).min(ctx.height),
            };
            let mut list = Vec::new();
            culler.cull(&view_projection(ctx), (ctx.width, ctx.height), rect, depths, &mut list);
            list
        })
    }
}

/// The visibility buffer's surface at pixel `(x, y)` of `unit`'s triangle, whose
/// attributes there are `own`: the triangle's three vertices fetched again, its uv at the
/// pixel's quad (for the textures' derivatives, as forward's quads give them), the textures
/// sampled. Also returns where the lighting samples the surface maps.
pub(super) fn refetched_surface(
    unit: &UnitContext,
    own: &LaneAttributes,
    (x, y): (u32, u32),
    blocks: &mut BlockSet,
    log: &mut AccessLog,
) -> (Surface, SurfacePoint) {
    blocks.take(Block::VisibilityInterpolate);
    for v in unit.triangle.vertices {
        log.touch(Stream::TriangleData, u64::from(v) * VERTEX_BYTES / LINE_BYTES, false);
    }
    let (qx, qy) = (x & !1, y & !1);
    let [a, b, c] = [(qx, qy), (qx + 1, qy), (qx, qy + 1)].map(|(u, v)| unit.attributes(u, v).uv);
    let at = unit.surface_point(own.uv, b - a, c - a, x, y);
    (unit.env.surface(unit.triangle.material, &at, blocks, log), at)
}

/// The world-to-clip matrix of the tile's view.
fn view_projection(ctx: &TileContext) -> glam::Mat4 {
    ctx.view_projections[ctx.view as usize]
}

/// Albedo as the G-buffer stores it: sRGB-encoded colour, linear alpha, 8 bits each.
fn encode_albedo(albedo: Vec4) -> [u8; 4] {
    let [r, g, b, a] = albedo.to_array().map(|c| c.clamp(0.0, 1.0));
    [
        linear_to_srgb8(r),
        linear_to_srgb8(g),
        linear_to_srgb8(b),
        (a * 255.0).round() as u8,
    ]
}

fn decode_albedo([r, g, b, a]: [u8; 4]) -> Vec4 {
    Vec4::new(
        srgb_to_linear(r),
        srgb_to_linear(g),
        srgb_to_linear(b),
        f32::from(a) / 255.0,
    )
}

/// A normal as two 16-bit signed-normalized octahedral coordinates (Cigolle et al. 2014).
fn octahedral_encode(n: Vec3) -> [u16; 2] {
    let sum = n.x.abs() + n.y.abs() + n.z.abs();
    let p = if sum > 0.0 { n / sum } else { Vec3::Z };
    let (u, v) = if p.z >= 0.0 {
        (p.x, p.y)
    } else {
        ((1.0 - p.y.abs()) * sign(p.x), (1.0 - p.x.abs()) * sign(p.y))
    };
    [u, v].map(|c| ((c.clamp(-1.0, 1.0) * 32767.0).round() as i16) as u16)
}

fn octahedral_decode(q: [u16; 2]) -> Vec3 {
    let [u, v] = q.map(|c| f32::from(c as i16) / 32767.0);
    let z = 1.0 - u.abs() - v.abs();
    let (x, y) = if z < 0.0 {
        ((1.0 - v.abs()) * sign(u), (1.0 - u.abs()) * sign(v))
    } else {
        (u, v)
    };
    Vec3::new(x, y, z).normalize_or(Vec3::Z)
}

fn sign(x: f32) -> f32 {
    if x >= 0.0 {
        1.0
    } else {
        -1.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn albedo_round_trips_through_srgb8() {
        for c in [0u8, 1, 17, 128, 254, 255] {
            let v = Vec4::new(
                srgb_to_linear(c),
                srgb_to_linear(c),
                srgb_to_linear(c),
                f32::from(c) / 255.0,
            );
            assert_eq!(encode_albedo(v), [c; 4]);
        }
    }

    #[test]
    fn octahedral_normals_round_trip_within_quantization() {
        for n in [
            Vec3::X,
            Vec3::NEG_Y,
            Vec3::new(0.3, -0.5, -0.8).normalize(),
            Vec3::new(-0.7, 0.1, 0.7).normalize(),
        ] {
            let back = octahedral_decode(octahedral_encode(n));
            assert!(back.dot(n) >= 1.0 - 1e-6, "{n} -> {back}");
        }
        assert_eq!(octahedral_decode(octahedral_encode(Vec3::ZERO)), Vec3::Z);
    }
}
