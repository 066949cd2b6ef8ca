//! `shadetrace compare`: one trace, several presets, all against the reference; a terminal
//! table, `summary.csv`, per-preset results and images, and a self-contained `index.html`.

use std::path::{Path, PathBuf};

use shadetrace_replay::{
    load_trace, replay_all, LoadedTrace, Preset, ReplayOptions, RunOutput, PRESETS, REFERENCE_PRESET,
};

use super::replay::{clear_previous_run, remove_if_present, write_frame_images, write_results};
use super::summary;
use crate::progress;
use crate::report::{self, write_html, ReportSection, TraceSummary};

#[derive(clap::Args)]
pub struct Args {
    /// Trace file (.strace).
    trace: PathBuf,
    /// Presets to compare, comma-separated (default: every preset). The reference
    /// (`forward`) always runs first.
    #[arg(long, value_delimiter = ',')]
    presets: Vec<String>,
    #[command(flatten)]
    replay: ReplayOptions,
    /// Output directory.
    #[arg(long, default_value = "compare-out")]
    out: PathBuf,
    /// Which frames' pictures to write per preset: the first (what the report shows), all,
    /// or none.
    #[arg(long, value_enum, default_value_t = ImageFrames::First)]
    images: ImageFrames,
    /// No progress bars, no table.
    #[arg(short, long)]
    quiet: bool,
}

/// Which frames' pictures a run writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum ImageFrames {
    First,
    All,
    None,
}

/// The presets to run: the reference first, then the others in the order given.
pub fn preset_list(names: &[String]) -> Result<Vec<Preset>, String> {
    let mut presets = vec![Preset::find(REFERENCE_PRESET)?];
    let names: Vec<String> = if names.is_empty() {
        PRESETS.iter().map(|p| p.name.to_string()).collect()
    } else {
        names.to_vec()
    };
    for name in names {
        let preset = Preset::find(&name)?;
        if preset.label() != REFERENCE_PRESET && !presets.iter().any(|p| p.label() == preset.label()) {
            presets.push(preset);
        }
    }
    Ok(presets)
}

/// The runs of one trace, and why the presets it could not run were left out.
pub struct PresetRuns {
    pub runs: Vec<RunOutput>,
    pub skipped: Vec<String>,
}

/// Runs every preset on `trace` against the reference, frame by frame, and writes
/// per-preset images and results and `summary.csv` into `dir`. Presets the trace cannot run
/// are reported and left out. `what` names the job in progress lines.
pub fn run_presets(
    trace: &LoadedTrace,
    presets: &[Preset],
    opts: &ReplayOptions,
    dir: &Path,
    images: ImageFrames,
    what: &str,
    quiet: bool,
) -> Result<PresetRuns, String> {
    let mut runnable = Vec::new();
    let mut skipped = Vec::new();
    for preset in presets {
        match preset.supports(&trace.prepared.scene) {
            Ok(()) => runnable.push((*preset, opts.clone())),
            Err(why) => {
                if !quiet {
                    println!("skipped: {why}");
                }
                skipped.push(why);
            }
        }
    }
    let dirs: Vec<(PathBuf, bool)> = runnable
        .iter()
        .map(|(p, _)| (dir.join(p.label()), p.scheme_info().reports_refinement))
        .collect();
    let figures = report::FIGURES
        .iter()
        .flat_map(|f| [format!("{f}.svg"), format!("{f}.png")]);
    for name in ["summary.csv", "frames.csv", "index.html"]
        .map(String::from)
        .into_iter()
        .chain(figures)
    {
        remove_if_present(&dir.join(name))?;
    }
    for (preset_dir, _) in &dirs {
        std::fs::create_dir_all(preset_dir).map_err(|e| format!("{}: {e}", preset_dir.display()))?;
        clear_previous_run(preset_dir)?;
    }
    let frames = opts.frames.map_or(trace.frames.len() as u32, |(a, b)| b - a);
    let first = opts.frames.map_or(0, |(a, _)| a);
    let bar = progress::replay_bar(frames, runnable.len(), what, quiet);
    let runs = replay_all(
        trace,
        &runnable,
        Some(opts),
        Some(&mut |i, pictures| match images {
            ImageFrames::All => write_frame_images(&dirs[i].0, pictures, dirs[i].1),
            ImageFrames::First if pictures.frame == first => write_frame_images(&dirs[i].0, pictures, dirs[i].1),
            _ => Ok(()),
        }),
        &mut |step| bar.replay_step(step, frames),
    )?;
    bar.finish_and_clear();
    for (run, (preset_dir, _)) in runs.iter().zip(&dirs) {
        write_results(preset_dir, &run.result)?;
    }
    let results: Vec<_> = runs.iter().map(|r| &r.result).collect();
    summary::write_csv(&dir.join("summary.csv"), &results)?;
    summary::write_frames_csv(&dir.join("frames.csv"), &results)?;
    Ok(PresetRuns { runs, skipped })
}

pub fn run(args: Args) -> Result<(), String> {
    let presets = preset_list(&args.presets)?;
    let opts = args.replay.clone();
    opts.check()?;
    let trace = load_trace(&args.trace)?;
    std::fs::create_dir_all(&args.out).map_err(|e| format!("{}: {e}", args.out.display()))?;
    let PresetRuns { runs, skipped } =
        run_presets(&trace, &presets, &opts, &args.out, args.images, &trace.name, args.quiet)?;
    let note = match opts.resolution {
        Some((w, h)) => format!(
            "Replayed at {w}x{h} per eye (the trace was captured at {}x{}).",
            trace.meta.capture.eye_width, trace.meta.capture.eye_height
        ),
        None => "Replayed at the trace's resolution.".to_string(),
    };
    let section = ReportSection {
        trace: TraceSummary::of(&trace),
        runs: &runs,
        skipped: &skipped,
        files: String::new(),
        pictures: args.images != ImageFrames::None,
    };
    let html = args.out.join("index.html");
    write_html(&html, &format!("shadetrace compare: {}", trace.name), &note, &[section])?;
    if !args.quiet {
        let results: Vec<_> = runs.iter().map(|r| &r.result).collect();
        println!("{}", summary::table(&results).trim_end());
        println!(
            "wrote {} and {}",
            args.out.join("summary.csv").display(),
            html.display()
        );
    }
    Ok(())
}
