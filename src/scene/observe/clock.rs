//! The wall time of the steps alone: a clock outside the model, stopped while the run's
//! observers work.

use std::time::{Duration, Instant};

/// Accumulates the time between [`start`](Self::start) (the end of the observers' work after a
/// step) and [`stop`](Self::stop) (the start of their work after the next step): the time of
/// the steps themselves.
#[derive(Debug, Clone, Default)]
pub struct StepClock {
    started: Option<Instant>,
    total: Duration,
}

impl StepClock {
    /// The next step starts now.
    #[inline]
    pub fn start(&mut self) {
        self.started = Some(Instant::now());
    }
    /// The step (if one was started) ended now.
    #[inline]
    pub fn stop(&mut self) {
        if let Some(s) = self.started.take() {
            self.total += s.elapsed();
        }
    }
    /// The time of the steps so far.
    pub fn elapsed(&self) -> Duration {
        self.total
    }
}
