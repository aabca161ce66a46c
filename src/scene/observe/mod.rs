//! Observers of a scene's run: each records one diagnostic after every step, from the
//! [`Simulation`] it is handed, and costs nothing when it is not part of the run.
//!
//! - [`EnergyBudget`]: `H`, its largest deviation and rise, and with damping the dissipated
//!   energy and the budget's error `H − H₀ + dissipated`;
//! - [`Residuals`]: `max |g|` and `max |φ|`;
//! - [`EnergyDrift`]: the energy's largest rise and its drift over the first and last tenth;
//! - [`NewtonMax`]: the most Newton iterations one step took;
//! - [`StepClock`]: the wall time spent in the steps, the observers' own time excluded.
//!
//! Closures `FnMut(usize, &mut dyn Simulation)`, `Option`s and tuples of observers are
//! observers too, so a run composes exactly the ones it asked for.

mod clock;
mod drift;
mod energy;
mod newton;
mod residuals;

pub use clock::StepClock;
pub use drift::EnergyDrift;
pub use energy::EnergyBudget;
pub use newton::NewtonMax;
pub use residuals::Residuals;

use crate::scene::simulation::Simulation;

/// Sees a simulation after each step (`step` counts the run's steps, 0 for the initial state).
pub trait RunObserver {
    /// Records what it needs from `sim` after step `step`.
    fn observe(&mut self, step: usize, sim: &mut dyn Simulation);
}

impl RunObserver for () {
    #[inline]
    fn observe(&mut self, _step: usize, _sim: &mut dyn Simulation) {}
}

impl<F: FnMut(usize, &mut dyn Simulation)> RunObserver for F {
    #[inline]
    fn observe(&mut self, step: usize, sim: &mut dyn Simulation) {
        self(step, sim)
    }
}

impl<O: RunObserver> RunObserver for Option<O> {
    #[inline]
    fn observe(&mut self, step: usize, sim: &mut dyn Simulation) {
        if let Some(o) = self {
            o.observe(step, sim);
        }
    }
}

macro_rules! tuple_observer {
    ($($name:ident $idx:tt),+) => {
        impl<$($name: RunObserver),+> RunObserver for ($($name,)+) {
            #[inline]
            fn observe(&mut self, step: usize, sim: &mut dyn Simulation) {
                $(self.$idx.observe(step, sim);)+
            }
        }
    };
}
tuple_observer!(A 0, B 1);
tuple_observer!(A 0, B 1, C 2);
tuple_observer!(A 0, B 1, C 2, D 3);
