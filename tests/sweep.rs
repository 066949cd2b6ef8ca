//! `sweep SPEC.toml`, `merge` and `sweep-report`: a small study run whole, stopped and
//! resumed, sharded and merged, and summarized (scripts/slurm-test.sh does it on a real Slurm).

mod common;

use std::collections::BTreeMap;
use std::path::Path;

use common::{shadetrace, shadetrace_ok, trace};

/// 2 traces x 3 presets x 4 points at a small resolution.
fn write_spec(dir: &Path) -> String {
    let spec = format!(
        "traces = [{:?}, {:?}]\npresets = [\"forward\", \"tile-pair\", \"amfs\"]\nframes = \"0..1\"\n\
         [options]\nres = \"48x54\"\n[grid]\ntile = [8, 16]\ntexture-cache-kb = [8, 32]\n",
        trace("floor"),
        trace("spheres")
    );
    let path = dir.join("spec.toml");
    std::fs::write(&path, spec).unwrap();
    path.display().to_string()
}

/// A store's `frames.csv` as rows of (column -> value), empty values left out, so stores
/// whose columns were added in another order compare equal.
fn rows(csv_path: &Path) -> Vec<BTreeMap<String, String>> {
    let mut reader = csv::Reader::from_path(csv_path).unwrap();
    let header: Vec<String> = reader.headers().unwrap().iter().map(String::from).collect();
    reader
        .records()
        .map(|r| {
            header
                .iter()
                .cloned()
                .zip(r.unwrap().iter().map(String::from))
                .filter(|(_, v)| !v.is_empty())
                .collect()
        })
        .collect()
}

fn stdout(args: &[&str]) -> String {
    String::from_utf8_lossy(&shadetrace_ok(args, None).stdout).into_owned()
}

#[test]
fn a_sweep_resumes_and_its_shards_merge_into_the_unsharded_run() {
    let dir = tempfile::tempdir().unwrap();
    let spec = write_spec(dir.path());
    let out = |name: &str| dir.path().join(name).display().to_string();

    // Stopped after two groups, then resumed: nothing finished is replayed again.
    let first = stdout(&["sweep", &spec, "--out", &out("whole"), "--limit", "2"]);
    assert!(first.contains("ran 6 jobs") && first.contains("18 left"), "{first}");
    let second = stdout(&["sweep", &spec, "--out", &out("whole")]);
    assert!(
        second.contains("ran 18 jobs") && second.contains("6 were already in"),
        "{second}"
    );
    let third = stdout(&["sweep", &spec, "--out", &out("whole")]);
    assert!(
        third.contains("ran 0 jobs") && third.contains("24 were already in"),
        "{third}"
    );
    let whole = rows(&dir.path().join("whole/frames.csv"));
    assert_eq!(whole.len(), 24 * 2, "one row per job and view");

    // Four shards, each on its own, merged (twice: merging is idempotent).
    for i in 0..4 {
        shadetrace_ok(
            &[
                "sweep",
                &spec,
                "--out",
                &out("sharded"),
                "--shard",
                &format!("{i}/4"),
                "--quiet",
            ],
            None,
        );
    }
    let shards: Vec<String> = (0..4)
        .map(|i| out(&format!("sharded/shard-{i:04}-of-0004.db")))
        .collect();
    let merged = out("merged");
    let mut merge: Vec<&str> = vec!["merge"];
    merge.extend(shards.iter().map(String::as_str));
    merge.extend(["-o", &merged]);
    assert!(stdout(&merge).contains("24 jobs added, 24 in all"));
    assert!(stdout(&merge).contains("0 jobs added, 24 in all"));
    assert_eq!(
        rows(&dir.path().join("merged/frames.csv")),
        whole,
        "bit-identical counters"
    );

    // A store of another spec is refused.
    std::fs::write(
        dir.path().join("other.toml"),
        std::fs::read_to_string(&spec).unwrap().replace("[8, 16]", "[8, 32]"),
    )
    .unwrap();
    shadetrace_ok(
        &[
            "sweep",
            &out("other.toml"),
            "--out",
            &out("other"),
            "--limit",
            "1",
            "--quiet",
        ],
        None,
    );
    let o = shadetrace(
        &["merge", &shards[0], &out("other/sweep.db"), "-o", &out("mixed")],
        None,
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("another spec") && err.lines().count() == 1,
        "{err}"
    );
    assert!(!dir.path().join("mixed").exists(), "nothing written");

    // The summary: per preset and point, and per preset and option value.
    shadetrace_ok(&["sweep-report", &out("merged/sweep.db"), "--quiet"], None);
    let summary = rows(&dir.path().join("merged/sweep-summary.csv"));
    let line = |by: &str, preset: &str, value: &str| {
        summary
            .iter()
            .find(|r| r["by"] == by && r["preset"] == preset && r["value"] == value)
            .unwrap_or_else(|| panic!("no line {by} {preset} {value}"))
    };
    assert_eq!(
        line("point", "forward", "tile=8 texture-cache-kb=8")["relative_cost_pct_mean"],
        "100"
    );
    assert_eq!(
        line("tile", "amfs", "16")["rows"],
        "8",
        "2 traces x 2 cache sizes x 2 views"
    );
    assert!(dir.path().join("merged/sweep-report.html").is_file());
    assert!(dir.path().join("merged/sweep-cost-quality.png").is_file());
}

