//! `forward+` (tiled forward, RTR4 §20.3): a depth pre-pass, then forward shading with the
//! light list of each 16x16 screen tile. Lists are conservative, so its pixels are
//! those of `forward` with the same pre-pass (which for opaque scenes are `forward`'s), with
//! blended surfaces too (their lists start at the near plane), at any raster tile size; with
//! many short-ranged lights it costs less, paying for its lists.

use shadetrace_capture::{capture, CaptureOptions, Input};
use shadetrace_formats::AlphaMode;
use shadetrace_replay::pipeline::{run_frame, CostHeat, FrameMode, PreparedScene};
use shadetrace_replay::schedule::Immediate;
use shadetrace_replay::scheme::{ForwardPlus, PerPixel, ShadingScheme};
use shadetrace_replay::ReplayOptions;

/// One run: both views' pixels, instructions issued, light-list bytes.
struct Run {
    pixels: Vec<Vec<[u8; 4]>>,
    issued: u64,
    list_bytes: u64,
}

/// `forward` and `forward+` on the built-in `scene`, its first material blended if asked.
fn frames(scene: &str, blend: bool, tile: u32) -> [Run; 2] {
    let captured = capture(
        &Input::Builtin(scene.into()),
        &CaptureOptions::default(),
        &mut |_, _| {},
    )
    .unwrap();
    let mut scene = captured.scene.clone();
    if blend {
        scene.materials[0].alpha = AlphaMode::Blend;
    }
    let prepared = PreparedScene::new(scene);
    let opts = ReplayOptions {
        resolution: Some((120, 90)),
        tile,
        msaa: 4,
        ..ReplayOptions::default()
    };
    let run = |scheme: &dyn ShadingScheme| {
        // Forward with the same pre-pass: blending order then agrees (opaque surfaces are
        // the pre-pass's; without it the pixels of opaque scenes are the same).
        let opts = ReplayOptions {
            z_prepass: true,
            ..opts.clone()
        };
        let out = run_frame(
            &prepared,
            &captured.meta,
            &captured.frames[0],
            &opts,
            &Immediate,
            scheme,
            FrameMode::alone(CostHeat::Kept),
        );
        Run {
            pixels: out.views.iter().map(|v| v.pixels.clone()).collect(),
            issued: out.views.iter().map(|v| v.cost.issued()).sum(),
            list_bytes: out.traffic.bytes("light_lists"),
        }
    };
    [run(&PerPixel), run(&ForwardPlus)]
}

#[test]
fn forward_plus_keeps_forwards_pixels_and_cuts_the_lighting() {
    for (blend, tile) in [(false, 16), (true, 16), (false, 20)] {
        let [forward, plus] = frames("light-room", blend, tile);
        assert!(
            plus.pixels == forward.pixels,
            "blend {blend}, tile {tile}: pixels differ"
        );
        assert!(plus.list_bytes > 0 && forward.list_bytes == 0);
        assert!(plus.issued < forward.issued, "{} >= {}", plus.issued, forward.issued);
    }
}
