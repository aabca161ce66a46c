//! A progress bar on stderr for a run of many steps; it hides itself when stderr is not a
//! terminal.

use indicatif::{ProgressBar, ProgressStyle};
use lieflow::scene::Sample;

/// An observer of a run that moves a bar every 1/200 of the steps.
pub(crate) struct Progress {
    bar: ProgressBar,
    tick: usize,
}

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
        }
    }
    /// Moves the bar to `s`'s step on every tick.
    pub(crate) fn observe(&mut self, s: &Sample<'_>) {
        if s.step.is_multiple_of(self.tick) {
            self.bar.set_position(s.step as u64);
        }
    }
    /// Removes the bar.
    pub(crate) fn finish(&self) {
        self.bar.finish_and_clear();
    }
}
