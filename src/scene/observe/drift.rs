//! How the energy drifts over a run: its largest rise, and its deviation over the first and
//! the last tenth of the steps (a drift shows as a last tenth much above the first).

use super::RunObserver;
use crate::scene::simulation::Simulation;

/// `H` after every step of a run of `steps` steps: `max |H − H₀|`, the largest rise
/// `H_{k+1} − H_k` and where it happened, and `max |H − H₀|` over the first and the last tenth.
#[derive(Debug, Clone, PartialEq)]
pub struct EnergyDrift {
    steps: usize,
    /// `H(x₀)`.
    pub initial: f64,
    previous: f64,
    /// The largest `H_{k+1} − H_k` (`−∞` before the first step).
    pub max_rise: f64,
    /// `(step, H)` after the largest rise.
    pub rise_at: (usize, f64),
    /// `max |H − H₀|`.
    pub max_abs_error: f64,
    /// `max |H − H₀|` over the first tenth of the steps.
    pub first_tenth: f64,
    /// `max |H − H₀|` over the last tenth of the steps.
    pub last_tenth: f64,
}

impl EnergyDrift {
    /// Starts at the simulation's current state, for a run of `steps` steps.
    pub fn new(sim: &dyn Simulation, steps: usize) -> Self {
        let initial = sim.energy();
        Self {
            steps,
            initial,
            previous: initial,
            max_rise: f64::NEG_INFINITY,
            rise_at: (0, initial),
            max_abs_error: 0.0,
            first_tenth: 0.0,
            last_tenth: 0.0,
        }
    }
}

impl RunObserver for EnergyDrift {
    fn observe(&mut self, step: usize, sim: &mut dyn Simulation) {
        if step == 0 {
            return;
        }
        let e = sim.energy();
        if e - self.previous > self.max_rise {
            self.max_rise = e - self.previous;
            self.rise_at = (step, e);
        }
        self.previous = e;
        let de = (e - self.initial).abs();
        self.max_abs_error = self.max_abs_error.max(de);
        let k = step - 1;
        if k < self.steps / 10 {
            self.first_tenth = self.first_tenth.max(de);
        } else if k >= self.steps - self.steps / 10 {
            self.last_tenth = self.last_tenth.max(de);
        }
    }
}
