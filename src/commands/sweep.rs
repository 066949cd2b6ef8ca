//! `shadetrace sweep SPEC.toml`: a parameter study (traces x presets x option points, see
//! `sweep::spec`) into a results store, resumable and sharded over a cluster's array jobs.
//!
//! The unit of work is a job group, one trace at one option point: its presets replay in
//! lockstep against one reference run (as `compare` does) and are committed to the store
//! together, so a killed sweep loses only the group in flight and a re-run replays only the
//! jobs the store lacks.

use std::path::{Path, PathBuf};
use std::time::Instant;

use sha2::{Digest, Sha256};
use shadetrace_formats::atomic_file::write_bytes_atomically;
use shadetrace_formats::results::{stage_names, traffic_names};
use shadetrace_replay::{load_trace, replay_all, LoadedTrace, Preset, ReplayOptions};

use super::summary::{extra_names, frame_header, frame_rows};
use crate::progress;
use crate::sweep::shard::{self, Shard};
use crate::sweep::spec::{self, Point};
use crate::sweep::store::{JobRows, Store};

#[derive(clap::Args)]
pub struct Args {
    /// The sweep's spec (TOML: traces, presets, frames, options, grid, points; README, Sweeps).
    spec: PathBuf,
    /// Folder of the results store (sweep.db, or shard-I-of-N.db when sharded) and frames.csv.
    #[arg(long, default_value = "sweep-out")]
    out: PathBuf,
    /// Run shard I of N (0-based); by default taken from SLURM_ARRAY_TASK_ID/COUNT (or
    /// _MIN/_MAX), or JOB_COMPLETION_INDEX with --shards.
    #[arg(long, value_parser = Shard::parse)]
    shard: Option<Shard>,
    /// The number of shards of a Kubernetes Indexed Job (its completions).
    #[arg(long)]
    shards: Option<u32>,
    /// Stop after this many job groups (e.g. to fit a time-limited allocation); a re-run
    /// goes on where this one stopped.
    #[arg(long)]
    limit: Option<usize>,
    /// Write OUT/sweep.sbatch, a Slurm job array of N shards, and exit.
    #[arg(long, value_name = "N")]
    emit_slurm: Option<u32>,
    /// Write OUT/sweep-job.yaml, a Kubernetes Indexed Job of N shards, and exit.
    #[arg(long, value_name = "N")]
    emit_k8s: Option<u32>,
    /// Container image of the Kubernetes Job (with `shadetrace` on its PATH).
    #[arg(long, default_value = "shadetrace:latest")]
    k8s_image: String,
    /// Persistent volume claim holding the spec, traces and OUT, mounted at this folder.
    #[arg(long, default_value = "shadetrace-data")]
    k8s_claim: String,
    /// No progress, no summary.
    #[arg(short, long)]
    quiet: bool,
}

/// One trace at one option point, with the jobs (presets) it holds.
struct Group {
    trace: usize,
    point: usize,
    /// `(preset, job key)` in spec order.
    jobs: Vec<(Preset, String)>,
    /// Index of the group's first job in the spec's expansion.
    first_job: u64,
    /// Estimated cost: triangles x pixels x frames x replays (presets and the reference).
    cost: u64,
}

