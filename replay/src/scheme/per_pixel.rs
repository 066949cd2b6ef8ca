//! `per-pixel`: the reference. Every lane of every 2x2 quad runs the whole shader (helper
//! lanes included, as they must for derivatives); SIMD groups pack W/4 quads of one unit.
//!
//! `forward+` (tiled forward, RTR4 §20.3) is the same pass after a depth pre-pass, each
//! lane lighting with the list of its 16x16 screen tile: built when the raster tile's depth
//! is final, from its depth bounds as `tiled` builds it (over the whole depth range when the
//! scene has blended or alpha-tested surfaces, which the pre-pass does not draw). Lists are
//! conservative, so its pixels are those of `forward` with the same pre-pass.

use std::collections::BTreeMap;

use glam::Vec4;
use shadetrace_formats::AlphaMode;

use super::light_lists::{charge_culling, depth_bounds, list_bytes, LightCuller, LIGHT_LISTS, TILED_TILE};
use super::{Accounting, SchemeJob, ShadeQuad, ShadingScheme, TileContext, UnitContext};
use crate::cost::{BlockSet, SimdPacker, FINE};
use crate::pipeline::SampleBuffer;
use crate::raster::Rect;
use crate::shader::{compose, QuadLighting};

pub struct PerPixel;

impl ShadingScheme for PerPixel {
    fn name(&self) -> &'static str {
        "per-pixel"
    }

    fn begin_job(&self, lights: usize, simd_width: u32) -> Box<dyn SchemeJob> {
        Box::new(PerPixelJob::new(lights, simd_width, None))
    }
}

pub struct ForwardPlus;

impl ShadingScheme for ForwardPlus {
    fn name(&self) -> &'static str {
        "forward-plus"
    }

    fn depth_prepass(&self) -> bool {
        true
    }

    fn begin_job(&self, lights: usize, simd_width: u32) -> Box<dyn SchemeJob> {
        Box::new(PerPixelJob::new(lights, simd_width, Some(TileLists::default())))
    }
}

/// The light lists of the 16x16 screen tiles a job has prepared, by (view, x, y) in tiles.
#[derive(Default)]
struct TileLists {
    culler: Option<LightCuller>,
    lists: BTreeMap<(u8, u32, u32), Vec<u32>>,
}

struct PerPixelJob {
    packer: SimdPacker,
    blocks: BlockSet,
    /// The quad being shaded, its arithmetic done four lanes at a time.
    quad: QuadLighting,
    /// `forward+`'s lists; None for `per-pixel`.
    lists: Option<TileLists>,
}

impl PerPixelJob {
    fn new(lights: usize, simd_width: u32, lists: Option<TileLists>) -> Self {
        PerPixelJob {
            packer: SimdPacker::new(simd_width, lights),
            blocks: BlockSet::new(lights),
            quad: QuadLighting::default(),
            lists,
        }
    }
}

