//! What a scene run reads and watches beyond its state: the declared outputs, the events, and
//! the energies its flow books exactly (supplied through inputs, removed by damping).

use crate::scene::model::SceneModel;
use crate::scene::ports::{At, CompiledOutput, Read, Scratch};
use crate::stepper::{EventHit, Events};
use crate::vector::Vector;
use serde::Serialize;
use std::sync::Arc;

/// An event that happened in a run.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EventRecord {
    /// The event's name.
    pub name: String,
    /// Its located time.
    pub t: f64,
    /// The step it happened in (counted from 1).
    pub step: usize,
    /// It stopped the run.
    pub stop: bool,
}

/// A run's outputs, events and exact energy accounts.
pub(crate) struct Watch<V: Vector> {
    pub(crate) model: Arc<SceneModel>,
    pub(crate) outputs: Vec<CompiledOutput>,
    /// Buffers for the outputs that evaluate `H` or `∇H`.
    pub(crate) scratch: Scratch,
    pub(crate) events: Option<Events<V>>,
    pub(crate) event_names: Vec<String>,
    pub(crate) log: Vec<EventRecord>,
    /// The flow books the energy supplied (the scene has inputs and a splitting).
    pub(crate) supplied: bool,
    /// The flow books the energy dissipated (damping in a splitting).
    pub(crate) dissipated: bool,
    /// The joints' coordinates the outputs and events read, with the run's unwrapping state
    /// (shared with the events' functions).
    pub(crate) joints: Arc<crate::scene::ports::JointTable>,
}

impl<V: Vector<Real = f64>> Watch<V> {
    /// Whether a declared output reads the energy dissipated (the books must then be kept).
    pub(crate) fn reads_dissipated(&self) -> bool {
        self.outputs.iter().any(|o| o.read == Read::Dissipated)
    }

    /// Records `hit` (of the step numbered `step`).
    pub(crate) fn record(&mut self, hit: EventHit<f64>, step: usize) {
        self.log.push(EventRecord {
            name: self.event_names[hit.index].clone(),
            t: hit.t,
            step,
            stop: hit.terminal,
        });
    }

    /// The outputs' values at `(t, x)`, into `out` (`multipliers`: the step's `(λ_k, λ_{k+1})`).
    pub(crate) fn values(
        &mut self,
        t: f64,
        x: &[f64],
        multipliers: Option<(&[f64], &[f64])>,
        energies: (f64, f64),
        out: &mut Vec<f64>,
    ) {
        out.clear();
        let at = At {
            model: &self.model,
            t,
            x,
            multipliers,
            energies,
            joints: &self.joints,
        };
        let scratch = &mut self.scratch;
        out.extend(self.outputs.iter().map(|o| o.value(&at, scratch)));
    }
}
