//! `shadetrace demo`, the README's main command: captures every built-in scene, compares
//! every preset on each, and writes one HTML report.

use std::path::PathBuf;

use shadetrace_capture::procedural::BUILTIN_SCENES;
use shadetrace_capture::{capture, CaptureOptions, Input};
use shadetrace_formats::DEFAULT_ZSTD_LEVEL;
use shadetrace_replay::{load_trace, ReplayOptions};

use super::compare::{preset_list, run_presets, ImageFrames};
use super::replay::remove_if_present;
use super::summary;
use crate::report::{write_html, ReportSection, TraceSummary};
use shadetrace_formats::atomic_file::write_atomically;
use shadetrace_replay::options::parse_resolution;

#[derive(clap::Args)]
pub struct Args {
    /// Output directory.
    #[arg(long, default_value = "demo-report")]
    out: PathBuf,
    /// Per-eye resolution of the demo replays (captures keep the paper's 1280x1440).
    #[arg(long, default_value = "640x720", value_parser = parse_resolution)]
    res: (u32, u32),
    /// No progress bars, no tables.
    #[arg(short, long)]
    quiet: bool,
}

pub fn run(args: Args) -> Result<(), String> {
    let started = std::time::Instant::now();
    let traces_dir = args.out.join("traces");
    std::fs::create_dir_all(&traces_dir).map_err(|e| format!("{}: {e}", traces_dir.display()))?;
    remove_if_present(&args.out.join("index.html"))?;
    let presets = preset_list(&[])?;
    let opts = ReplayOptions {
        resolution: Some(args.res),
        ..ReplayOptions::default()
    };
    let mut all_runs = Vec::new();
    let mut traces = Vec::new();
    for (scene, (name, _)) in BUILTIN_SCENES.iter().enumerate() {
        let captured = capture(
            &Input::Builtin(name.to_string()),
            &CaptureOptions::default(),
            &mut |_, _| {},
        )
        .map_err(|e| e.to_string())?;
        let path = traces_dir.join(format!("{name}.strace"));
        write_atomically(&path, |w| {
            captured
                .write(w, DEFAULT_ZSTD_LEVEL)
                .map(|_| ())
                .map_err(|e| e.to_string())
        })?;
        let trace = load_trace(&path)?;
        let dir = args.out.join(name);
        std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        // One plain line per scene on stdout, with a terminal or without.
        let what = format!("scene {}/{} {name}", scene + 1, BUILTIN_SCENES.len());
        if !args.quiet {
            println!("== {what} ({} presets)", presets.len());
        }
        let runs = run_presets(&trace, &presets, &opts, &dir, ImageFrames::First, &what, args.quiet)?;
        if !args.quiet {
            let results: Vec<_> = runs.runs.iter().map(|r| &r.result).collect();
            println!("{}", summary::table(&results).trim_end());
        }
        traces.push(TraceSummary::of(&trace));
        all_runs.push((name, runs));
    }
    let sections: Vec<ReportSection> = traces
        .into_iter()
        .zip(&all_runs)
        .map(|(trace, (name, runs))| ReportSection {
            trace,
            runs: &runs.runs,
            skipped: &runs.skipped,
            files: name.to_string(),
            pictures: true,
        })
        .collect();
    let note = format!(
        "Demo at {}x{} per eye, 1 frame per scene (paper resolution 1280x1440: use `shadetrace compare`). \
         Made in {:.0} s.",
        args.res.0,
        args.res.1,
        started.elapsed().as_secs_f64()
    );
    let html = args.out.join("index.html");
    write_html(
        &html,
        "shadetrace demo: every built-in scene, every preset",
        &note,
        &sections,
    )?;
    println!("wrote {}", html.display());
    Ok(())
}
