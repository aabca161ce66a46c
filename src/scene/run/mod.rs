//! Running a compiled scene: the one loop over a [`Simulation`] (its [`Stepper`]), with the
//! observers the run asked for, and the run's summary.
//!
//! [`advance`] takes the steps and calls one observer after each; [`run`] is `advance` with
//! the diagnostics of a [`RunPlan`] — each an observer of [`crate::scene::observe`], present only
//! when planned, so a run pays for nothing it did not ask for.
//!
//! [`Stepper`]: crate::stepper::Stepper

mod dense;
mod summary;

pub use dense::advance_dense_until;

pub(crate) use crate::scene::simulation::ModelRun;
pub use crate::scene::simulation::{EffectReport, Simulation, SimulationCheckpoint};
pub use summary::{
    AdaptiveSummary, BUDGET_WARNING_FRACTION, RunFailure, RunPlan, RunSummary, Sample,
};
pub(crate) use summary::{step_error_advice, step_error_kind};

use crate::scene::observe::{EnergyBudget, Residuals, RunObserver, StepClock};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

/// What [`advance`] did: the steps taken, and why it stopped early, if it did (the state is
/// then the last good one).
#[derive(Debug, Clone, PartialEq)]
pub struct Advanced {
    /// Steps taken.
    pub steps: usize,
    /// The failing step, if one failed.
    pub error: Option<RunFailure>,
    /// The run was interrupted (its `interrupt` flag was raised) before it took every step.
    pub interrupted: bool,
}

/// Takes up to `steps` steps of `sim`, calling `observer` after each successful one (with the
/// step count of this run, from 1). A failing step ends the run. Nothing is measured that the
/// observer does not measure (a [`StepClock`] times the steps).
pub fn advance(sim: &mut dyn Simulation, steps: usize, observer: &mut dyn RunObserver) -> Advanced {
    advance_until(sim, steps, observer, &AtomicBool::new(false))
}

/// [`advance`] that stops before the next step once `interrupt` is raised (by a signal
/// handler, another thread): the state is then the last one reached, and observed.
pub fn advance_until(
    sim: &mut dyn Simulation,
    steps: usize,
    observer: &mut dyn RunObserver,
    interrupt: &AtomicBool,
) -> Advanced {
    for k in 0..steps {
        if interrupt.load(Ordering::Relaxed) {
            return Advanced {
                steps: k,
                error: None,
                interrupted: true,
            };
        }
        if let Err(e) = sim.step() {
            return Advanced {
                steps: k,
                error: Some(failure(k, sim, &e)),
                interrupted: false,
            };
        }
        observer.observe(k + 1, sim);
        if sim.stopped().is_some() {
            return Advanced {
                steps: k + 1,
                error: None,
                interrupted: false,
            };
        }
    }
    Advanced {
        steps,
        error: None,
        interrupted: false,
    }
}

fn failure(step: usize, sim: &dyn Simulation, e: &crate::error::StepError) -> RunFailure {
    use crate::error::StepError;
    if matches!(e, StepError::Newton { .. } | StepError::NonFinite { .. })
        && let Some(cause) = overflowing_input(sim)
    {
        // The cause is an input, not the step size: say so instead of "try a smaller step".
        return RunFailure {
            step,
            t: sim.time(),
            kind: "NonFiniteInput".to_owned(),
            message: format!("{cause} ({e})"),
            advice: Some(
                "a smaller step does not help: bound the input (a force whose impulse over a step squares beyond the largest f64 leaves no finite kinetic energy)".to_owned(),
            ),
        };
    }
    RunFailure {
        step,
        t: sim.time(),
        kind: step_error_kind(e).to_owned(),
        message: match e {
            // The input by its name.
            crate::error::StepError::NonFiniteInput { input, t, value } => {
                match sim.input_names().get(*input) {
                    Some(name) => format!(
                        "input '{name}' is {value} at t = {t}: its signal is not finite there"
                    ),
                    None => e.to_string(),
                }
            }
            e => e.to_string(),
        },
        advice: step_error_advice(e, sim.dt()),
    }
}

/// An input whose impulse over a step, `|u(t)| dt`, squares beyond the largest `f64` (a held
/// value of 1e308): the state it drives cannot hold a finite energy, whatever the step.
fn overflowing_input(sim: &dyn Simulation) -> Option<String> {
    let (t, dt) = (sim.time(), sim.dt());
    sim.input_names().into_iter().find_map(|name| {
        let u = sim.input(&name)?;
        ((u * dt).abs() > f64::MAX.sqrt()).then(|| {
            format!(
                "input '{name}' = {u:e} at t = {t}: its impulse over a step, {:.1e}, overflows the energy",
                (u * dt).abs()
            )
        })
    })
}

/// Takes the scheme's own steps (an adaptive scheme's accepted steps, [`Simulation::step_own`])
/// until the time is `t_end`, calling `observer` after each; stops before the next step once
/// `interrupt` is raised. Failing and stopped like [`advance`]; a simulation stopped by an event
/// before takes no step. A scheme without steps of its own takes none.
pub fn advance_own_until(
    sim: &mut dyn Simulation,
    t_end: f64,
    observer: &mut dyn RunObserver,
    interrupt: &AtomicBool,
) -> Advanced {
    let mut steps = 0;
    while sim.stopped().is_none() {
        if interrupt.load(Ordering::Relaxed) {
            // Raised after the last step: the run is complete, not interrupted.
            let t = sim.time();
            let done = (t_end - t).abs() <= 8.0 * f64::EPSILON * (t_end.abs() + t.abs());
            return Advanced {
                steps,
                error: None,
                interrupted: !done,
            };
        }
        match sim.step_own(t_end) {
            Ok(None) => break,
            Ok(Some(_)) => {
                steps += 1;
                observer.observe(steps, sim);
            }
            Err(e) => {
                return Advanced {
                    steps,
                    error: Some(failure(steps, sim, &e)),
                    interrupted: false,
                };
            }
        }
    }
    Advanced {
        steps,
        error: None,
        interrupted: false,
    }
}

