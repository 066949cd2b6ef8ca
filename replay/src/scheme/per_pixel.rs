//! `per-pixel`: the reference. Every lane of every 2x2 quad runs the whole shader (helper
//! lanes included, as they must for derivatives); SIMD groups pack W/4 quads of one unit.

use glam::Vec4;

use super::{Accounting, SchemeJob, ShadeQuad, ShadingScheme, UnitContext};
use crate::cost::{BlockSet, SimdPacker, FINE};
use crate::shader::{compose, LightingInputs};

pub struct PerPixel;

impl ShadingScheme for PerPixel {
    fn name(&self) -> &'static str {
        "per-pixel"
    }

    fn begin_job(&self, lights: usize, simd_width: u32) -> Box<dyn SchemeJob> {
        Box::new(PerPixelJob {
            packer: SimdPacker::new(simd_width, lights),
            blocks: BlockSet::new(lights),
        })
    }
}

struct PerPixelJob {
    packer: SimdPacker,
    blocks: BlockSet,
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
            let lanes = [0u32, 1, 2, 3].map(|l| ctx.attributes(quad.x + (l & 1), quad.y + (l >> 1)));
            let duv_dx = lanes[1].uv - lanes[0].uv;
            let duv_dy = lanes[2].uv - lanes[0].uv;
            let mut out = [Vec4::ZERO; 4];
            for (l, lane) in lanes.iter().enumerate() {
                self.blocks.clear();
                let lighting = ctx.env.lighting(
                    &LightingInputs {
                        position: lane.position,
                        normal: lane.normal,
                        eye: ctx.eye,
                        material,
                    },
                    &mut self.blocks,
                    acc.log,
                );
                let albedo = ctx
                    .env
                    .albedo(material, lane.uv, duv_dx, duv_dy, &mut self.blocks, acc.log);
                out[l] = compose(albedo, lighting, &mut self.blocks);
                let (x, y) = (quad.x + (l as u32 & 1), quad.y + (l as u32 >> 1));
                let useful = quad.lanes & (1 << l) != 0;
                self.packer
                    .lane(&self.blocks, useful, ctx.pixel_id(x, y), fine, acc.heat);
            }
            colors.push(out);
        }
        self.packer.flush(fine, acc.heat);
    }
}
