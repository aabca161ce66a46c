//! The Newton iterations of the worst step of a run.

use super::RunObserver;
use crate::scene::simulation::Simulation;

/// The most Newton iterations (of all the step's multiplier and implicit solves) one step took.
#[derive(Debug, Clone, PartialEq)]
pub struct NewtonMax {
    /// The flow's cumulative count at the last step observed.
    previous: u64,
    /// The most iterations of one step.
    pub max: u64,
}

impl NewtonMax {
    /// Starts counting at the simulation's current counters.
    pub fn new(sim: &dyn Simulation) -> Self {
        Self {
            previous: sim.stats().newton_iterations,
            max: 0,
        }
    }
}

impl RunObserver for NewtonMax {
    fn observe(&mut self, _step: usize, sim: &mut dyn Simulation) {
        let n = sim.stats().newton_iterations;
        self.max = self.max.max(n - self.previous);
        self.previous = n;
    }
}