impl SchemeJob for PerPixelJob {
    fn shade_unit(
        &mut self,
        ctx: &UnitContext,
        quads: &[ShadeQuad],
        colors: &mut Vec<[Vec4; 4]>,
        acc: &mut Accounting,
    ) {
        let material = ctx.triangle.material;
        let fine = acc.cost.stage_mut(FINE);
        for quad in quads {
            let attributes = ctx.quad_attributes(quad.x, quad.y);
            let points = ctx.quad_surface_points(attributes.uv, quad.x, quad.y);
            let points = points.get();
            let quad_lit = ctx.env.quad_lighting(
                material,
                ctx.eye,
                attributes.position,
                attributes.normal,
                Some(points),
                &mut self.quad,
            );
            let list = self.lists.as_ref().map(|tiles| {
                let key = (ctx.view, quad.x / TILED_TILE, quad.y / TILED_TILE);
                tiles.lists.get(&key).map_or(&[][..], Vec::as_slice)
            });
            let lane_pixel = |l: usize| (quad.x + (l as u32 & 1), quad.y + (l as u32 >> 1));
            // Lanes that take the same blocks are shaded together and costed alike.
            self.blocks.clear();
            let together = match quad_lit {
                true => ctx
                    .env
                    .quad_colors(&mut self.quad, material, points, list, &mut self.blocks, acc.log),
                false => None,
            };
            if let Some(out) = together {
                let pixels = std::array::from_fn(|l| {
                    let (x, y) = lane_pixel(l);
                    acc.heat.pixel(|| ctx.pixel_id(x, y))
                });
                self.packer.quad(&self.blocks, quad.lanes, pixels, fine, acc.heat);
                colors.push(out);
                continue;
            }
            let mut out = [Vec4::ZERO; 4];
            for (l, at) in points.iter().enumerate() {
                let (x, y) = lane_pixel(l);
                self.blocks.clear();
                let (blocks, log) = (&mut self.blocks, &mut *acc.log);
                let lighting = match quad_lit {
                    true => ctx.env.lane_lighting(&self.quad, l, material, at, list, blocks, log),
                    false => {
                        let inputs = attributes.lane(l).lighting_inputs(ctx.eye, material, *at);
                        match list {
                            Some(list) => ctx.env.lighting_listed(&inputs, list, blocks, log),
                            None => ctx.env.lighting(&inputs, blocks, log),
                        }
                    }
                };
                let surface = ctx.env.surface(material, at, &mut self.blocks, acc.log);
                out[l] = compose(&surface, lighting, &mut self.blocks);
                let useful = quad.lanes & (1 << l) != 0;
                self.packer
                    .lane(&self.blocks, useful, ctx.pixel_id(x, y), fine, acc.heat);
            }
            colors.push(out);
        }
        self.packer.flush(fine, acc.heat);
    }

    /// `forward+`: the lists of the raster tile's 16x16 screen tiles, written once and read
    /// once by the tile (`light_lists` traffic).
    fn tile_prepared(&mut self, ctx: &TileContext, tile: &SampleBuffer, acc: &mut Accounting) {
        let Some(tiles) = self.lists.as_mut() else {
            return;
        };
        let culler = tiles.culler.get_or_insert_with(|| LightCuller::new(ctx.env.lights));
        let blended = ctx.env.materials.iter().any(|m| m.alpha != AlphaMode::Opaque);
        // The raster tile's parts of the screen's 16x16 tiles.
        let rect = tile.rect;
        let steps = |a: u32, b: u32| (a / TILED_TILE..b.div_ceil(TILED_TILE)).map(|t| t * TILED_TILE);
        for gy in steps(rect.y0, rect.y1) {
            for gx in steps(rect.x0, rect.x1) {
                let sub = Rect {
                    x0: gx.max(rect.x0),
                    y0: gy.max(rect.y0),
                    x1: (gx + TILED_TILE).min(rect.x1),
                    y1: (gy + TILED_TILE).min(rect.y1),
                };
                let bounds = depth_bounds(tile, sub, &mut self.packer, &mut self.blocks, acc);
                // Blended surfaces, which the pre-pass does not draw, may lie anywhere in front
                // of the opaque depth or over the background: the whole depth range.
                let (near, far) = match (bounds, blended) {
                    (_, true) => (0.0, 1.0),
                    (Some(b), false) => b,
                    (None, false) => continue,
                };
                let mut list = Vec::new();
                let view_projection = ctx.view_projections[ctx.view as usize];
                culler.cull(&view_projection, (ctx.width, ctx.height), sub, (near, far), &mut list);
                charge_culling(culler.tested(), &mut self.packer, &mut self.blocks, acc);
                (acc.traffic)(LIGHT_LISTS, 2 * list_bytes(list.len()));
                // A screen tile split between raster tiles lights with the union of their
                // lists: a superset still gives the same bits (a light out of range adds 0).
                let key = (ctx.view, gx / TILED_TILE, gy / TILED_TILE);
                match tiles.lists.get_mut(&key) {
                    Some(merged) => {
                        merged.extend(list);
                        merged.sort_unstable();
                        merged.dedup();
                    }
                    None => {
                        tiles.lists.insert(key, list);
                    }
                }
            }
        }
    }
}
