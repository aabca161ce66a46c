//! Peer solvers on the same problems: Hairer's DOP853 on the index-1 ODE and
//! Radau5 on the index-3 DAE, from the maintained `differential-equations` crate.
//!
//! ```text
//! index-1 ODE:  x' = M(x) (∇H(x) + G(x)ᵀ μ(x))      μ from d²g/dt² = 0 (the flow of H + μᵀg)
//! index-3 DAE:  x' = M(x) (∇H(x) + G(x)ᵀ λ),  0 = g(x)      (mass matrix diag(I, 0))
//! ```
//!
//! For a scene, `x = (q, p)`, `M = [[0, I], [−I, K − R]]` and position constraints give
//! `(G W⁻¹ Gᵀ) μ = G W⁻¹ ((K − R) v − ∇V) + Ġ v`, `v = W⁻¹ p` (`Ġ v` is `|v_a − v_b|²` for a rod,
//! `|v|²` for a sphere, 0 for planes and pins): a sparse solve per right-hand side, through the
//! library's own [`AutoLu`] on the pattern of `G W⁻¹ Gᵀ` recorded once. The paper's example
//! has `μ` in closed form. Neither formulation keeps `g = 0`: the index-1 ODE drifts off it, and
//! Radau5 (velocities declared index 2, multipliers index 3) holds it only to ~1e-5 … 1e-7 here;
//! their `max |g|` is reported in its own column. States of the sizes instantiated below are
//! fixed arrays (DOP853 for `n = 4`, Radau5 for `n + m = 5`), others `Vec`.

use crate::precision::plan::{PrecisionPlan, PrecisionRow, Reference, distance, min_median};
use differential_equations::linalg::Matrix;
use differential_equations::prelude::{
    ControlFlag, DAE, ExplicitRungeKutta, IVP, ImplicitRungeKutta, Interpolation, ODE, Solout,
    Solution,
};
use faer::Col;
use lieflow::System;
use lieflow::Vector;
use lieflow::scene::MassGram;
use lieflow::scene::Scene;
use lieflow::scene::SceneModel;
use lieflow::system::{Hamiltonian, HolonomicConstraint, StructureMatrix};
use std::cell::RefCell;
use std::sync::Arc;
use std::time::Instant;

/// The most steps a peer may take in one run (a run whose steps keep shrinking stops there,
/// as a row, instead of stalling the set).
pub const PEER_MAX_STEPS: usize = 10_000_000;

/// The `n + m` Radau5 runs on (see [`PeerState`]): the paper's example and a planar pendulum.
pub const RADAU_DIM: usize = 5;

/// A constrained problem as the peers see it.
trait PeerProblem {
    fn n(&self) -> usize;
    fn m(&self) -> usize;
    /// `out = M (∇H + Gᵀλ)` at `x`.
    fn field(&self, x: &[f64], lambda: &[f64], out: &mut [f64]);
    /// The index-1 multiplier `μ(x)`.
    fn mu(&self, x: &[f64], out: &mut [f64]);
    /// `out = M (∇H + Gᵀμ(x))`, the index-1 right-hand side (`mu` is scratch of `m` entries).
    fn index1(&self, x: &[f64], mu: &mut [f64], out: &mut [f64]) {
        self.mu(x, mu);
        self.field(x, mu, out);
    }
    /// LU factorizations per right-hand side of the index-1 ODE (a sparse solve for `μ`).
    fn factorizations_per_rhs(&self) -> u64 {
        0
    }
    /// `g(x)`.
    fn g(&self, x: &[f64], out: &mut [f64]);
    /// `φ(x) = G M ∇H`.
    fn phi(&self, x: &[f64], out: &mut [f64]);
    /// `H(x)`.
    fn energy(&self, x: &[f64]) -> f64;
}

/// The paper's example: `M (a₁, a₂, a₃, a₄) = (a₃, a₄, −a₁, −2a₂)`, `H = (x₃² + x₄²)/2`,
/// `g = (x₁² + x₂² − 1)/2`, `μ = (x₃² + x₄²)/(x₁² + 2x₂²)`.
struct Paper;

impl PeerProblem for Paper {
    fn n(&self) -> usize {
        4
    }
    fn m(&self) -> usize {
        1
    }
    fn field(&self, x: &[f64], l: &[f64], out: &mut [f64]) {
        out[0] = x[2];
        out[1] = x[3];
        out[2] = -l[0] * x[0];
        out[3] = -2.0 * l[0] * x[1];
    }
    fn mu(&self, x: &[f64], out: &mut [f64]) {
        out[0] = (x[2] * x[2] + x[3] * x[3]) / (x[0] * x[0] + 2.0 * x[1] * x[1]);
    }
    fn g(&self, x: &[f64], out: &mut [f64]) {
        out[0] = 0.5 * (x[0] * x[0] + x[1] * x[1] - 1.0);
    }
    fn phi(&self, x: &[f64], out: &mut [f64]) {
        out[0] = x[0] * x[2] + x[1] * x[3];
    }
    fn energy(&self, x: &[f64]) -> f64 {
        0.5 * (x[2] * x[2] + x[3] * x[3])
    }
}

