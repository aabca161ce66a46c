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
//!
//! The crate's first step builds its stage vectors with `State::zeros()`, which is empty for a
//! `Vec`: the sizes of the suite's scenes run on fixed arrays, every other size on [`AnyLen`], a
//! vector whose `zeros()` has the run's length.

use super::problem::PeerProblem;
use super::{PeerRun, Tracked};
use differential_equations::linalg::Matrix;
use differential_equations::prelude::{
    ControlFlag, DAE, IVP, ImplicitRungeKutta, Interpolation, Solout, Solution,
};
use differential_equations::traits::State;
use std::cell::{Cell, RefCell};

thread_local! {
    /// The length of the run's states on this thread, for [`AnyLen`]'s `zeros()`.
    static LEN: Cell<usize> = const { Cell::new(0) };
}

/// A state of the run's length (set on the thread before a run): what `zeros()` needs to build
/// the crate's stage vectors for any size.
#[derive(Clone, Debug)]
pub(super) struct AnyLen(Vec<f64>);

impl State<f64> for AnyLen {
    fn len(&self) -> usize {
        self.0.len()
    }
    fn get_component(&self, i: usize) -> f64 {
        self.0[i]
    }
    fn set_component(&mut self, i: usize, value: f64) {
        self.0[i] = value;
    }
    fn map_components_mut<F: FnMut(usize, &mut f64)>(&mut self, mut f: F) {
        for (i, v) in self.0.iter_mut().enumerate() {
            f(i, v);
        }
    }
    fn zeros_like(&self) -> Self {
        Self(vec![0.0; self.0.len()])
    }
    fn zeros() -> Self {
        Self(vec![0.0; LEN.with(Cell::get)])
    }
    fn mul_add_assign(&mut self, alpha: f64, other: &Self) {
        for (s, &o) in self.0.iter_mut().zip(&other.0) {
            *s += alpha * o;
        }
    }
    fn scale_mut(&mut self, alpha: f64) {
        self.0.iter_mut().for_each(|s| *s *= alpha);
    }
}

/// A state as a slice.
trait Slice: State<f64> {
    fn of(v: &[f64]) -> Self;
    fn slice(&self) -> &[f64];
    fn slice_mut(&mut self) -> &mut [f64];
}

impl<const N: usize> Slice for [f64; N] {
    fn of(v: &[f64]) -> Self {
        core::array::from_fn(|i| v[i])
    }
    fn slice(&self) -> &[f64] {
        self
    }
    fn slice_mut(&mut self) -> &mut [f64] {
        self
    }
}

impl Slice for AnyLen {
    fn of(v: &[f64]) -> Self {
        Self(v.to_vec())
    }
    fn slice(&self) -> &[f64] {
        &self.0
    }
    fn slice_mut(&mut self) -> &mut [f64] {
        &mut self.0
    }
}

/// The most steps a run may take (a run whose steps keep shrinking stops there, as a row).
const MAX_STEPS: usize = 10_000_000;

/// The index-3 DAE of a peer problem: `y = (x, λ)`.
struct Index3<'a, P: ?Sized>(&'a P);

impl<P: PeerProblem + ?Sized, Y: Slice> DAE<f64, Y> for Index3<'_, P> {
    fn diff(&self, t: f64, y: &Y, f: &mut Y) {
        let n = self.0.n();
        let (x, l) = y.slice().split_at(n);
        let (fx, fl) = f.slice_mut().split_at_mut(n);
        self.0.field(t, x, l, fx);
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

impl<P: PeerProblem + ?Sized, Y: Slice> Solout<f64, Y> for Track<'_, P> {
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
        self.state
            .borrow_mut()
            .record(self.problem, &y.slice()[..self.problem.n()], self.observe);
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
    // Fixed arrays for the suite's sizes: the damped pendulum and the paper's example (5), the
    // stiff ten-link chain (50), ten particles on a sphere (70), the Fekete problem's twenty
    // (140).
    match problem.n() + problem.m() {
        5 => solve_on::<P, [f64; 5]>(problem, x0, t_end, tol, observe),
        50 => solve_on::<P, [f64; 50]>(problem, x0, t_end, tol, observe),
        70 => solve_on::<P, [f64; 70]>(problem, x0, t_end, tol, observe),
        140 => solve_on::<P, [f64; 140]>(problem, x0, t_end, tol, observe),
        d => {
            LEN.with(|len| len.set(d));
            solve_on::<P, AnyLen>(problem, x0, t_end, tol, observe)
        }
    }
}

fn solve_on<P: PeerProblem + ?Sized, Y: Slice>(
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
    let size = n + m;
    let mut y0 = Y::of(&vec![0.0; size]);
    y0.slice_mut()[..n].copy_from_slice(x0);
    problem.mu(0.0, x0, &mut y0.slice_mut()[n..]);
    let dae = Index3(problem);
    let sol = IVP::dae(&dae, 0.0, t_end, y0)
        .solout(track)
        .method(
            ImplicitRungeKutta::radau5()
                .rtol(vec![tol; size])
                .atol(vec![tol; size])
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
