//! `cargo bench`: the reference replay (forward), sort-middle and the multi-rate schemes
//! (he-2x2, tile-pair, amfs, texel) at the paper resolution, 1280x1440 per eye, on the
//! floor, spheres and hairball scenes. Prints shaded pixels per second and milliseconds per
//! stereo frame. Speed targets live here, never in tests. `SHADETRACE_BENCH_PRESETS`
//! (comma-separated) picks other presets.
//!
//! A plain harness (no criterion): each measurement is one full stereo frame, repeated
//! `SHADETRACE_BENCH_REPS` times (default 3), best time reported.

use std::time::Instant;

use shadetrace_capture::{capture, CaptureOptions, Input};
use shadetrace_replay::{pipeline::PreparedScene, replay_all, LoadedTrace, Preset, ReplayOptions};

fn main() {
    let reps: usize = std::env::var("SHADETRACE_BENCH_REPS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(3);
    let presets: Vec<String> = std::env::var("SHADETRACE_BENCH_PRESETS")
        .unwrap_or_else(|_| "forward,sort-middle,he-2x2,tile-pair,amfs,texel".into())
        .split(',')
        .map(str::to_owned)
        .collect();
    println!("threads: {}", rayon::current_num_threads());
    println!(
        "{:<10} {:<12} {:>10} {:>14} {:>16}",
        "scene", "preset", "ms/frame", "Mpixels/s", "Mshaded frag/s"
    );
    for scene in ["floor", "spheres", "hairball"] {
        let captured = capture(
            &Input::Builtin(scene.into()),
            &CaptureOptions::default(),
            &mut |_, _| {},
        )
        .unwrap();
        let (_, hash) = captured.write(std::io::sink(), 1).unwrap();
        let trace = LoadedTrace {
            name: scene.into(),
            hash,
            meta: captured.meta.clone(),
            prepared: PreparedScene::new(captured.scene.clone()),
            frames: captured.frames.clone(),
        };
        for name in &presets {
            let preset = Preset::find(name).unwrap_or_else(|e| panic!("{e}"));
            let opts = ReplayOptions::default();
            let mut best = f64::INFINITY;
            let mut shaded = 0;
            for _ in 0..reps {
                let t = Instant::now();
                let out = match replay_all(&trace, &[(preset, opts.clone())], None, &mut |_, _| Ok(()), &mut |_| {}) {
                    Ok(mut runs) => runs.remove(0),
                    // texel refuses a scene without a unique UV atlas.
                    Err(e) => {
                        println!("{scene:<10} {name:<12} skipped: {e}");
                        break;
                    }
                };
                best = best.min(t.elapsed().as_secs_f64());
                shaded = out.result.total.shaded_pixels;
            }
            if best.is_infinite() {
                continue;
            }
            let pixels = 2.0 * 1280.0 * 1440.0;
            println!(
                "{:<10} {:<12} {:>10.1} {:>14.2} {:>16.2}",
                scene,
                preset.name,
                best * 1e3,
                pixels / best / 1e6,
                shaded as f64 / best / 1e6
            );
        }
    }
}