/// Workspace of a scene's peer problem.
struct SceneWork {
    x: Col<f64>,
    t1: Col<f64>,
    t2: Col<f64>,
    rhs: Vec<f64>,
    grad: Vec<f64>,
    /// Velocities `W⁻¹ p`.
    vel: Vec<f64>,
    full: Col<f64>,
    mu: Vec<f64>,
    gram: MassGram,
}

/// A scene as a peer problem (see the module docs).
struct ScenePeer {
    model: Arc<SceneModel>,
    /// `model` as a system, for the hidden constraint.
    system: System<Arc<SceneModel>, Arc<SceneModel>, Arc<SceneModel>>,
    work: RefCell<SceneWork>,
}

impl ScenePeer {
    fn new(model: Arc<SceneModel>, x0: &[f64]) -> Result<Self, String> {
        let m = model.constraint_rows();
        let n = model.state_len();
        let gram = MassGram::new(&model, &x0[..n / 2]).map_err(|e| e.to_string())?;
        let zeros = Col::<f64>::zeros(n);
        Ok(Self {
            work: RefCell::new(SceneWork {
                x: zeros.clone(),
                t1: zeros.clone(),
                t2: zeros,
                rhs: vec![0.0; m],
                grad: vec![0.0; n / 2],
                vel: vec![0.0; n / 2],
                full: Col::<f64>::zeros(n),
                mu: vec![0.0; m],
                gram,
            }),
            system: System::new(model.clone(), model.clone(), model.clone()),
            model,
        })
    }
}

impl ScenePeer {
    /// `μ(x)` with `∇V(q)` already in `w.grad`.
    fn mu_from(&self, w: &mut SceneWork, x: &[f64], out: &mut [f64]) {
        let model = &self.model;
        let (n, d) = (model.state_len(), model.space_dim());
        let nq = n / 2;
        // b = G W⁻¹ ((K − R) v − ∇V) + Ġ v: t1 = (0, v) so that M t1 = (v, (K − R) v).
        w.t1.as_mut_slice()[..nq].fill(0.0);
        for i in 0..nq {
            w.t1[nq + i] = model.inv_masses()[i / d] * x[nq + i];
        }
        model.apply(&w.x, &w.t1, &mut w.t2);
        // f = (K − R) v − ∇V, then W⁻¹ f into the q-half of t1 (G acts on positions).
        for i in 0..nq {
            w.t1[i] = model.inv_masses()[i / d] * (w.t2[nq + i] - w.grad[i]);
        }
        w.t1.as_mut_slice()[nq..].fill(0.0);
        HolonomicConstraint::<Col<f64>>::jacobian_apply(model, &w.x, &w.t1, &mut w.rhs);
        for i in 0..nq {
            w.vel[i] = model.inv_masses()[i / d] * x[nq + i];
        }
        model.velocity_curvature_add(&w.vel, &mut w.rhs);
        let ok = w.gram.factor(model, &x[..nq]).is_ok() && w.gram.solve(&mut w.rhs).is_ok();
        if ok {
            out.copy_from_slice(&w.rhs);
        } else {
            out.fill(f64::NAN);
        }
    }
}

