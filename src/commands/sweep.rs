//! `shadetrace sweep`: the cost-versus-quality curve of one preset over a range of
//! refinement-threshold scales (0 = refine everything, inf = never refine), against the
//! reference run once.

use std::io::Write;
use std::path::PathBuf;

use shadetrace_replay::{load_trace, replay_all, Preset, ReplayOptions};

use crate::progress;
use crate::report::figure::{self, CostQuality};
use shadetrace_formats::atomic_file::{write_atomically, write_bytes_atomically};

#[derive(clap::Args)]
pub struct Args {
    /// Trace file (.strace).
    trace: PathBuf,
    /// Preset to sweep (a multi-rate preset: the scale multiplies its refinement thresholds).
    #[arg(long, default_value = "he-2x2")]
    preset: String,
    /// Threshold scales to run, comma-separated (`inf` allowed).
    #[arg(long, value_delimiter = ',', default_value = "0,0.25,0.5,1,2,4,16,inf")]
    scales: Vec<f32>,
    #[command(flatten)]
    replay: ReplayOptions,
    /// Output directory for sweep.csv, sweep.svg and sweep.png.
    #[arg(long, default_value = "sweep-out")]
    out: PathBuf,
    /// No progress bar.
    #[arg(short, long)]
    quiet: bool,
}

pub fn run(args: Args) -> Result<(), String> {
    let preset = Preset::find(&args.preset)?;
    if !preset.scheme_info().has_thresholds {
        return Err(format!(
            "--preset {}: sweeping thresholds needs a scheme with refinement thresholds",
            args.preset
        ));
    }
    let base = args.replay.clone();
    base.check()?;
    let trace = load_trace(&args.trace)?;
    let runs: Vec<_> = args
        .scales
        .iter()
        .map(|&scale| {
            let mut opts = base.clone();
            opts.multirate.threshold_scale = scale;
            (preset, opts)
        })
        .collect();
    let frames = base.frames.map_or(trace.frames.len() as u32, |(a, b)| b - a);
    let bar = progress::replay_bar(frames, runs.len(), "sweep", args.quiet);
    let outs = replay_all(&trace, &runs, Some(&base), &mut |_, _| Ok(()), &mut |step| {
        bar.replay_step(step, frames)
    })?;
    bar.finish_and_clear();
    let mut rows = Vec::new();
    for (out, &scale) in outs.iter().zip(&args.scales) {
        let t = &out.result.total;
        let refined: u64 = out
            .result
            .frames
            .iter()
            .flat_map(|f| &f.views)
            .filter_map(|v| v.refined_pixels)
            .map(|r| r.any)
            .sum();
        let shaded: u64 = out
            .result
            .frames
            .iter()
            .flat_map(|f| &f.views)
            .map(|v| v.raster.fragments_shaded)
            .sum();
        rows.push((
            scale,
            t.relative_cost.unwrap_or(f64::NAN),
            t.min_ssim.unwrap_or(f64::NAN),
            refined as f64 / shaded.max(1) as f64,
        ));
    }
    std::fs::create_dir_all(&args.out).map_err(|e| format!("{}: {e}", args.out.display()))?;
    let mut csv = String::from("threshold_scale,relative_cost,min_ssim,refined_fraction\n");
    println!(
        "{:>10} {:>14} {:>10} {:>9}",
        "scale", "relative cost", "min SSIM", "refined"
    );
    for &(scale, cost, ssim, refined) in &rows {
        csv.push_str(&format!("{scale},{cost},{ssim},{refined}\n"));
        println!(
            "{scale:>10} {:>13.2}% {ssim:>10.6} {:>8.1}%",
            100.0 * cost,
            100.0 * refined
        );
    }
    write_atomically(&args.out.join("sweep.csv"), |w| {
        w.write_all(csv.as_bytes()).map_err(|e| e.to_string())
    })?;
    let points: Vec<(String, f64, f64)> = rows
        .iter()
        .map(|&(scale, cost, ssim, _)| (format!("x{scale}"), 100.0 * cost, ssim))
        .collect();
    let plot = figure::render(&CostQuality {
        points: &points,
        joined: true,
    })?;
    write_bytes_atomically(&args.out.join("sweep.svg"), plot.svg.as_bytes())?;
    write_bytes_atomically(&args.out.join("sweep.png"), &plot.png)?;
    if !args.quiet {
        println!(
            "wrote {}, sweep.svg and sweep.png",
            args.out.join("sweep.csv").display()
        );
    }
    Ok(())
}
