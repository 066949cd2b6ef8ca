//! He et al. multi-rate shading through the command line: threshold 0 reproduces the
//! reference exactly, infinity never refines, costs follow the paper's trends, and the SIMD
//! schedules rank as in its §6.3.

mod common;

use std::path::Path;

use common::{shadetrace_ok, trace};
use serde_json::Value;

/// Replays frame 0 of `trace_path` and returns results.json.
fn run(trace_path: &str, preset: &str, extra: &[&str], out: &Path) -> Value {
    let mut args = vec![
        "replay",
        trace_path,
        "--preset",
        preset,
        "--frames",
        "0",
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ];
    args.extend_from_slice(extra);
    shadetrace_ok(&args, None);
    serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap()
}

fn relative(v: &Value) -> f64 {
    v["total"]["relative_cost"].as_f64().unwrap()
}

#[test]
fn threshold_zero_reproduces_the_reference_exactly() {
    let dir = tempfile::tempdir().unwrap();
    for name in ["spheres", "depth-stack", "light-room"] {
        for preset in ["he-2x2", "he-4x4", "he-dynamic"] {
            let out = dir.path().join(format!("{name}-{preset}"));
            let v = run(
                &trace(name),
                preset,
                &["--res", "96x108", "--threshold-scale", "0"],
                &out,
            );
            for view in v["frames"][0]["views"].as_array().unwrap() {
                let q = &view["quality"];
                assert_eq!(q["max_abs_error"].as_u64(), Some(0), "{name}/{preset}: {q}");
                assert_eq!(q["ssim"].as_f64(), Some(1.0), "{name}/{preset}");
            }
        }
    }
}

#[test]
fn infinite_thresholds_never_refine() {
    let dir = tempfile::tempdir().unwrap();
    let default = run(
        &trace("spheres"),
        "he-2x2",
        &["--res", "160x180"],
        &dir.path().join("d"),
    );
    let never = run(
        &trace("spheres"),
        "he-2x2",
        &["--res", "160x180", "--threshold-scale", "inf"],
        &dir.path().join("n"),
    );
    assert!(
        relative(&never) < relative(&default),
        "{} !< {}",
        relative(&never),
        relative(&default)
    );
    for view in never["frames"][0]["views"].as_array().unwrap() {
        assert_eq!(view["refined_pixels"]["any"].as_u64(), Some(0), "{view}");
    }
    let refined = |v: &Value| v["frames"][0]["views"][0]["refined_pixels"]["any"].as_u64().unwrap();
    assert!(refined(&default) > 0);
    assert!(dir.path().join("n/frame0000-left-refine-shadow.png").exists());
}

#[test]
fn cost_follows_the_papers_trends() {
    let dir = tempfile::tempdir().unwrap();
    let res = ["--res", "320x360", "--no-images"];
    let floor2 = relative(&run(&trace("floor"), "he-2x2", &res, &dir.path().join("f2")));
    let floor4 = relative(&run(&trace("floor"), "he-4x4", &res, &dir.path().join("f4")));
    assert!(floor2 < 0.5 && floor4 < floor2, "floor: 2x2 {floor2}, 4x4 {floor4}");
    let hair2 = relative(&run(&trace("hairball"), "he-2x2", &res, &dir.path().join("h2")));
    assert!(
        hair2 > 0.6 && hair2 > floor2 + 0.15,
        "hairball 2x2 {hair2}: the benefit should mostly vanish"
    );

    // Tile-pair paper Fig. 9: He et al.'s cost rises as the tessellation gets finer.
    let mut costs = Vec::new();
    for subdiv in 1..=4 {
        let t = dir.path().join(format!("s{subdiv}.strace"));
        let spec = format!("builtin:spheres?subdiv={subdiv}");
        shadetrace_ok(
            &[
                "capture",
                &spec,
                "-o",
                t.to_str().unwrap(),
                "--res",
                "320x360",
                "--quiet",
            ],
            None,
        );
        costs.push(relative(&run(
            t.to_str().unwrap(),
            "he-2x2",
            &["--no-images"],
            &dir.path().join(format!("r{subdiv}")),
        )));
    }
    assert!(costs.windows(2).all(|w| w[1] > w[0]), "{costs:?}");
}

#[test]
fn two_phase_scheduling_beats_a_single_thread_of_control() {
    let dir = tempfile::tempdir().unwrap();
    let issued = |schedule: &str| {
        let v = run(
            &trace("floor"),
            "he-4x4",
            &[
                "--res",
                "320x360",
                "--simd",
                "32",
                "--simd-schedule",
                schedule,
                "--no-images",
                "--no-reference",
            ],
            &dir.path().join(schedule),
        );
        let c = &v["total"]["cost"];
        ["fine", "coarse", "reuse"]
            .iter()
            .map(|s| c[s]["alu"].as_u64().unwrap() + c[s]["tex"].as_u64().unwrap())
            .sum::<u64>()
    };
    let (single, two, sorted) = (issued("single-thread"), issued("two-phase"), issued("two-phase-sorted"));
    assert!(single as f64 > 1.3 * two as f64, "single {single} vs two-phase {two}");
    assert!(sorted <= two);
}

#[test]
fn golden_quality_is_above_99_9_percent() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("traces/golden");
    let mut seen = 0;
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        let v: Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
        if v["scheme"] != "multirate" {
            continue;
        }
        let ssim = v["total"]["min_ssim"].as_f64().unwrap();
        assert!(ssim > 0.999, "{}: SSIM {ssim}", path.display());
        seen += 1;
    }
    assert!(seen >= 15, "every multi-rate preset on five scenes: {seen} goldens");
}

#[test]
fn extremes_do_not_break_multirate() {
    let dir = tempfile::tempdir().unwrap();
    for (i, extra) in [
        vec!["--res", "1x1"],
        vec!["--res", "3x5", "--coarse-mode", "4x4"],
        vec!["--res", "64x72", "--tile", "4", "--coarse-mode", "dynamic"],
        vec!["--res", "64x72", "--simd", "64", "--sampling", "static-center"],
        vec![
            "--res",
            "64x72",
            "--simd",
            "8",
            "--sampling",
            "static-corner",
            "--small-triangle",
            "false",
        ],
        vec!["--res", "64x72", "--schedule", "sort-middle", "--msaa", "4"],
    ]
    .into_iter()
    .enumerate()
    {
        let v = run(&trace("depth-stack"), "he-2x2", &extra, &dir.path().join(i.to_string()));
        common::assert_sane(&v, &format!("{extra:?}"));
    }
}
