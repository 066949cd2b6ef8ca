//! The `shadetrace` command line: a thin layer over the capture, formats and replay crates.

mod allocator;
mod commands;
mod golden;
mod progress;
mod report;
mod sweep;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

/// Trace-driven replay of shading schemes for stereo (VR) rendering.
#[derive(Parser)]
#[command(version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Capture a glTF file or a built-in scene (builtin:NAME) into a trace.
    Capture(commands::capture::Args),
    /// Print a trace's header, features, counts and chunk sizes.
    Info(commands::info::Args),
    /// Replay a trace with one preset: results JSON, images and heat maps.
    Replay(commands::replay::Args),
    /// Replay several presets on one trace: table, summary.csv and an HTML report.
    Compare(commands::compare::Args),
    /// Capture the built-in scenes and compare every preset on each (the README's main job).
    Demo(commands::demo::Args),
    /// Run a parameter study (SPEC.toml: traces x presets x option grid) into a results store;
    /// resumable, sharded on Slurm or Kubernetes array jobs.
    Sweep(commands::sweep::Args),
    /// Combine the stores of a sweep's shards.
    Merge(commands::merge::Args),
    /// Summarize a sweep's store: per preset and option value, mean and spread; Pareto front.
    SweepReport(commands::sweep_report::Args),
    /// List the presets, schedulers and shading schemes and what each models.
    Presets(commands::presets::Args),
    /// Compare every corpus trace x preset with the golden numbers in traces/golden/.
    Check(commands::check::Args),
}

fn main() -> ExitCode {
    // Panics capture contains (a decoder's, on a corrupt file) become one-line errors;
    // print only the others.
    shadetrace_capture::contained::quiet_contained_panics();
    allocator::keep_freed_memory();
    stop_quietly_on_closed_output();
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Capture(args) => commands::capture::run(args),
        Command::Info(args) => commands::info::run(args),
        Command::Replay(args) => commands::replay::run(args),
        Command::Compare(args) => commands::compare::run(args),
        Command::Demo(args) => commands::demo::run(args),
        Command::Sweep(args) => commands::sweep::run(args),
        Command::Merge(args) => commands::merge::run(args),
        Command::SweepReport(args) => commands::sweep_report::run(args),
        Command::Presets(args) => commands::presets::run(args),
        Command::Check(args) => commands::check::run(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("error: {message}");
            ExitCode::FAILURE
        }
    }
}

/// Output piped into a reader that stops early (`shadetrace info T | head`) ends the process
/// as it ends any Unix tool, by SIGPIPE, instead of a panic in `println!` (Rust ignores the
/// signal by default).
fn stop_quietly_on_closed_output() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: restores the signal's default action before any thread starts.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}
