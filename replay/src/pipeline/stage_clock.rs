//! Wall time per stage of a frame, for the results' timing breakdown (never compared:
//! timing is not deterministic).

use std::time::{Duration, Instant};

/// Laps of a stopwatch, each named after the stage that just ended.
pub struct StageClock {
    last: Instant,
    pub laps: Vec<(&'static str, Duration)>,
}

impl StageClock {
    pub fn start() -> StageClock {
        StageClock {
            last: Instant::now(),
            laps: Vec::new(),
        }
    }

    /// Ends stage `name` now and starts the next one.
    pub fn lap(&mut self, name: &'static str) {
        let now = Instant::now();
        self.laps.push((name, now - self.last));
        self.last = now;
    }

    /// Ends stages that ran at once, each with its own wall time (so their laps add up to
    /// more than the time that passed), and starts the next one.
    pub fn overlapped(&mut self, stages: &[(&'static str, Duration)]) {
        self.laps.extend_from_slice(stages);
        self.last = Instant::now();
    }
}

/// `f`'s result and its wall time.
pub fn timed<R>(f: impl FnOnce() -> R) -> (R, Duration) {
    let start = Instant::now();
    let result = f();
    (result, start.elapsed())
}
