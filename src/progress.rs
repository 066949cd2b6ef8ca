//! Progress for long work, on stderr: a bar on a terminal; where stderr is piped or logged
//! (batch jobs, CI), a plain line every 10% with elapsed time and an estimate of what is
//! left, once the work has run for [`QUIET_FOR`] (short runs and one-line errors stay
//! clean). Nothing with `--quiet`.

use std::io::{IsTerminal, Write};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// Piped progress stays silent for this long.
const QUIET_FOR: Duration = Duration::from_secs(5);

pub struct Progress {
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
            ProgressStyle::with_template("{msg:>10} [{bar:40}] {pos}/{len} {elapsed} (eta {eta})")
                .expect("valid template")
                .progress_chars("=> "),
        );
        bar.set_message(what.to_string());
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

impl Progress {
    pub fn set_position(&self, done: u64) {
        match &self.kind {
            Kind::Hidden => {}
            Kind::Bar(bar) => bar.set_position(done),
            Kind::Lines(last) => {
                let tenth = (10 * done).checked_div(self.total).unwrap_or(10).min(10);
                let mut last = last.lock().unwrap_or_else(|e| e.into_inner());
                if tenth > *last && self.started.elapsed() >= QUIET_FOR {
                    *last = tenth;
                    let _ = writeln!(std::io::stderr(), "{}", self.line(done));
                }
            }
        }
    }

    pub fn finish_and_clear(&self) {
        if let Kind::Bar(bar) = &self.kind {
            bar.finish_and_clear();
        }
    }

    /// `what: done/total (pct), elapsed, eta` for a log line.
    fn line(&self, done: u64) -> String {
        let elapsed = self.started.elapsed().as_secs_f64();
        let left = if done > 0 {
            elapsed * (self.total.saturating_sub(done)) as f64 / done as f64
        } else {
            0.0
        };
        format!(
            "{}: {done}/{} ({:.0}%), {elapsed:.0} s, about {left:.0} s left",
            self.what,
            self.total,
            100.0 * done as f64 / self.total.max(1) as f64
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_lines_say_how_far_and_how_long() {
        let p = Progress {
            what: "frames".into(),
            total: 30,
            started: Instant::now(),
            kind: Kind::Hidden,
        };
        let line = p.line(3);
        assert!(line.starts_with("frames: 3/30 (10%), "), "{line}");
        assert!(line.ends_with(" s left"), "{line}");
        assert!(p.line(0).contains("0/30 (0%)"));
    }
}
