//! A run that reports at every `dt` from the dense output of its own steps.

use super::{Advanced, RunPlan, Simulation, failure};
use crate::error::StepError;
use crate::scene::observe::RunObserver;
use std::sync::atomic::{AtomicBool, Ordering};

/// Takes the scheme's own steps to `plan.t_end` and reports at the plan's times (`k dt`, and
/// `t_end` when `dt` does not divide it): each report time inside an accepted step is shown
/// from its dense output ([`Simulation::observe_at`]) while the steps go on from their own
/// ends, so the reports do not shorten them; a report time a step ends on is observed as it
/// is. The observer's step number is the report's. Stops before the next step once
/// `interrupt` is raised, and at an event that stops the run (its state the last row).
/// A scheme without dense output reports by [`advance_plan_until`](super::advance_plan_until)'s
/// steps.
pub fn advance_dense_until(
    sim: &mut dyn Simulation,
    plan: &RunPlan,
    observer: &mut dyn RunObserver,
    interrupt: &AtomicBool,
) -> Advanced {
    let reports = plan.total_steps();
    let t0 = sim.time();
    let dt = sim_dt(plan, t0);
    let at = |k: usize| {
        if k >= reports {
            plan.t_end
        } else {
            t0 + k as f64 * dt
        }
    };
    let slack = |a: f64, b: f64| 8.0 * f64::EPSILON * (a.abs() + b.abs());
    let mut done = 0;
    // The time of the last row (the caller observed the initial state).
    let mut seen = t0;
    while done < reports {
        let t = sim.time();
        let next = at(done + 1);
        if (next - t).abs() <= slack(next, t) {
            done += 1;
            seen = t;
            observer.observe(done, sim);
            continue;
        }
        if next < t {
            match sim.observe_at(next, &mut |s| observer.observe(done + 1, s)) {
                Ok(true) => {
                    done += 1;
                    seen = next;
                    continue;
                }
                Ok(false) => break,
                Err(e) => return failed(done, sim, &e),
            }
        }
        if sim.stopped().is_some() {
            // Stopped by an event inside the step, after the report times before it: its
            // state is the last row, as when the steps land on the report times.
            if seen != t {
                done += 1;
                observer.observe(done, sim);
            }
            break;
        }
        if interrupt.load(Ordering::Relaxed) {
            return Advanced {
                steps: done,
                error: None,
                interrupted: true,
            };
        }
        match sim.step_own(plan.t_end) {
            Ok(Some(_)) => {}
            Ok(None) => break,
            Err(e) => return failed(done, sim, &e),
        }
    }
    Advanced {
        steps: done,
        error: None,
        interrupted: false,
    }
}

/// The run ended by a failed step or dense output after `done` reports.
fn failed(done: usize, sim: &dyn Simulation, e: &StepError) -> Advanced {
    Advanced {
        steps: done,
        error: Some(failure(done, sim, e)),
        interrupted: false,
    }
}

/// The report interval: `t_end / steps` rounded as the plan's grid is (`t_end` is `steps · dt`
/// plus the shorter last step).
fn sim_dt(plan: &RunPlan, t0: f64) -> f64 {
    let full = plan.t_end - t0 - plan.last_step.unwrap_or(0.0);
    full / plan.steps.max(1) as f64
}