/// Threshold scale 0 refines everything (forward's result exactly), larger scales cost less.
#[test]
fn a_threshold_sweep_spans_refine_all_to_refine_none() {
    let dir = tempfile::tempdir().unwrap();
    let spec = dir.path().join("thresholds.toml");
    std::fs::write(
        &spec,
        format!(
            "traces = [{:?}]\npresets = [\"he-2x2\"]\nframes = \"0..1\"\n[options]\nres = \"96x108\"\n\
             [grid]\nthreshold-scale = [0, 1, inf]\n",
            trace("spheres")
        ),
    )
    .unwrap();
    let out = dir.path().join("out");
    shadetrace_ok(
        &[
            "sweep",
            spec.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--quiet",
        ],
        None,
    );
    let rows = rows(&out.join("frames.csv"));
    let cost = |scale: &str| -> f64 {
        let left = rows
            .iter()
            .find(|r| r["opt_threshold_scale"] == scale && r["eye"] == "left")
            .unwrap();
        left["relative_cost_pct"].parse().unwrap()
    };
    let zero = rows.iter().find(|r| r["opt_threshold_scale"] == "0").unwrap();
    assert_eq!(zero["ssim"], "1", "threshold 0 reproduces the reference");
    assert!(
        cost("0") > cost("1") && cost("1") > cost("inf"),
        "cost falls as thresholds rise"
    );
}

#[test]
fn bad_specs_name_the_line_and_cluster_scripts_submit_as_is() {
    let dir = tempfile::tempdir().unwrap();
    let spec = write_spec(dir.path());
    let bad = dir.path().join("bad.toml");
    std::fs::write(
        &bad,
        std::fs::read_to_string(&spec)
            .unwrap()
            .replace("tile = [8, 16]", "tiles = [8, 16]"),
    )
    .unwrap();
    let o = shadetrace(&["sweep", bad.to_str().unwrap()], None);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.lines().count() == 1, "{err}");
    assert!(err.contains("bad.toml:7:") && err.contains("tiles"), "{err}");

    let out = dir.path().join("out").display().to_string();
    shadetrace_ok(&["sweep", &spec, "--out", &out, "--emit-slurm", "4"], None);
    let sbatch = std::fs::read_to_string(dir.path().join("out/sweep.sbatch")).unwrap();
    assert!(
        sbatch.starts_with("#!/bin/bash\n") && sbatch.contains("#SBATCH --array=0-3\n"),
        "{sbatch}"
    );
    assert!(sbatch.contains(" sweep '") && sbatch.contains("--quiet"), "{sbatch}");
    let o = shadetrace(&["sweep", &spec, "--out", &out, "--emit-k8s", "4"], None);
    // The temporary folder is outside the repository (the working folder): refused.
    assert!(!o.status.success() && String::from_utf8_lossy(&o.stderr).contains("inside the current folder"));
    // Inside the working folder (the claim's mount) it writes an Indexed Job of 4 pods.
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_shadetrace"))
        .args([
            "sweep",
            "spec.toml",
            "--out",
            "out",
            "--emit-k8s",
            "4",
            "--k8s-image",
            "lab/shadetrace:1",
        ])
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let job = std::fs::read_to_string(dir.path().join("out/sweep-job.yaml")).unwrap();
    for line in [
        "kind: Job",
        "  completions: 4",
        "  parallelism: 4",
        "  completionMode: Indexed",
        "        image: \"lab/shadetrace:1\"",
        "\"--shards\", \"4\"",
        "claimName: \"shadetrace-data\"",
    ] {
        assert!(job.contains(line), "{line} missing from\n{job}");
    }
    // No shard in a Kubernetes pod without the Job's completions.
    let mut cmd = std::process::Command::new(env!("CARGO_BIN_EXE_shadetrace"));
    let o = cmd
        .args(["sweep", &spec, "--out", &out])
        .env("JOB_COMPLETION_INDEX", "1")
        .output()
        .unwrap();
    assert!(String::from_utf8_lossy(&o.stderr).contains("--shards"));
}
