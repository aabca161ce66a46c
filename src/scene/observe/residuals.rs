//! The constraint residuals of a run.

use super::RunObserver;
use crate::scene::simulation::Simulation;

/// `(|g|, |φ|)` (max norms) after every step and their maxima over the run; all `None` without
/// constraints.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Residuals {
    /// The last step's `(max |g|, max |φ|)`.
    pub last: Option<(f64, f64)>,
    /// `max |g|` over the run.
    pub max_g: Option<f64>,
    /// `max |φ|` over the run.
    pub max_phi: Option<f64>,
}

impl RunObserver for Residuals {
    fn observe(&mut self, _step: usize, sim: &mut dyn Simulation) {
        self.last = sim.residuals();
        if let Some((g, phi)) = self.last {
            self.max_g = Some(self.max_g.unwrap_or(0.0).max(g));
            self.max_phi = Some(self.max_phi.unwrap_or(0.0).max(phi));
        }
    }
}
