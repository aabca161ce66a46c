//! Peer solvers on the same problems, each at its best: Hairer's DOP853 (`dop853.rs`, his code's
//! algorithm on slices, 12 right-hand sides per step) on the index-1 ODE, and Radau5
//! (`radau5.rs`, the `differential-equations` crate configured as Hairer's code is used for
//! mechanics) on the index-3 DAE.
//!
//! ```text
//! index-1 ODE:  x' = M(x) (∇H(x) + G(x)ᵀ μ(x))      μ from d²g/dt² = 0 (the flow of H + μᵀg)
//! index-3 DAE:  x' = M(x) (∇H(x) + G(x)ᵀ λ),  0 = g(x)      (mass matrix diag(I, 0))
//! ```
//!
//! Neither formulation keeps `g = 0`: the index-1 ODE drifts off it, and Radau5 holds it to its
//! tolerance; their `max |g|` is reported in its own column.

pub mod dop853;
mod problem;
mod radau5;

use crate::precision::plan::{PrecisionPlan, PrecisionRow, Reference, distance, min_median};
use dop853::Dop853;
use lieflow::scene::{Scene, SceneModel};
use problem::{Paper, PeerProblem, ScenePeer};
use std::time::Instant;

/// The most steps a peer may take in one run (a run whose steps keep shrinking stops there,
/// as a row, instead of stalling the set).
pub const PEER_MAX_STEPS: u64 = 10_000_000;

/// What a run records at its accepted steps: the last state and, when observed, the largest
/// residuals and energy change.
struct Tracked {
    last: Vec<f64>,
    max_g: f64,
    max_phi: f64,
    max_de: f64,
    e0: f64,
    scratch: Vec<f64>,
}

impl Tracked {
    fn new<P: PeerProblem + ?Sized>(problem: &P, x0: &[f64]) -> Self {
        Self {
            last: x0.to_vec(),
            max_g: 0.0,
            max_phi: 0.0,
            max_de: 0.0,
            e0: problem.energy(x0),
            scratch: vec![0.0; problem.m()],
        }
    }

    fn record<P: PeerProblem + ?Sized>(&mut self, problem: &P, x: &[f64], observe: bool) {
        self.last.copy_from_slice(x);
        if observe {
            let inf = |v: &[f64]| v.iter().fold(0.0f64, |a, b| a.max(b.abs()));
            problem.g(x, &mut self.scratch);
            self.max_g = self.max_g.max(inf(&self.scratch));
            problem.phi(x, &mut self.scratch);
            self.max_phi = self.max_phi.max(inf(&self.scratch));
            self.max_de = self.max_de.max((problem.energy(x) - self.e0).abs());
        }
    }

    fn finish(self, steps: u64, evaluations: u64, newton: u64, decompositions: u64) -> PeerRun {
        PeerRun {
            x: self.last,
            max_g: self.max_g,
            max_phi: self.max_phi,
            max_de: self.max_de,
            steps,
            evaluations,
            newton,
            decompositions,
        }
    }
}

/// A peer run's outcome.
struct PeerRun {
    x: Vec<f64>,
    max_g: f64,
    max_phi: f64,
    max_de: f64,
    steps: u64,
    evaluations: u64,
    newton: u64,
    decompositions: u64,
}

#[derive(Clone, Copy, PartialEq)]
enum Peer {
    Dop853,
    Radau5,
}

/// Runs a peer, catching a panic inside the peer crate as an error (a peer's failure is a row,
/// never a crash).
fn solve_peer<P: PeerProblem + ?Sized>(
    problem: &P,
    peer: Peer,
    x0: &[f64],
    t_end: f64,
    tol: f64,
    observe: bool,
) -> Result<PeerRun, String> {
    let run = || match peer {
        Peer::Dop853 => solve_dop853(problem, x0, t_end, tol, observe),
        Peer::Radau5 => radau5::solve(problem, x0, t_end, tol, observe),
    };
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(run))
        .unwrap_or_else(|_| Err("the peer solver panicked".to_owned()))
}

