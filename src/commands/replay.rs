//! `shadetrace replay`: one trace, one preset; results JSON and images.

use std::borrow::Cow;
use std::path::{Path, PathBuf};

use rayon::prelude::*;

use shadetrace_formats::results::RunResult;
use shadetrace_formats::results::{stage_names, traffic_names};
use shadetrace_replay::images::{
    heat_map, robust_max, side_by_side, Rgba8Image, ERROR_LABEL, ERROR_SCALE, SSIM_LOSS_LABEL, SSIM_LOSS_SCALE,
};
use shadetrace_replay::scheme::Effects;
use shadetrace_replay::{load_trace, replay_all, FrameImages, Preset, ReplayOptions, RunOutput, REFERENCE_PRESET};

use crate::progress;
use shadetrace_formats::atomic_file::write_atomically;

#[derive(clap::Args)]
pub struct Args {
    /// Trace file (.strace).
    trace: PathBuf,
    /// Preset name (see `shadetrace presets`) or SCHEDULER+SCHEME.
    #[arg(long, default_value = REFERENCE_PRESET)]
    preset: String,
    #[command(flatten)]
    replay: ReplayOptions,
    /// Output directory for results.json and images.
    #[arg(long, default_value = "replay-out")]
    out: PathBuf,
    /// Skip the reference run (no relative cost, no quality).
    #[arg(long)]
    no_reference: bool,
    /// Do not write PNG images.
    #[arg(long)]
    no_images: bool,
    /// No progress bar, no summary.
    #[arg(short, long)]
    quiet: bool,
}

pub fn run(args: Args) -> Result<(), String> {
    let preset = Preset::find(&args.preset)?;
    let opts = args.replay.clone();
    opts.check()?;
    let trace = load_trace(&args.trace)?;
    preset.supports(&trace.prepared.scene)?;
    let frames = opts.frames.map_or(trace.frames.len() as u32, |(a, b)| b - a);
    std::fs::create_dir_all(&args.out).map_err(|e| format!("{}: {e}", args.out.display()))?;
    clear_previous_run(&args.out)?;
    let refinement = preset.scheme_info().reports_refinement;
    let bar = progress::replay_bar(frames, 1, "replay", args.quiet);
    let started = std::time::Instant::now();
    let mut write_images = |_, images: &FrameImages| write_frame_images(&args.out, images, refinement);
    let mut runs = replay_all(
        &trace,
        &[(preset, opts.clone())],
        (!args.no_reference).then_some(&opts),
        (!args.no_images).then_some(&mut write_images),
        &mut |step| bar.replay_step(step, frames),
    )?;
    bar.finish_and_clear();
    let output = runs.pop().ok_or("no run")?;
    write_results(&args.out, &output.result)?;
    if !args.quiet {
        print_summary(&output);
        if !args.no_reference {
            println!(
                "{:.2} s in all, the reference replay included",
                started.elapsed().as_secs_f64()
            );
        }
        println!("wrote {}", args.out.join("results.json").display());
    }
    Ok(())
}

/// Removes what an earlier run left in `dir`: `results.json` first, so that from here on a
/// killed or failed run leaves no results file that could be read as describing the
/// pictures beside it, then its frame pictures (`frameNNNN-*.png`), so that a finished run
/// never sits beside another run's frames. The rule: a directory holds one run's outputs,
/// and `results.json`, written last, says the run finished.
pub fn clear_previous_run(dir: &Path) -> Result<(), String> {
    remove_if_present(&dir.join("results.json"))?;
    let entries = std::fs::read_dir(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    for entry in entries.filter_map(|e| e.ok()) {
        let name = entry.file_name();
        let name = name.to_string_lossy();
        let frame_picture = name.strip_prefix("frame").is_some_and(|rest| {
            rest.len() > 5 && rest.as_bytes()[..4].iter().all(u8::is_ascii_digit) && rest.ends_with(".png")
        });
        if frame_picture && entry.file_type().is_ok_and(|t| t.is_file()) {
            remove_if_present(&entry.path())?;
        }
    }
    Ok(())
}

/// Removes an output of an earlier run, if there is one.
pub fn remove_if_present(path: &Path) -> Result<(), String> {
    match std::fs::remove_file(path) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(format!("{}: {e}", path.display())),
        _ => Ok(()),
    }
}

/// Writes `results.json` into `dir`, after everything else of the run (see
/// [`clear_previous_run`]).
pub fn write_results(dir: &Path, result: &RunResult) -> Result<(), String> {
    if let Some(field) = result.non_finite_fields().first() {
        return Err(format!("{}: {field} is not a finite number", result.preset));
    }
    let json = serde_json::to_string_pretty(result).map_err(|e| e.to_string())?;
    write_atomically(&dir.join("results.json"), |w| {
        use std::io::Write;
        w.write_all(json.as_bytes()).map_err(|e| e.to_string())
    })
}

