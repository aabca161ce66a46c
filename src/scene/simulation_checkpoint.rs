//! A saved [`Simulation`](crate::scene::Simulation): what a restore puts back.

use std::any::Any;

/// A saved [`Simulation`](crate::scene::Simulation) (opaque: restored into the simulation it came from, or one compiled
/// from the same scene).
pub struct SimulationCheckpoint {
    pub(crate) state: Box<dyn Any + Send>,
    /// The scene's name and fingerprint it was saved from.
    pub(crate) identity: Option<(String, u64)>,
    /// Events' values at the save, and how many had happened.
    pub(crate) events: Option<(Vec<f64>, usize)>,
    /// The joint angles' unwrapping state at the save.
    pub(crate) joints: Option<Vec<f64>>,
    /// Steps before the save were taken with the books off: its ledger has no dissipated total.
    pub(crate) unbooked: bool,
}

impl std::fmt::Debug for SimulationCheckpoint {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SimulationCheckpoint")
            .finish_non_exhaustive()
    }
}