/// DOP853 on the index-1 ODE.
fn solve_dop853<P: PeerProblem + ?Sized>(
    problem: &P,
    x0: &[f64],
    t_end: f64,
    tol: f64,
    observe: bool,
) -> Result<PeerRun, String> {
    let mut tracked = Tracked::new(problem, x0);
    let mut mu = vec![0.0; problem.m()];
    let mut x = x0.to_vec();
    let stats = Dop853::new(x.len(), tol, tol)
        .max_steps(PEER_MAX_STEPS)
        .solve(
            |t, x, dx| problem.index1(t, x, &mut mu, dx),
            &mut x,
            t_end,
            |_, x| tracked.record(problem, x, observe),
        )
        .map_err(|e| e.to_string())?;
    let factorizations = stats.evaluations * problem.factorizations_per_rhs();
    Ok(tracked.finish(stats.accepted, stats.evaluations, 0, factorizations))
}

/// The peers' rows for a scene (nothing for built-in models other than the paper's); no run
/// starts once `stopped()` holds.
pub(crate) fn peer_rows(
    scene: &Scene,
    plan: &PrecisionPlan,
    reference: &Reference,
    stopped: &dyn Fn() -> bool,
) -> Vec<PrecisionRow> {
    let t_end = scene.file.integrator.t_end;
    let problem: Box<dyn PeerProblem>;
    let x0: Vec<f64>;
    let dissipative;
    match &scene.file.builtin {
        Some(b) if b.model == "paper" => {
            problem = Box::new(Paper);
            x0 = vec![1.0, 0.0, 0.0, -0.15];
            dissipative = false;
        }
        Some(b) => {
            return vec![PrecisionRow::failed(
                "peers",
                None,
                None,
                "Skipped",
                format!("no peer formulation for the built-in model '{}'", b.model),
            )];
        }
        None => {
            let compiled = match scene.compile() {
                Ok(c) => c,
                Err(e) => {
                    return vec![PrecisionRow::failed(
                        "peers",
                        None,
                        None,
                        "Setup",
                        e.to_string(),
                    )];
                }
            };
            let model = compiled.model.expect("a scene of bodies has a model");
            x0 = compiled.simulation.state().to_vec();
            dissipative = SceneModel::is_dissipative(&model);
            match ScenePeer::new(model, &x0) {
                Ok(p) => problem = Box::new(p),
                Err(e) => return vec![PrecisionRow::failed("peers", None, None, "Setup", e)],
            }
        }
    }
    let mut rows = Vec::new();
    for (peer, name) in [
        (Peer::Dop853, "DOP853 (index-1 ODE)"),
        (Peer::Radau5, "Radau5 (index-3 DAE)"),
    ] {
        for &tol in &plan.tolerances {
            if stopped() {
                return rows;
            }
            let observed = match solve_peer(&*problem, peer, &x0, t_end, tol, true) {
                Ok(r) => r,
                Err(e) => {
                    rows.push(PrecisionRow::failed(name, None, Some(tol), "PeerError", e));
                    continue;
                }
            };
            let mut times = Vec::new();
            for _ in 0..plan.repeats {
                let start = Instant::now();
                if solve_peer(&*problem, peer, &x0, t_end, tol, false).is_err() {
                    break;
                }
                times.push(start.elapsed().as_secs_f64());
            }
            let (time_min, time_median) = min_median(times);
            let finite = observed.x.iter().all(|v| v.is_finite());
            rows.push(PrecisionRow {
                method: name.to_owned(),
                dt: None,
                tol: Some(tol),
                status: if finite { "ok" } else { "NonFinite" }.to_owned(),
                message: String::new(),
                error: finite.then(|| distance(&observed.x, &reference.x)),
                max_abs_g: Some(observed.max_g),
                max_abs_phi: Some(observed.max_phi),
                energy_error: (!dissipative && !crate::precision::plan::is_paper(scene))
                    .then_some(observed.max_de),
                steps: observed.steps,
                evaluations: observed.evaluations,
                newton_iterations: observed.newton,
                factorizations: observed.decompositions,
                time_min,
                time_median,
            });
        }
    }
    rows
}
