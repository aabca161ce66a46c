//! Newton's options, its Jacobian policy and the report of a solve.

use crate::linalg::SolverChoice;
use crate::real::Real;

/// When Newton rebuilds its (finite-difference) Jacobian.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[non_exhaustive]
pub enum JacobianUpdate {
    /// Every iteration: full Newton, quadratic convergence, `k + 1` residual evaluations per
    /// iteration.
    EveryIteration,
    /// Once per solve, at the starting guess: simplified Newton.
    OncePerSolve,
    /// Kept across solves and rebuilt only when an iteration contracts the residual by less
    /// than [`NewtonOptions::max_contraction`] (or diverges): simplified Newton with the
    /// Jacobian of an earlier step, the standard choice for implicit integrators (Hairer &
    /// Wanner, *Solving ODEs II*, §IV.8). In a time-stepping loop the Jacobian changes by
    /// `O(h)` per step, so most solves need no Jacobian at all. A Jacobian the problem provides
    /// in closed form ([`NonlinearProblem::jacobian_column`](super::NonlinearProblem::jacobian_column)) costs no residual evaluations and
    /// is rebuilt at every iteration instead (full Newton: quadratic convergence for the price
    /// of a few products and a small factorization).
    #[default]
    Reuse,
}

/// Options of [`Newton`](super::Newton).
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub struct NewtonOptions<T> {
    /// Converged when `‖F(z)‖∞ ≤ ftol`. Default `2 ε` (4.4e-16 for `f64`).
    pub ftol: T,
    /// Also converged when `‖F‖∞ ≤ 100 ftol` (the round-off floor of a residual can lie above
    /// `ftol`) and, right after a freshly built Jacobian, either the update is at round-off,
    /// `‖Δz‖∞ ≤ xtol (1 + ‖z‖∞)`, or the residual stopped decreasing (by at least half); and
    /// when `‖F‖∞ ≤ 10⁴ ftol` with both at once (a residual whose terms cancel rounds far above
    /// `ε` times its own size; no representable `z` does better). Default `16 ε`.
    pub xtol: T,
    /// Iteration limit. Default 25.
    pub max_iterations: usize,
    /// Relative forward-difference step for the Jacobian,
    /// `δ_j = fd_step · max(|z_j|, ‖z‖∞, 1/|s|)` with `s` the problem's
    /// [`jacobian_scale`](super::NonlinearProblem::jacobian_scale). Default `√ε`.
    pub fd_step: T,
    /// When to rebuild the Jacobian.
    pub jacobian: JacobianUpdate,
    /// With [`JacobianUpdate::Reuse`]: rebuild when `‖F(z_{i+1})‖ > max_contraction ‖F(z_i)‖`.
    /// Default `0.1`.
    pub max_contraction: T,
    /// Between rebuilds, improve the kept Jacobian with Broyden's secant update after every
    /// iteration (superlinear instead of linear convergence, no extra residual evaluations).
    /// Default `true`; ignored with [`JacobianUpdate::EveryIteration`] and with sparse storage
    /// (a rank-one update fills the matrix) — except for a diagonal pattern (independent
    /// unknowns), whose update is restricted to the diagonal: a secant slope per unknown.
    pub broyden: bool,
    /// Also converged when the last update satisfies `|Δz_i| ≤ atol + rtol |z_i|` for every `i`
    /// (Newton's error after an update is about the square of the update, so this is a
    /// per-component accuracy of `z`). Default `0` (off unless `atol` or `rtol` is positive).
    pub atol: T,
    /// See [`atol`](Self::atol). Default `0`.
    pub rtol: T,
    /// Damping: when an update with a fresh Jacobian increases `‖F‖∞` (and `‖F‖∞` is above its
    /// round-off floor), the update is halved up to this many times until the residual
    /// decreases (a backtracking line search; Deuflhard 2004, §3.1). `0` takes full steps.
    /// Default 8.
    pub max_halvings: usize,
    /// Grouped differences ([`Newton::with_pattern`](super::Newton::with_pattern)) by central instead of forward
    /// differences: twice the residual evaluations, but the error is `O(δ²)` instead of
    /// `O(δ)`, and exactly zero for residuals quadratic in `z` (such as the constraint
    /// residuals of RATTLE, which are quadratic in the multipliers), so `fd_step` can be large
    /// and the rounding error small. Needed when the Newton matrix is ill-conditioned (a chain
    /// of `N` links has condition number `~N²`). Default `false`.
    pub central_differences: bool,
    /// The backend of the linear solver when it has several ([`crate::linalg::AutoLu`]).
    /// Default [`SolverChoice::Auto`].
    pub solver: SolverChoice,
    /// Scale every row of a dense Newton matrix by the power of two nearest the inverse of its
    /// largest entry before factoring (and the right-hand sides with it): the solution is the
    /// same, but rows of very different size — a stage system whose stiffly damped rows carry
    /// `c h/m` — no longer make the smaller pivots look singular against the largest
    /// (Golub & Van Loan, *Matrix Computations*, §3.5.2). Powers of two scale exactly. Default
    /// `false`.
    pub equilibrate: bool,
}

