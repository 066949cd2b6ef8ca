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
}