impl PeerProblem for ScenePeer {
    fn n(&self) -> usize {
        self.model.state_len()
    }
    fn m(&self) -> usize {
        self.model.constraint_rows()
    }
    fn field(&self, x: &[f64], lambda: &[f64], out: &mut [f64]) {
        let mut w = self.work.borrow_mut();
        let w = &mut *w;
        w.x.as_mut_slice().copy_from_slice(x);
        self.model.gradient(&w.x, &mut w.t1);
        self.model
            .jacobian_transpose_apply_add(&w.x, lambda, 1.0, &mut w.t1);
        self.model.apply(&w.x, &w.t1, &mut w.t2);
        out.copy_from_slice(w.t2.as_slice());
    }
    fn mu(&self, x: &[f64], out: &mut [f64]) {
        let mut w = self.work.borrow_mut();
        let w = &mut *w;
        w.x.as_mut_slice().copy_from_slice(x);
        w.grad.fill(0.0);
        let nq = self.model.state_len() / 2;
        self.model
            .potential_gradient_add(&x[..nq], 1.0, &mut w.grad);
        self.mu_from(w, x, out);
    }
    fn index1(&self, x: &[f64], _mu: &mut [f64], out: &mut [f64]) {
        // ∇H once: its q-half is ∇V for μ's right-hand side, all of it for the field.
        let mut w = self.work.borrow_mut();
        let w = &mut *w;
        let nq = self.model.state_len() / 2;
        w.x.as_mut_slice().copy_from_slice(x);
        self.model.gradient(&w.x, &mut w.full);
        w.grad.copy_from_slice(&w.full.as_slice()[..nq]);
        let mut mu = std::mem::take(&mut w.mu);
        self.mu_from(w, x, &mut mu);
        self.model
            .jacobian_transpose_apply_add(&w.x, &mu, 1.0, &mut w.full);
        w.mu = mu;
        self.model.apply(&w.x, &w.full, &mut w.t2);
        out.copy_from_slice(w.t2.as_slice());
    }
    fn factorizations_per_rhs(&self) -> u64 {
        1
    }
    fn g(&self, x: &[f64], out: &mut [f64]) {
        let mut w = self.work.borrow_mut();
        w.x.as_mut_slice().copy_from_slice(x);
        HolonomicConstraint::<Col<f64>>::residual(&self.model, &w.x, out);
    }
    fn phi(&self, x: &[f64], out: &mut [f64]) {
        let mut w = self.work.borrow_mut();
        let w = &mut *w;
        w.x.as_mut_slice().copy_from_slice(x);
        self.system
            .hidden_constraint(&w.x, &mut w.t1, &mut w.t2, out);
    }
    fn energy(&self, x: &[f64]) -> f64 {
        let mut w = self.work.borrow_mut();
        w.x.as_mut_slice().copy_from_slice(x);
        self.model.energy(&w.x)
    }
}

/// A peer's state type: `Vec<f64>` for DOP853, `[f64; N]` for Radau5 (whose first step builds
/// its stage vectors with `State::zeros()`, which is empty for dynamically sized states).
trait PeerState: differential_equations::traits::State<f64> + AsRef<[f64]> + AsMut<[f64]> {
    fn from_slice(x: &[f64]) -> Self;
}

impl PeerState for Vec<f64> {
    fn from_slice(x: &[f64]) -> Self {
        x.to_vec()
    }
}

impl<const N: usize> PeerState for [f64; N] {
    fn from_slice(x: &[f64]) -> Self {
        let mut a = [0.0; N];
        a.copy_from_slice(x);
        a
    }
}

/// The index-1 ODE of a peer problem.
struct Index1<'a, P: ?Sized>(&'a P, RefCell<Vec<f64>>);

impl<P: PeerProblem + ?Sized, Y: PeerState> ODE<f64, Y> for Index1<'_, P> {
    fn diff(&self, _t: f64, x: &Y, dx: &mut Y) {
        let mut mu = self.1.borrow_mut();
        self.0.index1(x.as_ref(), &mut mu, dx.as_mut());
    }
}

/// The index-3 DAE of a peer problem: `y = (x, λ)`.
struct Index3<'a, P: ?Sized>(&'a P);

impl<P: PeerProblem + ?Sized, Y: PeerState> DAE<f64, Y> for Index3<'_, P> {
    fn diff(&self, _t: f64, y: &Y, f: &mut Y) {
        let n = self.0.n();
        let (x, l) = y.as_ref().split_at(n);
        let (fx, fl) = f.as_mut().split_at_mut(n);
        self.0.field(x, l, fx);
        self.0.g(x, fl);
    }
    fn mass(&self, m: &mut Matrix<f64>) {
        for i in 0..self.0.n() {
            m[(i, i)] = 1.0;
        }
    }
}

/// What a run's tracker records.
struct Tracked {
    last: Vec<f64>,
    max_g: f64,
    max_phi: f64,
    max_de: f64,
    scratch: Vec<f64>,
}

/// Keeps the last accepted state and, when asked, the residuals and energy along the run.
struct Track<'a, P: ?Sized> {
    problem: &'a P,
    n: usize,
    observe: bool,
    e0: f64,
    state: &'a RefCell<Tracked>,
}

