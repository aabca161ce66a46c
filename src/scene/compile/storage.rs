//! The storage of a compiled scene's state: a stack array (`SVector<f64, N>`) when a splitting
//! steps a state of one to three bodies (`N` = 4, 6, 8 or 12), a heap column (`Col<f64>`)
//! otherwise.
//!
//! On a stack state every vector of the step — the half-step directions, the inner flow's
//! state, the multiplier systems' iterates — is a value the compiler keeps in registers, and a
//! copy or a fill is a few moves instead of a call to `memcpy`/`memset`: a step of the damped
//! pendulum scene costs ~30% less (docs/performance.md). The flow, the system and everything a
//! run observes are the same generic code on either storage.

use super::scheme::splitting_flow;
use super::{Raise, Result, initial_state_error};
use crate::flow::Flow;
use crate::scene::model::SceneModel;
use crate::scene::ports::{CompiledOutput, EventSpec, Scratch, compile_events};
use crate::scene::run::{ModelRun, Simulation};
use crate::scene::watch::Watch;
use crate::stepper::Events;
use crate::system::System;
use crate::vector::Vector;
use faer::Col;
use nalgebra::SVector;
use std::sync::Arc;

/// What a run is built from, whatever its storage.
pub(super) struct RunParts<'a> {
    pub(super) model: &'a Arc<SceneModel>,
    pub(super) x0: &'a Col<f64>,
    pub(super) dt: f64,
    pub(super) outputs: Vec<CompiledOutput>,
    /// The events' specs and what compiling them needs (they were compiled and checked once
    /// on the heap storage; a stack run compiles them again for its own state type).
    pub(super) events: EventSource<'a>,
    /// The flow books the energy dissipated (damping in a splitting).
    pub(super) books_dissipation: bool,
}

/// The events of a scene, to be compiled for the run's storage.
pub(super) struct EventSource<'a> {
    pub(super) specs: &'a [EventSpec],
    pub(super) bodies: &'a crate::scene::bodies::Bodies,
    pub(super) dim: usize,
    /// The joints' coordinates the outputs and events read (their unwrapping is the run's).
    pub(super) joints: Arc<crate::scene::ports::JointTable>,
}

/// The run of a compiled scene: the splitting `raise`d again on a stack state when `stack` is
/// given (a splitting scheme) and the state has 4, 6, 8 or 12 entries; `flow` on the heap
/// column otherwise.
pub(super) fn simulation(
    flow: Box<dyn Flow<Col<f64>>>,
    parts: RunParts<'_>,
    stack: Option<(Raise, bool)>,
) -> Result<Box<dyn Simulation>> {
    match (stack, parts.x0.nrows()) {
        (Some((raise, backward)), 4) => on_stack::<4>(parts, raise, backward),
        (Some((raise, backward)), 6) => on_stack::<6>(parts, raise, backward),
        (Some((raise, backward)), 8) => on_stack::<8>(parts, raise, backward),
        (Some((raise, backward)), 12) => on_stack::<12>(parts, raise, backward),
        _ => {
            let x0 = parts.x0.clone();
            run_on(flow, x0, parts)
        }
    }
}

fn on_stack<const N: usize>(
    parts: RunParts<'_>,
    raise: Raise,
    backward: bool,
) -> Result<Box<dyn Simulation>> {
    let x0: SVector<f64, N> = SVector::from_column_slice(parts.x0.as_slice());
    let (flow, _, _) = splitting_flow(parts.model, &x0, raise, backward, f64::EPSILON)
        .map_err(|e| super::constraints::setup_error(parts.model, e))?;
    run_on(flow, x0, parts)
}

/// The run of `flow` from `x0` on storage `V`.
fn run_on<V: Vector<Real = f64> + 'static>(
    flow: Box<dyn Flow<V>>,
    x0: V,
    parts: RunParts<'_>,
) -> Result<Box<dyn Simulation>> {
    let model = parts.model;
    let n = x0.len();
    let m = model.m;
    let (events, event_names) = if parts.events.specs.is_empty() {
        (Vec::new(), Vec::new())
    } else {
        compile_events::<V>(
            parts.events.specs,
            parts.events.bodies,
            parts.events.dim,
            model.inputs.as_ref(),
            model,
            &parts.events.joints,
        )?
    };
    let system = System::new(model.clone(), model.clone(), model.clone());
    let mut run = ModelRun::new(flow, system, x0, parts.dt, m, Some(model.clone()))
        .map_err(initial_state_error)?;
    if model.inputs.is_some()
        || !parts.outputs.is_empty()
        || !events.is_empty()
        || parts.books_dissipation
        || parts.events.joints.any_read()
    {
        run.watch = Some(Watch {
            model: model.clone(),
            scratch: Scratch::new(n, model.inputs.as_ref().map_or(0, |i| i.names().len())),
            outputs: parts.outputs,
            events: (!events.is_empty()).then(|| Events::new(events)),
            event_names,
            log: Vec::new(),
            supplied: model.inputs.is_some(),
            dissipated: parts.books_dissipation,
            joints: parts.events.joints.clone(),
        });
    }
    Ok(Box::new(run))
}