impl<T: Real> Default for NewtonOptions<T> {
    fn default() -> Self {
        Self {
            ftol: T::lit(2.0) * T::epsilon(),
            xtol: T::lit(16.0) * T::epsilon(),
            max_iterations: 25,
            fd_step: T::epsilon().sqrt(),
            jacobian: JacobianUpdate::default(),
            max_contraction: T::lit(0.1),
            broyden: true,
            atol: T::zero(),
            rtol: T::zero(),
            max_halvings: 8,
            central_differences: false,
            solver: SolverChoice::Auto,
            equilibrate: false,
        }
    }
}

impl<T: Real> NewtonOptions<T> {
    /// Sets the residual tolerance.
    pub fn with_ftol(mut self, ftol: T) -> Self {
        self.ftol = ftol;
        self
    }
    /// Sets the update tolerance.
    pub fn with_xtol(mut self, xtol: T) -> Self {
        self.xtol = xtol;
        self
    }
    /// Sets the iteration limit.
    pub fn with_max_iterations(mut self, n: usize) -> Self {
        self.max_iterations = n;
        self
    }
    /// Sets the relative finite-difference step of the Jacobian.
    pub fn with_fd_step(mut self, fd_step: T) -> Self {
        self.fd_step = fd_step;
        self
    }
    /// Sets the Jacobian update policy.
    pub fn with_jacobian(mut self, j: JacobianUpdate) -> Self {
        self.jacobian = j;
        self
    }
    /// Sets the scaled update tolerance `|Δz_i| ≤ atol + rtol |z_i|`.
    pub fn with_update_tol(mut self, atol: T, rtol: T) -> Self {
        self.atol = atol;
        self.rtol = rtol;
        self
    }
    /// Sets the number of step halvings of the line search (`0`: full steps).
    pub fn with_max_halvings(mut self, n: usize) -> Self {
        self.max_halvings = n;
        self
    }
    /// Uses central differences for grouped (sparse) Jacobians, with relative step `fd_step`.
    pub fn with_central_differences(mut self, fd_step: T) -> Self {
        self.central_differences = true;
        self.fd_step = fd_step;
        self
    }
    /// Sets the linear solver backend.
    pub fn with_solver(mut self, solver: SolverChoice) -> Self {
        self.solver = solver;
        self
    }
}

/// What one Newton solve did.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SolveReport<T> {
    /// Newton updates applied.
    pub iterations: usize,
    /// Residual evaluations (including those for the finite-difference Jacobian).
    pub residual_evaluations: usize,
    /// Jacobian factorizations.
    pub factorizations: usize,
    /// Step halvings of the line search.
    pub halvings: usize,
    /// Iterations that took the root of the exact quadratic model instead of the Newton step
    /// (see [`NonlinearProblem::second_derivative`](super::NonlinearProblem::second_derivative)).
    pub quadratic_steps: usize,
    /// `‖F(z)‖∞` at the returned `z` (its prediction from the measured contraction when a
    /// solve stopped without evaluating it).
    pub residual: T,
}
