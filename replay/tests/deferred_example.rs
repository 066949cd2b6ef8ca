//! A scheme that shades after visibility, written against the public API only (no pipeline
//! file knows it): per tile, each visible sample's triangle is shaded at its pixel centre,
//! once per (pixel, triangle). On opaque scenes its image equals `forward`'s bit for bit, as
//! a deferred renderer's equals a forward renderer's under z pre-pass semantics.

use std::path::Path;

use glam::Vec4;
use shadetrace_replay::cost::{BlockSet, SimdPacker, FINE};
use shadetrace_replay::pipeline::{run_frame, CostHeat, FrameMode, SampleBuffer, NO_PRIMITIVE};
use shadetrace_replay::schedule::{Immediate, Scheduler, SortMiddle, TilePair};
use shadetrace_replay::scheme::{
    Accounting, Passes, PerPixel, SchemeJob, ShadeQuad, ShadingScheme, TileContext, UnitContext,
};
use shadetrace_replay::shader::{compose, LightingInputs};
use shadetrace_replay::{load_trace, ReplayOptions};

struct DeferredPerPixel;

impl ShadingScheme for DeferredPerPixel {
    fn name(&self) -> &'static str {
        "deferred-example"
    }

    fn passes(&self) -> Passes {
        Passes::ShadeAfterVisibility
    }

    fn begin_job(&self, lights: usize, simd_width: u32) -> Box<dyn SchemeJob> {
        Box::new(DeferredJob {
            packer: SimdPacker::new(simd_width, lights),
            blocks: BlockSet::new(lights),
        })
    }
}

struct DeferredJob {
    packer: SimdPacker,
    blocks: BlockSet,
}

impl DeferredJob {
    /// The colour forward shading gives pixel (x, y) of triangle `tri`: attributes at the
    /// pixel centre, texture derivatives across its 2x2 quad.
    fn shade_pixel(&mut self, ctx: &UnitContext, x: u32, y: u32, acc: &mut Accounting) -> Vec4 {
        let (qx, qy) = (x & !1, y & !1);
        let lane = ctx.attributes(x, y);
        let duv_dx = ctx.attributes(qx + 1, qy).uv - ctx.attributes(qx, qy).uv;
        let duv_dy = ctx.attributes(qx, qy + 1).uv - ctx.attributes(qx, qy).uv;
        let material = ctx.triangle.material;
        self.blocks.clear();
        let inputs = LightingInputs {
            position: lane.position,
            normal: lane.normal,
            eye: ctx.eye,
            material,
            surface: ctx.surface_point(lane.uv, duv_dx, duv_dy, x, y),
        };
        let lighting = ctx.env.lighting(&inputs, &mut self.blocks, acc.log);
        let surface = ctx.env.surface(material, &inputs.surface, &mut self.blocks, acc.log);
        let color = compose(&surface, lighting, &mut self.blocks);
        self.packer.lane(
            &self.blocks,
            true,
            ctx.pixel_id(x, y),
            acc.cost.stage_mut(FINE),
            acc.heat,
        );
        color
    }
}

impl SchemeJob for DeferredJob {
    fn shade_unit(&mut self, _: &UnitContext, _: &[ShadeQuad], _: &mut Vec<[Vec4; 4]>, _: &mut Accounting) {
        unreachable!("a ShadeAfterVisibility scheme is never handed units")
    }

    fn shade_tile(&mut self, ctx: &TileContext, tile: &mut SampleBuffer, acc: &mut Accounting) {
        let r = tile.rect;
        for y in r.y0..r.y1 {
            for x in r.x0..r.x1 {
                let mut shaded: Option<(u32, Vec4)> = None;
                for s in 0..tile.samples {
                    let i = tile.index(x, y, s);
                    let tri = tile.tri[i];
                    if tri == NO_PRIMITIVE {
                        continue;
                    }
                    let color = match shaded {
                        Some((t, c)) if t == tri => c,
                        _ => {
                            let c = self.shade_pixel(&ctx.unit(tri), x, y, acc);
                            shaded = Some((tri, c));
                            c
                        }
                    };
                    tile.color[i] = color.truncate().extend(1.0);
                }
            }
        }
        self.packer.flush(acc.cost.stage_mut(FINE), acc.heat);
    }
}

#[test]
fn deferred_example_equals_forward_bit_for_bit() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../traces");
    for (trace, msaa) in [("spheres", 1), ("light-room", 4)] {
        let trace = load_trace(&root.join(format!("{trace}.strace"))).unwrap();
        let opts = ReplayOptions {
            resolution: Some((96, 80)),
            msaa,
            ..ReplayOptions::default()
        };
        let schedulers: [&dyn Scheduler; 3] = [&Immediate, &SortMiddle, &TilePair { disparity_order: true }];
        let frame = &trace.frames[0];
        let forward = run_frame(
            &trace.prepared,
            &trace.meta,
            frame,
            &opts,
            &Immediate,
            &PerPixel,
            FrameMode::alone(CostHeat::Kept),
        );
        for scheduler in schedulers {
            let deferred = run_frame(
                &trace.prepared,
                &trace.meta,
                frame,
                &opts,
                scheduler,
                &DeferredPerPixel,
                FrameMode::alone(CostHeat::Kept),
            );
            for v in 0..2 {
                assert!(
                    forward.views[v].pixels == deferred.views[v].pixels,
                    "{} view {v} msaa {msaa} under {}",
                    trace.name,
                    scheduler.name()
                );
                let (f, d) = (&forward.views[v], &deferred.views[v]);
                assert!(d.cost.stage(FINE).issued() > 0);
                // Deferred shading runs no helper lanes and never shades hidden fragments.
                assert!(
                    d.cost.stage(FINE).issued() < f.cost.stage(FINE).issued(),
                    "{} < {}",
                    d.cost.stage(FINE).issued(),
                    f.cost.stage(FINE).issued()
                );
                assert_eq!(d.raster.units, f.raster.units);
            }
        }
    }
}

#[test]
fn pixels_covered_counts_the_pixels_that_are_not_clear() {
    use shadetrace_replay::pipeline::CLEAR_COLOR;
    use shadetrace_replay::srgb::linear_to_srgb8;
    let clear = [CLEAR_COLOR.x, CLEAR_COLOR.y, CLEAR_COLOR.z].map(linear_to_srgb8);
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../traces");
    for (trace, msaa) in [("spheres", 1), ("depth-stack", 4)] {
        let trace = load_trace(&root.join(format!("{trace}.strace"))).unwrap();
        let opts = ReplayOptions {
            resolution: Some((96, 80)),
            msaa,
            ..ReplayOptions::default()
        };
        let out = run_frame(
            &trace.prepared,
            &trace.meta,
            &trace.frames[0],
            &opts,
            &Immediate,
            &PerPixel,
            FrameMode::alone(CostHeat::Kept),
        );
        for view in &out.views {
            let not_clear = view.pixels.iter().filter(|p| p[..3] != clear).count() as u64;
            assert!(not_clear > 0);
            assert_eq!(view.raster.pixels_covered, not_clear, "{}", trace.name);
        }
    }
}