/// Takes the steps of `plan`: its full steps of `dt`, then, when `dt` does not divide `t_end`,
/// the shorter last step that lands on `t_end` ([`Simulation::advance_to`]) — or, when the
/// plan asks for [`own_steps`](RunPlan::own_steps) and the scheme has them, the scheme's own
/// steps to `t_end` ([`advance_own_until`]). Observed, failing and stopped like [`advance`].
pub fn advance_plan(
    sim: &mut dyn Simulation,
    plan: &RunPlan,
    observer: &mut dyn RunObserver,
) -> Advanced {
    advance_plan_until(sim, plan, observer, &AtomicBool::new(false))
}

/// [`advance_plan`] that stops once `interrupt` is raised, like [`advance_until`].
pub fn advance_plan_until(
    sim: &mut dyn Simulation,
    plan: &RunPlan,
    observer: &mut dyn RunObserver,
    interrupt: &AtomicBool,
) -> Advanced {
    if plan.own_steps && sim.adaptive_stats().is_some() {
        return advance_own_until(sim, plan.t_end, observer, interrupt);
    }
    if plan.dense && sim.adaptive_stats().is_some() {
        return advance_dense_until(sim, plan, observer, interrupt);
    }
    let done = advance_until(sim, plan.steps, observer, interrupt);
    if done.error.is_some()
        || done.interrupted
        || sim.stopped().is_some()
        || plan.last_step.is_none()
    {
        return done;
    }
    if interrupt.load(Ordering::Relaxed) {
        return Advanced {
            interrupted: true,
            ..done
        };
    }
    match sim.advance_to(plan.t_end) {
        Ok(0) => done,
        Ok(_) => {
            observer.observe(done.steps + 1, sim);
            Advanced {
                steps: done.steps + 1,
                ..done
            }
        }
        Err(e) => Advanced {
            error: Some(failure(done.steps, sim, &e)),
            ..done
        },
    }
}

/// Runs the steps of `plan` (see [`advance_plan`]) of `sim`, computing the planned diagnostics
/// after every step and passing each state to `observe` (also the initial one). A failing step
/// ends the run: the state stays the last good one and the summary's `error` says what
/// happened.
pub fn run(
    sim: &mut dyn Simulation,
    plan: &RunPlan,
    observe: &mut dyn FnMut(&Sample<'_>),
) -> RunSummary {
    run_until(sim, plan, observe, &AtomicBool::new(false))
}

/// [`run`] that stops before the next step once `interrupt` is raised (Ctrl-C in the
/// command): the summary then covers the steps taken and says `interrupted`.
pub fn run_until(
    sim: &mut dyn Simulation,
    plan: &RunPlan,
    observe: &mut dyn FnMut(&Sample<'_>),
    interrupt: &AtomicBool,
) -> RunSummary {
    sim.reset_counters();
    let run_start = Instant::now();
    let mut energy = plan.energy.then(|| EnergyBudget::new(sim));
    let mut residuals = plan.residuals.then(Residuals::default);
    let mut clock = StepClock::default();
    let with_outputs = !sim.output_names().is_empty();
    let mut outputs = Vec::new();
    let mut multipliers = Vec::new();
    let mut each = |step: usize, sim: &mut dyn Simulation| {
        clock.stop();
        energy.observe(step, sim);
        residuals.observe(step, sim);
        let last = residuals.as_ref().and_then(|r| r.last);
        if with_outputs {
            sim.outputs(&mut outputs);
        }
        if plan.multipliers && step > 0 {
            multipliers = sim.multipliers().unwrap_or_default();
        }
        observe(&Sample {
            step,
            t: sim.time(),
            x: sim.state(),
            energy: energy.as_ref().map(|e| e.last),
            dissipated: energy.as_ref().and_then(|e| e.dissipated),
            supplied: energy.as_ref().and_then(|e| e.supplied),
            g: last.map(|r| r.0),
            phi: last.map(|r| r.1),
            outputs: &outputs,
            multipliers: &multipliers,
        });
        clock.start();
    };
    each(0, sim);
    let own = plan.own_steps && sim.adaptive_stats().is_some();
    let done = advance_plan_until(sim, plan, &mut each, interrupt);
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
        steps_planned: if own { taken } else { plan.total_steps() },
        own_steps: own,
        last_step: plan
            .last_step
            .filter(|_| !own && taken == plan.total_steps()),
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
        energy_balance_warning: e
            .filter(|e| e.dissipated.is_some() || e.supplied.is_some())
            .and_then(|e| {
                summary::budget_warning(
                    e.max_balance_error,
                    e.dissipated.unwrap_or(0.0),
                    e.supplied.unwrap_or(0.0),
                    e.initial.abs().max(e.last.abs()),
                    sim.adaptive_stats().is_some(),
                )
            }),
        effects,
        residual_evaluations: stats.residual_evaluations,
        newton_iterations: stats.newton_iterations,
        ns_per_step: if taken > 0 {
            clock.elapsed().as_nanos() as f64 / taken as f64
        } else {
            0.0
        },
        error: done.error,
        interrupted: done.interrupted,
        adaptive: sim.adaptive_stats().map(Into::into),
    }
}
