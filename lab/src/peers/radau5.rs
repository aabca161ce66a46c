//! Radau5 on the index-3 DAE `x' = M(∇H + Gᵀλ)`, `0 = g(x)` (mass matrix `diag(I, 0)`), from
//! the maintained `differential-equations` crate, configured as Hairer's code is used for
//! mechanics: velocities declared index 2, multipliers index 3, tolerances passed as a *vector*
//! and the Newton tolerance left to Hairer's formula.
//!
//! Why each setting: the crate turns a scalar tolerance into `0.1·rtol^{2/3}` once per component
//! inside a loop, so a scalar `1e-12` becomes ~4e-5 and the error stops falling with the
//! tolerance; a vector is transformed once, as in Hairer's `RADAU5`. Its default Newton
//! tolerance is fixed at ~3e-3; a non-positive value selects Hairer's
//! `max(10 u / rtol′, min(0.03, rtol′^{1/2}))` (~3e-5 at 1e-12). What cannot be configured: it
//! does not refactor its LU after a step-size change (after a rejection or the shortened last
//! step), which shows as "step size too small" just before `T` at some tolerances — those runs
//! are reported as rows with the peer's message.

use super::problem::PeerProblem;
use super::{PeerRun, Tracked};
use differential_equations::linalg::Matrix;
use differential_equations::prelude::{
    ControlFlag, DAE, IVP, ImplicitRungeKutta, Interpolation, Solout, Solution,
};
use std::cell::RefCell;

/// The `n + m` Radau5 runs on: the damped pendulum and the paper's example (5), the stiff
/// ten-link chain (50), ten particles on a sphere (70), the Fekete problem's twenty (140). The crate's first step builds its stage
/// vectors with `State::zeros()`, empty for `Vec`, so each size is a fixed array.
pub const RADAU_DIMS: [usize; 4] = [5, 50, 70, 140];

/// The most steps a run may take (a run whose steps keep shrinking stops there, as a row).
const MAX_STEPS: usize = 10_000_000;

/// The index-3 DAE of a peer problem: `y = (x, λ)`.
struct Index3<'a, P: ?Sized>(&'a P);

impl<P: PeerProblem + ?Sized, const N: usize> DAE<f64, [f64; N]> for Index3<'_, P> {
    fn diff(&self, _t: f64, y: &[f64; N], f: &mut [f64; N]) {
        let n = self.0.n();
        let (x, l) = y.split_at(n);
        let (fx, fl) = f.split_at_mut(n);
        self.0.field(x, l, fx);
        self.0.g(x, fl);
    }
    fn mass(&self, m: &mut Matrix<f64>) {
        for i in 0..self.0.n() {
            m[(i, i)] = 1.0;
        }
    }
}

/// Records every accepted step through the crate's output hook.
struct Track<'a, P: ?Sized> {
    problem: &'a P,
    observe: bool,
    state: &'a RefCell<Tracked>,
}

impl<P: PeerProblem + ?Sized, const N: usize> Solout<f64, [f64; N]> for Track<'_, P> {
    fn solout<I>(
        &mut self,
        _t: f64,
        _t_prev: f64,
        y: &[f64; N],
        _y_prev: &[f64; N],
        _interpolator: &mut I,
        _solution: &mut Solution<f64, [f64; N]>,
    ) -> ControlFlag<f64, [f64; N]>
    where
        I: Interpolation<f64, [f64; N]> + ?Sized,
    {
        self.state
            .borrow_mut()
            .record(self.problem, &y[..self.problem.n()], self.observe);
        ControlFlag::Continue
    }
}

/// Radau5 from `x0` to `t_end` at tolerance `tol` (relative and absolute).
pub(super) fn solve<P: PeerProblem + ?Sized>(
    problem: &P,
    x0: &[f64],
    t_end: f64,
    tol: f64,
    observe: bool,
) -> Result<PeerRun, String> {
    match problem.n() + problem.m() {
        5 => solve_sized::<P, 5>(problem, x0, t_end, tol, observe),
        50 => solve_sized::<P, 50>(problem, x0, t_end, tol, observe),
        70 => solve_sized::<P, 70>(problem, x0, t_end, tol, observe),
        140 => solve_sized::<P, 140>(problem, x0, t_end, tol, observe),
        d => Err(format!(
            "Radau5 is built here for n + m in {RADAU_DIMS:?} only (this scene has {d})"
        )),
    }
}

fn solve_sized<P: PeerProblem + ?Sized, const N: usize>(
    problem: &P,
    x0: &[f64],
    t_end: f64,
    tol: f64,
    observe: bool,
) -> Result<PeerRun, String> {
    let (n, m) = (problem.n(), problem.m());
    let state = RefCell::new(Tracked::new(problem, x0));
    let track = Track {
        problem,
        observe,
        state: &state,
    };
    let mut y0 = [0.0; N];
    y0[..n].copy_from_slice(x0);
    problem.mu(x0, &mut y0[n..]);
    let dae = Index3(problem);
    let sol = IVP::dae(&dae, 0.0, t_end, y0)
        .solout(track)
        .method(
            ImplicitRungeKutta::radau5()
                .rtol(vec![tol; N])
                .atol(vec![tol; N])
                .newton_tol(0.0)
                .max_steps(MAX_STEPS)
                .index2_equations((n / 2..n).collect::<Vec<_>>())
                .index3_equations((n..n + m).collect::<Vec<_>>()),
        )
        .solve()
        .map_err(|e| format!("{e:?}").chars().take(300).collect::<String>())?;
    Ok(state.into_inner().finish(
        sol.steps.accepted as u64,
        sol.evals.function as u64,
        sol.evals.newton as u64,
        sol.evals.decompositions as u64,
    ))
}