/// Writes one frame's pictures into `dir`: per eye the colour, the cost heat map, the error
/// and SSIM-loss maps against the reference when it ran and, for schemes that refine, one
/// refinement map per effect; and the stereo pair. The pictures are made and encoded in parallel (each file
/// is the same whatever the order).
pub fn write_frame_images(dir: &Path, frame: &FrameImages, refinement: bool) -> Result<(), String> {
    let stem = format!("frame{:04}", frame.frame);
    // (file name, how to make the picture), in a fixed order.
    type Make<'a> = Box<dyn Fn() -> Cow<'a, Rgba8Image> + Send + Sync + 'a>;
    let mut pictures: Vec<(String, Make)> = Vec::new();
    for (eye, view) in ["left", "right"].iter().zip(&frame.views) {
        let (width, height) = (view.color.width, view.color.height);
        pictures.push((
            format!("{stem}-{eye}.png"),
            Box::new(move || Cow::Borrowed(&view.color)),
        ));
        pictures.push((
            format!("{stem}-{eye}-cost.png"),
            Box::new(move || {
                let heat: Vec<f32> = view.cost_heat.iter().map(|&c| c as f32).collect();
                let scale = robust_max(heat.iter().copied());
                Cow::Owned(heat_map(&heat, width, height, scale, "instr per pixel, p99 scale"))
            }),
        ));
        if let Some(error) = &view.error {
            pictures.push((
                format!("{stem}-{eye}-error.png"),
                Box::new(move || {
                    // A fixed scale, so error images compare across presets and frames.
                    let error: Vec<f32> = error.iter().map(|&e| f32::from(e)).collect();
                    let map = heat_map(&error, width, height, Some(ERROR_SCALE), ERROR_LABEL);
                    Cow::Owned(map)
                }),
            ));
        }
        if let Some(loss) = &view.ssim_loss {
            pictures.push((
                format!("{stem}-{eye}-ssim.png"),
                Box::new(move || Cow::Owned(heat_map(loss, width, height, Some(SSIM_LOSS_SCALE), SSIM_LOSS_LABEL))),
            ));
        }
        if refinement {
            for (bit, effect) in [
                (Effects::DIFFUSE, "diffuse"),
                (Effects::SPECULAR, "specular"),
                (Effects::SHADOW, "shadow"),
            ] {
                pictures.push((
                    format!("{stem}-{eye}-refine-{effect}.png"),
                    Box::new(move || {
                        let refined: Vec<f32> = view
                            .refinement
                            .iter()
                            .map(|&r| f32::from(r & bit.bits() != 0))
                            .collect();
                        let label = format!("{effect} refined per pixel");
                        Cow::Owned(heat_map(&refined, width, height, Some(1.0), &label))
                    }),
                ));
            }
        }
    }
    let [left, right] = &frame.views;
    pictures.push((
        format!("{stem}-stereo.png"),
        Box::new(move || Cow::Owned(side_by_side(&left.color, &right.color))),
    ));
    pictures
        .par_iter()
        .map(|(name, make)| make().write_png(dir.join(name)))
        .collect::<Result<Vec<()>, String>>()
        .map(|_| ())
}

fn print_summary(output: &RunOutput) {
    let r = &output.result;
    let t = &r.total;
    let stages: Vec<String> = stage_names([&t.cost])
        .iter()
        .map(|s| format!("{s} {}", t.cost.stage(s).issued()))
        .collect();
    println!(
        "{} on {} ({}x{} per eye, {} frames): {} issued instructions ({}), SIMD utilization {:.1}%",
        r.preset,
        r.trace_name,
        r.eye_width,
        r.eye_height,
        r.frames.len(),
        t.cost.issued(),
        stages.join(", "),
        100.0 * t.cost.simd_utilization()
    );
    if let Some(rel) = t.relative_cost {
        println!("relative shading cost {:.2}%", 100.0 * rel);
    }
    if let Some(ssim) = t.min_ssim {
        println!("min SSIM {ssim:.6}");
    }
    let tr = &t.traffic;
    let classes: Vec<String> = traffic_names([tr])
        .iter()
        .map(|c| format!("{} {} B", c.replace('_', " "), tr.bytes(c)))
        .collect();
    println!("DRAM traffic: {} (total {} B)", classes.join(", "), tr.total());
    println!("{:.2} s, {:.2} Mpixels/s", r.timing.wall_s, r.timing.pixels_per_s / 1e6);
    // In pipeline order, then what runs after it.
    const ORDER: [&str; 10] = [
        "geometry",
        "shadow",
        "vertex",
        "bins",
        "raster_shade",
        "view_pass",
        "memory",
        "assemble",
        "quality",
        "images",
    ];
    let stages: Vec<String> = ORDER
        .iter()
        .filter_map(|s| {
            r.timing
                .stages_ms
                .get(*s)
                .map(|ms| format!("{} {ms:.0}", s.replace('_', "+")))
        })
        .collect();
    println!("wall ms per stage: {}", stages.join(", "));
}
