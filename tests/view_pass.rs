//! A back-end with a view-to-view pass and a per-pixel work list, written against the public
//! API only (no pipeline file knows it): the left view is drawn and shaded as `forward` does;
//! the right view is not drawn but copied from the left one (the eyes coincide, so there is no
//! disparity); pixels the copy cannot fill (nothing covered them) go to a work list whose
//! chunks "trace" them to the background. The right view must equal `forward`'s bit for bit,
//! cost no raster work, spend its work on a stage of its own, and not depend on the thread
//! count. The same pass with `from == to` reworks a drawn view (a per-view screen pass).

use glam::Vec4;
use shadetrace_capture::{capture, CaptureOptions, Input};
use shadetrace_replay::cost::{BlockSet, SimdPacker};
use shadetrace_replay::cost_table::Block;
use shadetrace_replay::pipeline::{
    run_frame, CostHeat, FrameMode, FrameOutput, PreparedScene, SampleBuffer, CLEAR_COLOR, NO_PRIMITIVE,
};
use shadetrace_replay::schedule::Immediate;
use shadetrace_replay::scheme::{
    Accounting, PerPixel, SchemeJob, ShadeQuad, ShadingScheme, UnitContext, ViewContext, ViewPass, WorkListState,
};
use shadetrace_replay::ReplayOptions;

/// The example's stage for work-list pixels (a real back-end would trace rays there).
const RAY: &str = "ray";

/// `ViewPass { from: 0, to: 1, draw_to: false }`: the right view copied from the left one. With `from == to`
/// (a per-view pass over the drawn right view) the copy is of the view onto itself.
struct CopyLeft(ViewPass);

impl ShadingScheme for CopyLeft {
    fn name(&self) -> &'static str {
        "copy-left-example"
    }

    fn view_pass(&self) -> Option<ViewPass> {
        Some(self.0)
    }

    fn begin_job(&self, lights: usize, simd_width: u32) -> Box<dyn SchemeJob> {
        Box::new(CopyLeftJob {
            forward: PerPixel.begin_job(lights, simd_width),
            packer: SimdPacker::new(simd_width, lights),
            blocks: BlockSet::new(lights),
        })
    }
}

struct CopyLeftJob {
    forward: Box<dyn SchemeJob>,
    packer: SimdPacker,
    blocks: BlockSet,
}

impl SchemeJob for CopyLeftJob {
    fn shade_unit(
        &mut self,
        ctx: &UnitContext,
        quads: &[ShadeQuad],
        colors: &mut Vec<[Vec4; 4]>,
        acc: &mut Accounting,
    ) {
        self.forward.shade_unit(ctx, quads, colors, acc);
    }

    fn derive_view(
        &mut self,
        _: &ViewContext,
        from: &SampleBuffer,
        to: &mut SampleBuffer,
        work: &mut Vec<u32>,
        _: &mut Accounting,
    ) -> Option<WorkListState> {
        for pixel in 0..from.width() * from.height() {
            let first = pixel as usize * from.samples;
            let samples = first..first + from.samples;
            if from.prim[samples.clone()].iter().all(|&p| p == NO_PRIMITIVE) {
                work.push(pixel);
                continue;
            }
            to.depth[samples.clone()].copy_from_slice(&from.depth[samples.clone()]);
            to.prim[samples.clone()].copy_from_slice(&from.prim[samples.clone()]);
            to.color[samples.clone()].copy_from_slice(&from.color[samples]);
        }
        None
    }

    fn shade_pixels(
        &mut self,
        ctx: &ViewContext,
        _: &SampleBuffer,
        pixels: &[u32],
        _: Option<&WorkListState>,
        colors: &mut Vec<Vec4>,
        acc: &mut Accounting,
    ) {
        let stage = acc.cost.stage_mut(RAY);
        for &pixel in pixels {
            self.blocks.clear();
            self.blocks.take(Block::Compose);
            let id = (ctx.view as u32) << 30 | pixel;
            self.packer.lane(&self.blocks, true, id, stage, acc.heat);
            colors.push(CLEAR_COLOR);
        }
        self.packer.flush(stage, acc.heat);
    }
}

fn frame(threads: usize, scheme: &dyn ShadingScheme) -> FrameOutput {
    let captured = capture(
        &Input::Builtin("spheres".into()),
        &CaptureOptions {
            frames: 1,
            ipd_m: 0.0,
            ..CaptureOptions::default()
        },
        &mut |_, _| {},
    )
    .unwrap();
    let prepared = PreparedScene::new(captured.scene.clone());
    let opts = ReplayOptions {
        resolution: Some((96, 80)),
        ..ReplayOptions::default()
    };
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
    pool.install(|| {
        run_frame(
            &prepared,
            &captured.meta,
            &captured.frames[0],
            &opts,
            &Immediate,
            scheme,
            FrameMode::alone(CostHeat::Kept),
        )
    })
}

#[test]
fn a_copied_right_view_equals_forward_and_holes_go_to_the_work_list() {
    let forward = frame(2, &PerPixel);
    let copy = CopyLeft(ViewPass {
        from: 0,
        to: 1,
        draw_to: false,
    });
    let copied = frame(2, &copy);
    assert!(forward.views[0].pixels == forward.views[1].pixels, "the eyes coincide");
    for v in 0..2 {
        assert!(copied.views[v].pixels == forward.views[v].pixels, "view {v}");
    }
    let (left, right) = (&copied.views[0], &copied.views[1]);
    assert_eq!(left.cost, forward.views[0].cost);
    assert_eq!(right.vertex.triangles_in, 0);
    assert_eq!(right.raster.units, 0);
    assert_eq!(right.raster.pixels_covered, left.raster.pixels_covered);
    let holes = 96 * 80 - left.raster.pixels_covered;
    assert!(holes > 0);
    let ray = right.cost.stage(RAY);
    assert_eq!(ray.useful_lanes, holes);
    assert_eq!(right.cost.issued(), ray.issued());
    // Chunks of the work list run in parallel: nothing depends on the thread count.
    let one = frame(1, &copy);
    for v in 0..2 {
        assert!(one.views[v].pixels == copied.views[v].pixels);
        assert_eq!(one.views[v].cost, copied.views[v].cost);
        assert_eq!(one.views[v].cost_heat, copied.views[v].cost_heat);
    }
    assert_eq!(one.traffic, copied.traffic);
}

#[test]
fn a_per_view_pass_reworks_a_drawn_view() {
    let forward = frame(2, &PerPixel);
    let reworked = frame(
        2,
        &CopyLeft(ViewPass {
            from: 1,
            to: 1,
            draw_to: false,
        }),
    );
    let (f, r) = (&forward.views[1], &reworked.views[1]);
    assert!(r.pixels == f.pixels);
    assert_eq!(r.raster.units, f.raster.units, "the view is drawn");
    let holes = 96 * 80 - f.raster.pixels_covered;
    assert_eq!(r.cost.stage(RAY).useful_lanes, holes);
    assert_eq!(r.cost.issued(), f.cost.issued() + r.cost.stage(RAY).issued());
    assert!(reworked.views[0].pixels == forward.views[0].pixels);
}
