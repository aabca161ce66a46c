//! The energy and, with damping, the energy budget of a run.

use super::RunObserver;
use crate::scene::simulation::Simulation;

/// `H` after every step: its initial and last value, `max |H − H₀|`, `max (H_{k+1} − H_k)`,
/// and, when the model dissipates, the dissipated energy `∫ ∇Hᵀ R ∇H dt` (trapezoidal rule
/// over the steps) with the budget's error `max |H − H₀ + dissipated|`.
#[derive(Debug, Clone, PartialEq)]
pub struct EnergyBudget {
    /// `H(x₀)`.
    pub initial: f64,
    /// `H` after the last step observed.
    pub last: f64,
    /// `max |H − H₀|`.
    pub max_abs_error: f64,
    /// `max (H_{k+1} − H_k)` over the steps (`−∞` before the first step).
    pub max_increase: f64,
    /// Energy dissipated so far (`None` when the model does not dissipate).
    pub dissipated: Option<f64>,
    /// `max |H − H₀ + dissipated|` (with dissipation).
    pub max_balance_error: f64,
    /// The dissipated power at the last step observed.
    last_power: Option<f64>,
}

impl EnergyBudget {
    /// Starts the budget at the simulation's current state.
    pub fn new(sim: &mut dyn Simulation) -> Self {
        let initial = sim.energy();
        let power = sim.dissipation_power();
        Self {
            initial,
            last: initial,
            max_abs_error: 0.0,
            max_increase: f64::NEG_INFINITY,
            dissipated: power.map(|_| 0.0),
            max_balance_error: 0.0,
            last_power: power,
        }
    }
}

impl RunObserver for EnergyBudget {
    fn observe(&mut self, step: usize, sim: &mut dyn Simulation) {
        if step == 0 {
            return;
        }
        let e = sim.energy();
        self.max_abs_error = self.max_abs_error.max((e - self.initial).abs());
        self.max_increase = self.max_increase.max(e - self.last);
        if let (Some(p_prev), Some(d)) = (self.last_power, self.dissipated.as_mut()) {
            let p = sim.dissipation_power().unwrap_or(0.0);
            *d += 0.5 * sim.dt() * (p + p_prev);
            self.last_power = Some(p);
            self.max_balance_error = self.max_balance_error.max((e - self.initial + *d).abs());
        }
        self.last = e;
    }
}
