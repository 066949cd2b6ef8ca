//! `deferred` (RTR4 §20.1): a geometry pass writes a G-buffer, then a screen pass lights
//! each tile from it. The G-buffer is the layout of Schied and Dachsbacher's comparison, 20
//! bytes per sample with depth ([`GBUFFER_SAMPLE_BYTES`]): albedo as sRGB RGBA8, triangle
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
//! [`GBUFFER_SAMPLE_BYTES`]: crate::memory::GBUFFER_SAMPLE_BYTES

use std::collections::BTreeMap;

use glam::{Vec3, Vec4};

use super::{Accounting, Passes, SchemeJob, ShadeQuad, ShadingScheme, TileContext, UnitContext, VisibleQuads};
use crate::cost::{BlockSet, SimdPacker, FINE};
use crate::cost_table::Block;
use crate::memory::Stream;
use crate::pipeline::{SampleBuffer, NO_PRIMITIVE};
use crate::shader::{compose, LightingInputs};
use crate::srgb::linear_to_srgb8;
use crate::texture::srgb_to_linear;

/// Cost stage of the G-buffer pass (the lighting pass is [`FINE`]).
pub const GBUFFER: &str = "gbuffer";

pub struct Deferred;

impl ShadingScheme for Deferred {
    fn name(&self) -> &'static str {
        "deferred"
    }

    fn passes(&self) -> Passes {
        Passes::ShadeAfterVisibility
    }

    fn begin_job(&self, lights: usize, simd_width: u32) -> Box<dyn SchemeJob> {
        Box::new(DeferredJob {
            packer: SimdPacker::new(simd_width, lights),
            blocks: BlockSet::new(lights),
            tiles: BTreeMap::new(),
            shaded: Vec::new(),
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
    packer: SimdPacker,
    blocks: BlockSet,
    /// The G-buffer of every tile this job touches, by (view, tile), in the tile's sample order.
    tiles: BTreeMap<(u8, u32), Vec<GSample>>,
    /// Triangles already lit in the current pixel (MSAA deduplication).
    shaded: Vec<(u32, Vec4)>,
}

impl SchemeJob for DeferredJob {
    /// Never called: the scheme shades after visibility.
    fn shade_unit(&mut self, _: &UnitContext, _: &[ShadeQuad], _: &mut Vec<[Vec4; 4]>, _: &mut Accounting) {}

    fn visible_quads(&mut self, ctx: &UnitContext, visible: &VisibleQuads, acc: &mut Accounting) {
        let samples = visible.samples;
        let rect = visible.rect;
        let tile = self.tiles.entry((ctx.view, visible.tile)).or_insert_with(|| {
            vec![GSample::default(); ((rect.x1 - rect.x0) * (rect.y1 - rect.y0)) as usize * samples]
        });
        let material = ctx.triangle.material;
        let stage = acc.cost.stage_mut(GBUFFER);
        for &(quad, passed) in visible.quads {
            let lanes = [0u32, 1, 2, 3].map(|l| ctx.attributes(quad.x + (l & 1), quad.y + (l >> 1)));
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
                    acc.log
                        .touch(Stream::GBuffer, visible.layout.gbuffer_line(ctx.view, x, y), true);
                }
                self.packer
                    .lane(&self.blocks, lane_samples != 0, ctx.pixel_id(x, y), stage, acc.heat);
            }
        }
        self.packer.flush(stage, acc.heat);
    }

    fn shade_tile(&mut self, ctx: &TileContext, buffer: &mut SampleBuffer, acc: &mut Accounting) {
        let Some(gbuffer) = self.tiles.remove(&(buffer.view, ctx.tile)) else {
            return;
        };
        let samples = buffer.samples;
        let stage = acc.cost.stage_mut(FINE);
        let (width, rect) = (buffer.width(), buffer.rect);
        for y in rect.y0..rect.y1 {
            for x in rect.x0..rect.x1 {
                let first = ((y - rect.y0) * width + (x - rect.x0)) as usize * samples;
                if buffer.tri[first..first + samples].iter().all(|&t| t == NO_PRIMITIVE) {
                    continue;
                }
                acc.log
                    .touch(Stream::GBuffer, ctx.layout.gbuffer_line(buffer.view, x, y), false);
                acc.log
                    .touch(Stream::Color, ctx.layout.color_line(buffer.view, x, y), true);
                self.shaded.clear();
                for s in 0..samples {
                    let i = first + s;
                    let tri = buffer.tri[i];
                    if tri == NO_PRIMITIVE {
                        continue;
                    }
                    if let Some(&(_, colour)) = self.shaded.iter().find(|(t, _)| *t == tri) {
                        buffer.color[i] = colour;
                        continue;
                    }
                    let unit = ctx.unit(tri);
                    let g = gbuffer[i];
                    self.blocks.clear();
                    self.blocks.take(Block::GBufferRead);
                    let lighting = ctx.env.lighting(
                        &LightingInputs {
                            position: unit.attributes(x, y).position,
                            normal: octahedral_decode(g.normal),
                            eye: ctx.eye,
                            material: unit.triangle.material,
                        },
                        &mut self.blocks,
                        acc.log,
                    );
                    let colour = compose(decode_albedo(g.albedo), lighting, &mut self.blocks);
                    self.packer
                        .lane(&self.blocks, true, unit.pixel_id(x, y), stage, acc.heat);
                    self.shaded.push((tri, colour));
                    buffer.color[i] = colour;
                }
            }
        }
        self.packer.flush(stage, acc.heat);
    }
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
