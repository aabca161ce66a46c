//! The energy and, with damping, the energy budget of a run.

use super::RunObserver;
use crate::scene::simulation::Simulation;

/// `H` after every step: its initial and last value, `max |H − H₀|`, `max (H_{k+1} − H_k)`,
/// and, when the model dissipates or has inputs, the energy budget
/// `H − H₀ = −dissipated + supplied` and its error `max |H − H₀ + dissipated − supplied|`.
///
/// The dissipated and supplied energies are the flow's own exact accounts when it keeps them
/// (a splitting: the damping's closed-form sub-flow removes `(1 − e^{−2γh}) |p|²/(2m)` per
/// body, the inputs' sub-flow adds `H(after) − H(before)`; both integrated to the scheme's
/// order, see [`Ledger`](crate::flow::Ledger)); otherwise the dissipated power `∇Hᵀ R ∇H` is
/// integrated by the trapezoidal rule over the steps (an `O(h²)` quadrature, meaningless when
/// the damping is stiff on the step's scale).
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
    /// Energy supplied through the inputs so far (`None` without inputs).
    pub supplied: Option<f64>,
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
            supplied: sim.supplied().map(|_| 0.0),
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
        if let Some(d) = self.dissipated.as_mut() {
            match (sim.dissipated(), self.last_power) {
                (Some(exact), _) => *d = exact,
                (None, Some(p_prev)) => {
                    let p = sim.dissipation_power().unwrap_or(0.0);
                    *d += 0.5 * sim.dt() * (p + p_prev);
                    self.last_power = Some(p);
                }
                (None, None) => {}
            }
        }
        if let Some(s) = self.supplied.as_mut() {
            *s = sim.supplied().unwrap_or(0.0);
        }
        if self.dissipated.is_some() || self.supplied.is_some() {
            let (d, s) = (self.dissipated.unwrap_or(0.0), self.supplied.unwrap_or(0.0));
            self.max_balance_error = self.max_balance_error.max((e - self.initial + d - s).abs());
        }
        self.last = e;
    }
}
