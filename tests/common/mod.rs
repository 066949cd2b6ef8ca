//! Helpers shared by the integration tests that drive the `shadetrace` binary.

#![allow(dead_code)]

use std::path::Path;
use std::process::{Command, Output};

use serde_json::Value;

/// Runs `shadetrace` in the repository root, optionally with `RAYON_NUM_THREADS`.
pub fn shadetrace(args: &[&str], threads: Option<&str>) -> Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_shadetrace"));
    cmd.args(args).current_dir(env!("CARGO_MANIFEST_DIR"));
    if let Some(t) = threads {
        cmd.env("RAYON_NUM_THREADS", t);
    }
    cmd.output().unwrap()
}

/// Runs `shadetrace` and asserts it succeeded.
pub fn shadetrace_ok(args: &[&str], threads: Option<&str>) -> Output {
    let out = shadetrace(args, threads);
    assert!(
        out.status.success(),
        "shadetrace {args:?} failed: {}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// Path of a committed corpus trace.
pub fn trace(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("traces")
        .join(format!("{name}.strace"))
        .display()
        .to_string()
}

/// `results.json` of a replay output directory, wall-clock timing removed.
pub fn results(dir: &Path) -> Value {
    let mut v: Value = serde_json::from_str(&std::fs::read_to_string(dir.join("results.json")).unwrap()).unwrap();
    v.as_object_mut().unwrap().remove("timing");
    v
}

/// Checks a replay's results at extreme settings: every view was compared with the reference
/// (quality present), and every view that shaded anything has a positive, finite relative
/// cost. (Non-finite floats never reach results.json: the writer refuses them.)
pub fn assert_sane(v: &Value, what: &str) {
    // `results` strips the wall-clock timing; put a neutral one back to parse the rest.
    let mut v = v.clone();
    v["timing"] = serde_json::json!({"wall_s": 0.0, "threads": 1, "pixels_per_s": 0.0});
    let r: shadetrace_formats::results::RunResult = serde_json::from_value(v).expect("results parse");
    for frame in &r.frames {
        for view in &frame.views {
            assert!(view.quality.is_some(), "{what}: no quality for {}", view.eye);
            if view.cost.issued() > 0 {
                let rel = view.relative_cost.expect("a relative cost");
                assert!(rel.is_finite() && rel > 0.0, "{what}: relative cost {rel}");
            }
        }
    }
}

/// Replays `trace` with `preset` and extra flags into `out`, asserting success; returns
/// its `results.json` (timing removed).
pub fn replay_into(trace: &str, preset: &str, extra: &[&str], threads: Option<&str>, out: &Path) -> Value {
    let out_arg = out.display().to_string();
    let mut args = vec!["replay", trace, "--preset", preset, "--out", &out_arg, "--quiet"];
    args.extend_from_slice(extra);
    shadetrace_ok(&args, threads);
    results(out)
}
