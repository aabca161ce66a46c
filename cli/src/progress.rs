//! A progress bar on stderr for a run of many steps; it hides itself when stderr is not a
//! terminal.

use indicatif::{ProgressBar, ProgressStyle};
use lieflow::scene::Sample;

/// An observer of a run that moves a bar every 1/200 of the steps, or of the time.
pub(crate) struct Progress {
    bar: ProgressBar,
    tick: usize,
    /// A bar over the time `(t₀, t_end)` in thousandths, for steps not counted before.
    span: Option<(f64, f64)>,
}

/// The thousandths of a bar over time.
const PER_MILLE: u64 = 1000;

impl Progress {
    /// A bar for `steps` steps.
    pub(crate) fn new(steps: usize) -> Self {
        let bar = ProgressBar::new(steps as u64);
        bar.set_style(
            ProgressStyle::with_template("{bar:40} {pos}/{len} steps, {elapsed} (eta {eta})")
                .expect("valid template"),
        );
        Self {
            bar,
            tick: (steps / 200).max(1),
            span: None,
        }
    }
    /// A bar for a run over the times `span = (t₀, t_end)` (the controller's own steps).
    pub(crate) fn over_time(span: (f64, f64)) -> Self {
        let bar = ProgressBar::new(PER_MILLE);
        bar.set_style(
            ProgressStyle::with_template("{bar:40} {percent}% of the time, {elapsed} (eta {eta})")
                .expect("valid template"),
        );
        Self {
            bar,
            tick: 1,
            span: Some(span),
        }
    }
    /// Moves the bar to `s`'s step (or time) on every tick.
    pub(crate) fn observe(&mut self, s: &Sample<'_>) {
        if let Some((t0, t_end)) = self.span {
            let done = ((s.t - t0) / (t_end - t0)).clamp(0.0, 1.0);
            let at = (done * PER_MILLE as f64) as u64;
            if at > self.bar.position() {
                self.bar.set_position(at);
            }
        } else if s.step.is_multiple_of(self.tick) {
            self.bar.set_position(s.step as u64);
        }
    }
    /// Removes the bar.
    pub(crate) fn finish(&self) {
        self.bar.finish_and_clear();
    }
}