pub fn run(args: Args) -> Result<(), String> {
    let spec = spec::read(&args.spec)?;
    if let Some(n) = args.emit_slurm {
        return emit(&args, &slurm_script(&args, n)?, "sweep.sbatch", "sbatch");
    }
    if let Some(n) = args.emit_k8s {
        return emit(&args, &k8s_job(&args, n)?, "sweep-job.yaml", "kubectl apply -f");
    }
    let traces = spec
        .traces
        .iter()
        .map(|t| load_trace(t))
        .collect::<Result<Vec<_>, _>>()?;
    let groups = groups(&spec.presets, &spec.points, &traces);
    let spec_hash = {
        let mut h = Sha256::new();
        for (_, key) in groups.iter().flat_map(|g| &g.jobs) {
            h.update(key.as_bytes());
            h.update(b"\n");
        }
        hex(&h.finalize())
    };
    let shard = match args.shard {
        Some(shard) => shard,
        None => Shard::from_env(&|name| std::env::var(name).ok(), args.shards)?.unwrap_or(Shard::WHOLE),
    };
    let owner = shard::assign(&groups.iter().map(|g| g.cost).collect::<Vec<_>>(), shard.count);
    std::fs::create_dir_all(&args.out).map_err(|e| format!("{}: {e}", args.out.display()))?;
    let store_path = args.out.join(shard.store_name());
    let mut store = Store::open(&store_path, &spec_hash)?;

    // This shard's groups, each with the jobs the store still lacks.
    let mut todo = Vec::new();
    let (mut mine, mut done) = (0, 0);
    for (group, _) in groups.iter().zip(&owner).filter(|(_, &s)| s == shard.index) {
        mine += group.jobs.len();
        let mut pending = Vec::new();
        for (i, (_, key)) in group.jobs.iter().enumerate() {
            if store.has_job(key)? {
                done += 1;
            } else {
                pending.push(i);
            }
        }
        if !pending.is_empty() {
            todo.push((group, pending));
        }
    }
    todo.truncate(args.limit.unwrap_or(usize::MAX));
    let frames_of = |g: &Group| frame_count(&traces[g.trace], &spec.points[g.point].options);
    let units: u64 = todo.iter().map(|(g, p)| u64::from(frames_of(g)) * p.len() as u64).sum();
    let bar = progress::bar(units, "sweep", args.quiet);
    let started = Instant::now();
    let (mut units_done, mut ran) = (0u64, 0);
    for (n, (group, pending)) in todo.iter().enumerate() {
        let (trace, point) = (&traces[group.trace], &spec.points[group.point]);
        let runs: Vec<(Preset, ReplayOptions)> = pending
            .iter()
            .map(|&i| (group.jobs[i].0, point.options.clone()))
            .collect();
        let frames = frames_of(group);
        let what = format!("group {}/{} ({}, {})", n + 1, todo.len(), trace.name, point.label);
        let group_started = Instant::now();
        let outputs = replay_all(trace, &runs, Some(&point.options), None, &mut |step| {
            bar.set_position_with(units_done + step.units_done(), &what)
        })?;
        let wall_s = group_started.elapsed().as_secs_f64() / outputs.len().max(1) as f64;
        let jobs: Vec<JobRows> = pending
            .iter()
            .zip(&outputs)
            .map(|(&i, out)| {
                let r = &out.result;
                let stages = stage_names([&r.total.cost]);
                let classes = traffic_names([&r.total.traffic]);
                let extras = extra_names([r]);
                JobRows {
                    key: group.jobs[i].1.clone(),
                    index: group.first_job + i as u64,
                    trace: trace.name.clone(),
                    trace_hash: trace.hash.to_string(),
                    preset: r.preset.clone(),
                    point: point.label.clone(),
                    options_hash: point.options.hash(),
                    frames: frames_text(&point.options),
                    wall_s,
                    header: frame_header(&stages, &classes, &extras),
                    rows: frame_rows(r, &stages, &classes, &extras),
                }
            })
            .collect();
        store.commit(&jobs, &point.values)?;
        ran += jobs.len();
        units_done += u64::from(frames) * pending.len() as u64;
    }
    bar.finish_and_clear();
    let left = mine - done - ran;
    if shard == Shard::WHOLE && left == 0 {
        store.export_csv(&args.out.join("frames.csv"))?;
    }
    if !args.quiet {
        println!(
            "shard {}/{}: ran {ran} jobs in {:.1} s, {done} were already in {}, {left} left{}",
            shard.index,
            shard.count,
            started.elapsed().as_secs_f64(),
            store_path.display(),
            if left > 0 { " (run again to go on)" } else { "" }
        );
    }
    Ok(())
}

/// Every (trace, point) group in spec order (traces outer, points inner), with its jobs' keys
/// `sha256(trace hash, preset, options hash, frames)`.
fn groups(presets: &[Preset], points: &[Point], traces: &[LoadedTrace]) -> Vec<Group> {
    let mut groups = Vec::new();
    let mut first_job = 0u64;
    for (t, trace) in traces.iter().enumerate() {
        for (p, point) in points.iter().enumerate() {
            let options_hash = point.options.hash();
            let frames = frames_text(&point.options);
            let jobs: Vec<(Preset, String)> = presets
                .iter()
                .map(|preset| {
                    let key = format!("{}\n{}\n{options_hash}\n{frames}", trace.hash, preset.label());
                    (*preset, hex(&Sha256::digest(key.as_bytes())))
                })
                .collect();
            let (w, h) = point
                .options
                .resolution
                .unwrap_or((trace.meta.capture.eye_width, trace.meta.capture.eye_height));
            let cost = trace.meta.counts.triangles.max(1)
                * 2
                * u64::from(w)
                * u64::from(h)
                * u64::from(frame_count(trace, &point.options))
                * (jobs.len() as u64 + 1);
            let count = jobs.len() as u64;
            groups.push(Group {
                trace: t,
                point: p,
                jobs,
                first_job,
                cost,
            });
            first_job += count;
        }
    }
    groups
}

fn frame_count(trace: &LoadedTrace, options: &ReplayOptions) -> u32 {
    options
        .frames
        .map_or(trace.frames.len() as u32, |(a, b)| b.saturating_sub(a))
}

