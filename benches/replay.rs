//! `cargo bench`: one stereo frame at the paper resolution, 1280x1440 per eye, of the
//! reference (forward), sort-middle and the multi-rate schemes (he-2x2, tile-pair, amfs,
//! texel) on the floor, spheres and hairball scenes, at 1 and 2 threads. divan reports time
//! per frame and pixels per second (items/s: both eyes). These scenes do not move, so their
//! shadow map is rendered once per run and the frames timed here are the steady state of a
//! long run. Speed targets live here, never in tests; compare against Mesa's llvmpipe with
//! `scripts/bench-llvmpipe.sh`.
//!
//! divan (not criterion): a small build on 2 cores (it reuses clap) and per-argument
//! sample counts, so a one-second frame is timed three times rather than for a fixed
//! measurement window. Filter as usual: `cargo bench -- spheres`.

use std::collections::BTreeMap;
use std::fmt;
use std::sync::{Mutex, OnceLock};

use divan::counter::ItemsCount;
use divan::Bencher;
use shadetrace_capture::{capture, CaptureOptions, Input};
use shadetrace_replay::{pipeline::PreparedScene, replay_all, LoadedTrace, Preset, ReplayOptions};

fn main() {
    divan::main();
}

/// A scene and a preset; texel runs only where the scene has a unique UV atlas (spheres).
#[derive(Clone, Copy)]
struct Case(&'static str, &'static str);

impl fmt::Display for Case {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        write!(f, "{}/{}", self.0, self.1)
    }
}

/// A case at a thread count (rayon's pool size).
#[derive(Clone, Copy)]
struct Threaded(Case, usize);

impl fmt::Display for Threaded {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        write!(f, "{}/{}t", self.0, self.1)
    }
}

const THREADS: [usize; 2] = [1, 2];

fn cases() -> impl Iterator<Item = Threaded> {
    CASES
        .into_iter()
        .flat_map(|case| THREADS.into_iter().map(move |t| Threaded(case, t)))
}

const CASES: [Case; 16] = [
    Case("floor", "forward"),
    Case("floor", "sort-middle"),
    Case("floor", "he-2x2"),
    Case("floor", "tile-pair"),
    Case("floor", "amfs"),
    Case("spheres", "forward"),
    Case("spheres", "sort-middle"),
    Case("spheres", "he-2x2"),
    Case("spheres", "tile-pair"),
    Case("spheres", "amfs"),
    Case("spheres", "texel"),
    Case("hairball", "forward"),
    Case("hairball", "sort-middle"),
    Case("hairball", "he-2x2"),
    Case("hairball", "tile-pair"),
    Case("hairball", "amfs"),
];

/// Captured once per scene (capture is not what is measured).
fn trace(scene: &'static str) -> &'static LoadedTrace {
    static TRACES: OnceLock<Mutex<BTreeMap<&'static str, &'static LoadedTrace>>> = OnceLock::new();
    let mut traces = TRACES.get_or_init(Default::default).lock().unwrap();
    traces.entry(scene).or_insert_with(|| {
        let captured = capture(
            &Input::Builtin(scene.into()),
            &CaptureOptions::default(),
            &mut |_, _| {},
        )
        .unwrap_or_else(|e| panic!("{scene}: {e}"));
        let (_, hash) = captured.write(std::io::sink(), 1).unwrap();
        Box::leak(Box::new(LoadedTrace {
            name: scene.into(),
            hash,
            meta: captured.meta.clone(),
            prepared: PreparedScene::new(captured.scene.clone()),
            frames: vec![captured.frames[0].clone()],
        }))
    })
}

#[divan::bench(args = cases(), sample_count = 3, sample_size = 1)]
fn stereo_frame(bencher: Bencher, Threaded(case, threads): Threaded) {
    let trace = trace(case.0);
    let preset = Preset::find(case.1).unwrap_or_else(|e| panic!("{e}"));
    let runs = [(preset, ReplayOptions::default())];
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
    bencher
        .counter(ItemsCount::new(2 * 1280 * 1440usize))
        .bench(|| pool.install(|| replay_all(trace, &runs, None, None, &mut |_| {}).unwrap()));
}
