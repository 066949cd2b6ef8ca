//! Progress for long work, on stderr: a bar on a terminal; where stderr is piped or logged
//! (batch jobs, CI), a plain line every 10% with where the work is (`frames 3-4/30, preset
//! 5/11 (tile-pair)`), elapsed time and an estimate of what is left, once the work has run
//! for [`QUIET_FOR`] (short runs and one-line errors stay clean). Nothing with `--quiet`.

use std::io::{IsTerminal, Write};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use shadetrace_replay::ReplayStep;

/// Piped progress stays silent for this long.
const QUIET_FOR: Duration = Duration::from_secs(5);

pub struct Progress {
    /// What the whole job is (`compare`, `scene 2/6 floor`).
    what: String,
    total: u64,
    started: Instant,
    kind: Kind,
}

enum Kind {
    Hidden,
    Bar(ProgressBar),
    /// The last tenth of the work reported.
    Lines(Mutex<u64>),
}

pub fn bar(total: u64, what: &str, quiet: bool) -> Progress {
    let kind = if quiet {
        Kind::Hidden
    } else if std::io::stderr().is_terminal() {
        let bar = ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr());
        bar.set_style(
            ProgressStyle::with_template("{prefix} [{bar:30}] {pos}/{len} {elapsed} (eta {eta}) {msg}")
                .expect("valid template")
                .progress_chars("=> "),
        );
        bar.set_prefix(what.to_string());
        Kind::Bar(bar)
    } else {
        Kind::Lines(Mutex::new(0))
    };
    Progress {
        what: what.to_string(),
        total,
        started: Instant::now(),
        kind,
    }
}

/// A bar over every run of every frame of a [`replay_all`](shadetrace_replay::replay_all)
/// of `runs` runs over `frames` frames.
pub fn replay_bar(frames: u32, runs: usize, what: &str, quiet: bool) -> Progress {
    bar(u64::from(frames) * runs as u64, what, quiet)
}

impl Progress {
    /// Reports a replay's step (see [`replay_bar`]).
    pub fn replay_step(&self, step: ReplayStep, frames: u32) {
        self.set_position_with(step.units_done(), &step_label(step, frames));
    }

    pub fn set_position(&self, done: u64) {
        self.set_position_with(done, "");
    }

    /// The position, with where the work is (shown on the bar and in log lines).
    pub fn set_position_with(&self, done: u64, step: &str) {
        match &self.kind {
            Kind::Hidden => {}
            Kind::Bar(bar) => {
                bar.set_position(done);
                bar.set_message(step.to_string());
            }
            Kind::Lines(last) => {
                let tenth = (10 * done).checked_div(self.total).unwrap_or(10).min(10);
                let mut last = last.lock().unwrap_or_else(|e| e.into_inner());
                if tenth > *last && self.started.elapsed() >= QUIET_FOR {
                    *last = tenth;
                    let _ = writeln!(std::io::stderr(), "{}", self.line(done, step));
                }
            }
        }
    }

    pub fn finish_and_clear(&self) {
        if let Kind::Bar(bar) = &self.kind {
            bar.finish_and_clear();
        }
    }

    /// `what: step, done/total (pct), elapsed, eta` for a log line.
    fn line(&self, done: u64, step: &str) -> String {
        let elapsed = self.started.elapsed().as_secs_f64();
        let left = if done > 0 {
            elapsed * (self.total.saturating_sub(done)) as f64 / done as f64
        } else {
            0.0
        };
        let step = if step.is_empty() {
            String::new()
        } else {
            format!("{step}, ")
        };
        format!(
            "{}: {step}{done}/{} ({:.0}%), {elapsed:.0} s, about {left:.0} s left",
            self.what,
            self.total,
            100.0 * done as f64 / self.total.max(1) as f64
        )
    }
}

/// `frames 3-4/30, preset 5/11 (tile-pair)`: the frames being replayed (`frame 3/30` for
/// one) and the presets done with them.
fn step_label(step: ReplayStep, frames: u32) -> String {
    let first = (step.frames_done + 1).min(frames.max(1));
    let last = (step.frames_done + step.in_flight).clamp(first, frames.max(1));
    let which = match first == last {
        true => format!("frame {first}"),
        false => format!("frames {first}-{last}"),
    };
    format!(
        "{which}/{frames}, preset {}/{} ({})",
        step.runs_done, step.runs, step.preset
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_lines_say_where_how_far_and_how_long() {
        let p = Progress {
            what: "scene 2/6 floor".into(),
            total: 30,
            started: Instant::now(),
            kind: Kind::Hidden,
        };
        let step = ReplayStep {
            frames_done: 1,
            in_flight: 1,
            runs_done: 1,
            runs: 10,
            preset: "amfs",
        };
        assert_eq!(step.units_done(), 11);
        let line = p.line(3, &step_label(step, 3));
        assert!(
            line.starts_with("scene 2/6 floor: frame 2/3, preset 1/10 (amfs), 3/30 (10%), "),
            "{line}"
        );
        // Two frames in flight: both counted for the runs done with them.
        let pair = ReplayStep { in_flight: 2, ..step };
        assert_eq!(pair.units_done(), 12);
        assert!(
            step_label(pair, 3).starts_with("frames 2-3/3, "),
            "{}",
            step_label(pair, 3)
        );
        assert!(line.ends_with(" s left"), "{line}");
        assert!(p.line(0, "").contains(": 0/30 (0%)"));
    }
}
