//! `shadetrace check [--bless]`: replays every corpus trace with every preset at the golden
//! options and compares with `traces/golden/`, keyed by trace hash, preset and options hash.

use std::path::{Path, PathBuf};

use serde::Deserialize;
use serde_json::Value;
use shadetrace_replay::{load_trace, replay_all, Preset, ReplayOptions, PRESETS};

use crate::golden;
use shadetrace_formats::atomic_file::write_atomically;

#[derive(clap::Args)]
pub struct Args {
    /// Rewrite the golden files from this run instead of comparing.
    #[arg(long)]
    bless: bool,
    /// Corpus directory holding MANIFEST.toml and golden/.
    #[arg(long, default_value = "traces")]
    traces: PathBuf,
    /// Only these presets (comma-separated; default all).
    #[arg(long, value_delimiter = ',')]
    presets: Vec<String>,
}

/// Goldens run at a reduced resolution so CI stays fast; the paper resolution is benchmarked.
pub fn golden_options() -> ReplayOptions {
    ReplayOptions {
        resolution: Some((320, 360)),
        ..ReplayOptions::default()
    }
}

#[derive(Deserialize)]
struct Manifest {
    trace: Vec<Entry>,
}

#[derive(Deserialize)]
struct Entry {
    name: String,
    file: String,
}

/// Golden file name: trace name, preset, and the first 12 hex digits of the trace and
/// options hashes (the key).
fn golden_path(dir: &Path, trace: &str, trace_hash: &str, preset: &str, options_hash: &str) -> PathBuf {
    dir.join(format!(
        "{trace}-{preset}-{}-{}.json",
        &trace_hash[..12],
        &options_hash[..12]
    ))
}

pub fn run(args: Args) -> Result<(), String> {
    let manifest_path = args.traces.join("MANIFEST.toml");
    let text = std::fs::read_to_string(&manifest_path).map_err(|e| {
        format!(
            "{}: {e} (check runs on a corpus directory: --traces DIR, default ./traces of a shadetrace checkout)",
            manifest_path.display()
        )
    })?;
    let manifest: Manifest =
        toml::from_str(&text).map_err(|e| format!("{}: {}", manifest_path.display(), e.message()))?;
    let presets: Vec<Preset> = if args.presets.is_empty() {
        PRESETS.to_vec()
    } else {
        args.presets.iter().map(|p| Preset::find(p)).collect::<Result<_, _>>()?
    };
    let opts = golden_options();
    let golden_dir = args.traces.join("golden");
    std::fs::create_dir_all(&golden_dir).map_err(|e| format!("{}: {e}", golden_dir.display()))?;
    let mut failures = 0;
    let mut checked = 0;
    for entry in &manifest.trace {
        let trace = load_trace(&args.traces.join(&entry.file))?;
        let mut runnable = Vec::new();
        for preset in &presets {
            match preset.supports(&trace.prepared.scene) {
                Ok(()) => runnable.push((*preset, opts.clone())),
                Err(why) => println!("skip {}/{}: {why}", entry.name, preset.label()),
            }
        }
        let runs = replay_all(&trace, &runnable, Some(&opts), None, &mut |_| {})?;
        for (run, (preset, _)) in runs.iter().zip(&runnable) {
            let mut result = serde_json::to_value(&run.result).map_err(|e| e.to_string())?;
            // Wall-clock timing is not a golden number.
            if let Some(obj) = result.as_object_mut() {
                obj.remove("timing");
            }
            let path = golden_path(
                &golden_dir,
                &entry.name,
                &run.result.trace_hash,
                &preset.label(),
                &run.result.options_hash,
            );
            checked += 1;
            if args.bless {
                let text = serde_json::to_string_pretty(&result).map_err(|e| e.to_string())? + "\n";
                write_atomically(&path, |w| {
                    use std::io::Write;
                    w.write_all(text.as_bytes()).map_err(|e| e.to_string())
                })?;
                println!("blessed {}", path.display());
                continue;
            }
            let label = format!("{}/{}", entry.name, preset.label());
            let golden: Value = match std::fs::read_to_string(&path) {
                Ok(text) => serde_json::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))?,
                Err(_) => {
                    println!(
                        "FAIL {label}: no golden {} (trace, preset or options changed? run `shadetrace check --bless`)",
                        path.display()
                    );
                    failures += 1;
                    continue;
                }
            };
            let differences = golden::diff(&golden, &result);
            if differences.is_empty() {
                println!("ok   {label}");
            } else {
                failures += 1;
                println!(
                    "FAIL {label}: {} field(s) differ from {}",
                    differences.len(),
                    path.display()
                );
                for line in differences.iter().take(20) {
                    println!("     {line}");
                }
                if differences.len() > 20 {
                    println!("     ... {} more", differences.len() - 20);
                }
            }
        }
    }
    if failures > 0 {
        return Err(format!("{failures} of {checked} golden checks failed"));
    }
    if !args.bless {
        println!("{checked} golden checks passed");
    }
    Ok(())
}