/// A job's frames as the store keeps them: `START..END`, or `all`.
fn frames_text(options: &ReplayOptions) -> String {
    options.frames.map_or("all".to_string(), |(a, b)| format!("{a}..{b}"))
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// Writes a cluster script into OUT and says how to submit it.
fn emit(args: &Args, text: &str, name: &str, submit: &str) -> Result<(), String> {
    std::fs::create_dir_all(&args.out).map_err(|e| format!("{}: {e}", args.out.display()))?;
    let path = args.out.join(name);
    write_bytes_atomically(&path, text.as_bytes())?;
    println!(
        "wrote {}; submit it with `{submit} {}`, then `shadetrace merge {}/shard-*.db -o {}/merged`",
        path.display(),
        path.display(),
        args.out.display(),
        args.out.display()
    );
    Ok(())
}

/// `path` made absolute against the current folder.
fn absolute(path: &Path) -> Result<PathBuf, String> {
    std::path::absolute(path).map_err(|e| format!("{}: {e}", path.display()))
}

/// A word for a POSIX shell, single-quoted.
fn shell_word(text: &str) -> String {
    format!("'{}'", text.replace('\'', r"'\''"))
}

/// An sbatch script for a job array of `n` tasks: each runs its shard (from the array's
/// environment) of this spec into OUT.
fn slurm_script(args: &Args, n: u32) -> Result<String, String> {
    if n == 0 {
        return Err("--emit-slurm 0: give the number of shards".into());
    }
    let exe = std::env::current_exe().map_err(|e| format!("the shadetrace binary: {e}"))?;
    let (spec, out) = (absolute(&args.spec)?, absolute(&args.out)?);
    let word = |p: &Path| shell_word(&p.display().to_string());
    Ok(format!(
        "#!/bin/bash\n\
         # shadetrace sweep {spec_name}: {n} shards as a Slurm job array. Submit with `sbatch {script}`;\n\
         # each task writes {out_name}/shard-I-of-{n:04}.db, then merge them:\n\
         #   shadetrace merge {out_name}/shard-*.db -o {out_name}/merged\n\
         #SBATCH --job-name=shadetrace-sweep\n\
         #SBATCH --array=0-{last}\n\
         #SBATCH --ntasks=1\n\
         #SBATCH --output={log}\n\
         set -euo pipefail\n\
         exec {exe} sweep {spec_word} --out {out_word} --quiet\n",
        spec_name = spec.display(),
        script = out.join("sweep.sbatch").display(),
        out_name = out.display(),
        last = n - 1,
        log = out.join("slurm-%A_%a.log").display(),
        exe = word(&exe),
        spec_word = word(&spec),
        out_word = word(&out),
    ))
}

/// A Kubernetes Indexed Job of `n` completions. The claim is mounted at the current folder,
/// so the spec and OUT must lie inside it (their paths are the same in the pod).
fn k8s_job(args: &Args, n: u32) -> Result<String, String> {
    if n == 0 {
        return Err("--emit-k8s 0: give the number of shards".into());
    }
    let cwd = std::env::current_dir().map_err(|e| format!("the current folder: {e}"))?;
    let inside = |p: &Path| -> Result<String, String> {
        let abs = absolute(p)?;
        abs.strip_prefix(&cwd).map(|_| abs.display().to_string()).map_err(|_| {
            format!(
                "{}: for --emit-k8s it must lie inside the current folder (the mounted claim)",
                p.display()
            )
        })
    };
    let (spec, out) = (inside(&args.spec)?, inside(&args.out)?);
    let json = |s: &str| serde_json::to_string(s).unwrap_or_default();
    Ok(format!(
        "# shadetrace sweep as a Kubernetes Indexed Job of {n} shards: `kubectl apply -f` this file; each pod\n\
         # writes {out_plain}/shard-I-of-{n:04}.db on the claim, then merge them with `shadetrace merge`.\n\
         apiVersion: batch/v1\n\
         kind: Job\n\
         metadata:\n  name: shadetrace-sweep\n\
         spec:\n  completions: {n}\n  parallelism: {n}\n  completionMode: Indexed\n  backoffLimitPerIndex: 2\n\
         \x20 template:\n    spec:\n      restartPolicy: Never\n      containers:\n\
         \x20     - name: sweep\n        image: {image}\n        workingDir: {cwd}\n\
         \x20       command: [\"shadetrace\", \"sweep\", {spec}, \"--out\", {out}, \"--shards\", \"{n}\", \"--quiet\"]\n\
         \x20       volumeMounts:\n        - name: data\n          mountPath: {cwd}\n\
         \x20     volumes:\n      - name: data\n        persistentVolumeClaim:\n          claimName: {claim}\n",
        image = json(&args.k8s_image),
        cwd = json(&cwd.display().to_string()),
        spec = json(&spec),
        out_plain = out,
        out = json(&out),
        claim = json(&args.k8s_claim),
    ))
}
