//! Running a compiled scene: the one loop over a [`Simulation`] (its [`Stepper`]), with the
//! observers the run asked for, and the run's summary.
//!
//! [`advance`] takes the steps and calls one observer after each; [`run`] is `advance` with
//! the diagnostics of a [`RunPlan`] — each an observer of [`crate::scene::observe`], present only
//! when planned, so a run pays for nothing it did not ask for.
//!
//! [`Stepper`]: crate::stepper::Stepper

mod summary;

pub(crate) use crate::scene::simulation::ModelRun;
pub use crate::scene::simulation::{EffectReport, Simulation, SimulationCheckpoint};
pub(crate) use summary::step_error_kind;
pub use summary::{RunFailure, RunPlan, RunSummary, Sample};

use crate::scene::observe::{EnergyBudget, Residuals, RunObserver, StepClock};
use std::time::Instant;

/// What [`advance`] did: the steps taken, and why it stopped early, if it did (the state is
/// then the last good one).
#[derive(Debug, Clone, PartialEq)]
pub struct Advanced {
    /// Steps taken.
    pub steps: usize,
    /// The failing step, if one failed.
    pub error: Option<RunFailure>,
}

/// Takes up to `steps` steps of `sim`, calling `observer` after each successful one (with the
/// step count of this run, from 1). A failing step ends the run. Nothing is measured that the
/// observer does not measure (a [`StepClock`] times the steps).
pub fn advance(sim: &mut dyn Simulation, steps: usize, observer: &mut dyn RunObserver) -> Advanced {
    for k in 0..steps {
        if let Err(e) = sim.step() {
            return Advanced {
                steps: k,
                error: Some(RunFailure {
                    step: k,
                    t: sim.time(),
                    kind: step_error_kind(&e).to_owned(),
                    message: e.to_string(),
                }),
            };
        }
        observer.observe(k + 1, sim);
        if sim.stopped().is_some() {
            return Advanced {
                steps: k + 1,
                error: None,
            };
        }
    }
    Advanced { steps, error: None }
}

/// Runs `plan.steps` steps of `sim`, computing the planned diagnostics after every step and
/// passing each state to `observe` (also the initial one). A failing step ends the run: the
/// state stays the last good one and the summary's `error` says what happened.
pub fn run(
    sim: &mut dyn Simulation,
    plan: &RunPlan,
    observe: &mut dyn FnMut(&Sample<'_>),
) -> RunSummary {
    sim.reset_counters();
    let run_start = Instant::now();
    let mut energy = plan.energy.then(|| EnergyBudget::new(sim));
    let mut residuals = plan.residuals.then(Residuals::default);
    let mut clock = StepClock::default();
    let with_outputs = !sim.output_names().is_empty();
    let mut outputs = Vec::new();
    let mut each = |step: usize, sim: &mut dyn Simulation| {
        clock.stop();
        energy.observe(step, sim);
        residuals.observe(step, sim);
        let last = residuals.as_ref().and_then(|r| r.last);
        if with_outputs {
            sim.outputs(&mut outputs);
        }
        observe(&Sample {
            step,
            t: sim.time(),
            x: sim.state(),
            energy: energy.as_ref().map(|e| e.last),
            g: last.map(|r| r.0),
            phi: last.map(|r| r.1),
            outputs: &outputs,
        });
        clock.start();
    };
    each(0, sim);
    let done = advance(sim, plan.steps, &mut each);
    let stats = sim.stats();
    let run_ns = run_start.elapsed().as_nanos() as f64;
    let effects = sim
        .effects()
        .into_iter()
        .map(|mut r| {
            r.time_share = r
                .time_share
                .map(|ns| if run_ns > 0.0 { ns / run_ns } else { 0.0 });
            r
        })
        .collect();
    let taken = done.steps;
    let e = energy.as_ref();
    RunSummary {
        t: sim.time(),
        steps: taken,
        steps_planned: plan.steps,
        dt: sim.dt(),
        x: sim.state().to_vec(),
        max_abs_g: residuals.as_ref().and_then(|r| r.max_g),
        max_abs_phi: residuals.as_ref().and_then(|r| r.max_phi),
        energy_initial: e.map(|e| e.initial),
        energy_final: e.map(|e| e.last),
        max_abs_energy_error: e.map(|e| e.max_abs_error),
        max_energy_increase: e.filter(|_| taken > 0).map(|e| e.max_increase),
        dissipated: e.and_then(|e| e.dissipated),
        supplied: e.and_then(|e| e.supplied),
        events: sim.events().to_vec(),
        stopped_by: sim.stopped().map(str::to_owned),
        max_energy_balance_error: e
            .filter(|e| e.dissipated.is_some() || e.supplied.is_some())
            .map(|e| e.max_balance_error),
        effects,
        residual_evaluations: stats.residual_evaluations,
        newton_iterations: stats.newton_iterations,
        ns_per_step: if taken > 0 {
            clock.elapsed().as_nanos() as f64 / taken as f64
        } else {
            0.0
        },
        error: done.error,
    }
}