impl<P: PeerProblem + ?Sized, Y: PeerState> Solout<f64, Y> for Track<'_, P> {
    fn solout<I>(
        &mut self,
        _t: f64,
        _t_prev: f64,
        y: &Y,
        _y_prev: &Y,
        _interpolator: &mut I,
        _solution: &mut Solution<f64, Y>,
    ) -> ControlFlag<f64, Y>
    where
        I: Interpolation<f64, Y> + ?Sized,
    {
        let x = &y.as_ref()[..self.n];
        let mut st = self.state.borrow_mut();
        let st = &mut *st;
        st.last.copy_from_slice(x);
        if self.observe {
            let inf = |v: &[f64]| v.iter().fold(0.0f64, |a, b| a.max(b.abs()));
            self.problem.g(x, &mut st.scratch);
            st.max_g = st.max_g.max(inf(&st.scratch));
            self.problem.phi(x, &mut st.scratch);
            st.max_phi = st.max_phi.max(inf(&st.scratch));
            st.max_de = st.max_de.max((self.problem.energy(x) - self.e0).abs());
        }
        ControlFlag::Continue
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
    let (nx, n) = (problem.n(), problem.n() + problem.m());
    // Fixed-size arrays where instantiated (no allocation per stage in the peer's step; Radau5
    // needs them, see `PeerState`), `Vec` otherwise.
    let run = || match peer {
        Peer::Dop853 if nx == 4 => {
            solve_with::<P, [f64; 4]>(problem, peer, x0, t_end, tol, observe)
        }
        Peer::Dop853 => solve_with::<P, Vec<f64>>(problem, peer, x0, t_end, tol, observe),
        Peer::Radau5 if n == RADAU_DIM => {
            solve_with::<P, [f64; RADAU_DIM]>(problem, peer, x0, t_end, tol, observe)
        }
        Peer::Radau5 => Err(format!(
            "Radau5 runs here for n + m = {RADAU_DIM} only (n + m = {n})"
        )),
    };
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(run))
        .unwrap_or_else(|_| Err("the peer solver panicked".to_owned()))
}

fn solve_with<P: PeerProblem + ?Sized, Y: PeerState>(
    problem: &P,
    peer: Peer,
    x0: &[f64],
    t_end: f64,
    tol: f64,
    observe: bool,
) -> Result<PeerRun, String> {
    let (n, m) = (problem.n(), problem.m());
    let state = RefCell::new(Tracked {
        last: x0.to_vec(),
        max_g: 0.0,
        max_phi: 0.0,
        max_de: 0.0,
        scratch: vec![0.0; m],
    });
    let track = Track {
        problem,
        n,
        observe,
        e0: problem.energy(x0),
        state: &state,
    };
    let short = |e: String| e.chars().take(300).collect::<String>();
    let (steps, evals) = match peer {
        Peer::Dop853 => {
            let ode = Index1(problem, RefCell::new(vec![0.0; m]));
            let sol = IVP::ode(&ode, 0.0, t_end, Y::from_slice(x0))
                .solout(track)
                .method(
                    ExplicitRungeKutta::dop853()
                        .rtol(tol)
                        .atol(tol)
                        .max_steps(usize::MAX),
                )
                .solve()
                .map_err(|e| short(format!("{e:?}")))?;
            (sol.steps, sol.evals)
        }
        Peer::Radau5 => {
            let mut y0 = x0.to_vec();
            let mut mu = vec![0.0; m];
            problem.mu(x0, &mut mu);
            y0.extend_from_slice(&mu);
            let dae = Index3(problem);
            let sol = IVP::dae(&dae, 0.0, t_end, Y::from_slice(&y0))
                .solout(track)
                .method(
                    ImplicitRungeKutta::radau5()
                        .rtol(tol)
                        .atol(tol)
                        .max_steps(PEER_MAX_STEPS)
                        // Velocities index 2, multipliers index 3 (Hairer's setup for
                        // mechanics); the crate's default Newton tolerance.
                        .index2_equations((n / 2..n).collect::<Vec<_>>())
                        .index3_equations((n..n + m).collect::<Vec<_>>()),
                )
                .solve()
                .map_err(|e| short(format!("{e:?}")))?;
            (sol.steps, sol.evals)
        }
    };
    let st = state.into_inner();
    Ok(PeerRun {
        x: st.last,
        max_g: st.max_g,
        max_phi: st.max_phi,
        max_de: st.max_de,
        steps: steps.accepted as u64,
        evaluations: evals.function as u64,
        newton: evals.newton as u64,
        // The index-1 ODE factors G W⁻¹ Gᵀ in every right-hand side; Radau5 counts its own.
        decompositions: match peer {
            Peer::Dop853 => evals.function as u64 * problem.factorizations_per_rhs(),
            Peer::Radau5 => evals.decompositions as u64,
        },
    })
}

/// The peers' rows for a scene (nothing for built-in models other than the paper's).
pub(crate) fn peer_rows(
    scene: &Scene,
    plan: &PrecisionPlan,
    reference: &Reference,
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
            if peer == Peer::Radau5 && problem.n() + problem.m() != RADAU_DIM {
                rows.push(PrecisionRow::failed(
                    name,
                    None,
                    Some(tol),
                    "Skipped",
                    format!(
                        "n + m = {}: differential-equations 0.7's Radau5 panics on dynamically sized states (its first step builds stage vectors with State::zeros(), empty for Vec), so it runs on fixed-size arrays, here n + m = {RADAU_DIM}",
                        problem.n() + problem.m()
                    ),
                ));
                continue;
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
