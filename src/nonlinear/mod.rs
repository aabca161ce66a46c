//! Nonlinear systems `F(z) = 0` for the Lagrange multipliers, and Newton's method.
//!
//! The multiplier systems of the projection half-steps are small (`m` or `2m` unknowns) but
//! their residual runs the inner flow, so Newton's cost is counted in residual evaluations.

mod diagonal;
mod newton;
mod options;
mod small;
mod stopping;

pub use diagonal::DiagonalNewton;
pub use newton::Newton;
pub use options::{JacobianUpdate, NewtonOptions, SolveReport};
pub(crate) use small::solve_dense;
pub use small::{SMALL_MAX, SmallNewton};
pub(crate) use stopping::{NOISE_FACTOR, effective_residual};

use crate::error::NewtonError;
use crate::linalg::Sink;
use crate::real::Real;

/// A square nonlinear system `F(z) = 0` with `dim()` unknowns.
pub trait NonlinearProblem<T: Real> {
    /// What a failed residual evaluation reports (a flow's
    /// [`StepError`](crate::error::StepError) for the multiplier systems of a step). Newton
    /// passes it through as [`NewtonError::Residual`].
    type Error;
    /// The number of unknowns (and equations).
    fn dim(&self) -> usize;
    /// `f = F(z)`.
    fn residual(&mut self, z: &[T], f: &mut [T]) -> Result<(), Self::Error>;
    /// How the Jacobian scales from one solve to the next: a solver that keeps a Jacobian
    /// built at scale `s₀` reuses it at scale `s` as `(s/s₀) J`. Multiplier systems of a
    /// projected step scale like `h` or `h²`, so a kept Jacobian stays valid across the
    /// different (even negative) sub-steps of a composition. Default `1`.
    fn jacobian_scale(&self) -> T {
        T::one()
    }
    /// An estimate of the rounding noise in the last residual evaluated (max-norm). Newton
    /// accepts rows within `4 · noise_floor` ([`noisy_rows`](Self::noisy_rows)), the others at
    /// `ftol`: a residual computed with cancellation
    /// cannot be driven below its own noise. Default `0`.
    fn noise_floor(&self) -> T {
        T::zero()
    }
    /// The number of leading residual rows the [`noise_floor`](Self::noise_floor) applies to;
    /// the rows after them must meet the tolerance on their own (for instance the constraint
    /// rows of a discrete-gradient step, which carry no cancellation). Default: all rows.
    fn noisy_rows(&self) -> usize {
        self.dim()
    }
    /// Writes column `j` of the Jacobian `∂F/∂z` at `z` into `out` and returns `true`, when the
    /// problem has it in closed form (from model-provided derivatives). The default returns
    /// `false`, and the solver falls back to forward differences (`dim()` residual evaluations,
    /// about `√ε` relative accuracy). A problem must answer all columns alike.
    fn jacobian_column(&mut self, z: &[T], j: usize, out: &mut [T]) -> bool {
        let _ = (z, j, out);
        false
    }
    /// Writes `∂²F/∂z_j∂z_k` into `out` and returns `true` when `F` is quadratic in `z` (its
    /// second derivatives are constant) and the problem has them in closed form; the default
    /// returns `false`. Called after the columns of the same Jacobian
    /// ([`jacobian_column`](Self::jacobian_column)). The small solver then takes the root of the
    /// exact quadratic model `F + J δ + ½ δᵀ∇²F δ` nearest the Newton step instead of the Newton
    /// step: one iteration where Newton takes two.
    fn second_derivative(&mut self, z: &[T], j: usize, k: usize, out: &mut [T]) -> bool {
        let _ = (z, j, k, out);
        false
    }
    /// After Newton moved from the point of the last evaluation by `dz` to `z`, writes `F(z)`
    /// into `f` and returns `Ok(true)` when the problem forms it without a full evaluation —
    /// its state is affine in `z` along columns it holds exactly (a projection around an
    /// affine inner flow moves `y` by `Σ dz_j DL d_j` and evaluates the constraint there,
    /// not the flow). The problem is then at `z` as after [`residual`](Self::residual).
    /// Default `Ok(false)`: Newton evaluates.
    fn residual_after_shift(
        &mut self,
        z: &[T],
        dz: &[T],
        f: &mut [T],
    ) -> Result<bool, Self::Error> {
        let _ = (z, dz, f);
        Ok(false)
    }
    /// Writes `J(z) Σ_{j ∈ cols} e_j` — the sum of the Jacobian's columns `cols` — into `out`
    /// and returns `true`, when the problem forms Jacobian–vector products in closed form.
    /// Newton with a sparsity pattern calls it once per group of structurally orthogonal
    /// columns (no two share a row), so each entry is read off exactly; without it the groups
    /// are differenced. `z` is the current iterate (the residual was last evaluated there
    /// unless a previous group was differenced). Default `false`.
    fn jacobian_group(&mut self, z: &[T], cols: &[usize], out: &mut [T]) -> bool {
        let _ = (z, cols, out);
        false
    }
    /// Adds every entry of the Jacobian `∂F/∂z` at `z` into `sink` and returns `true`, when the
    /// problem sums them in closed form; the default returns `false`, and so must a problem
    /// that cannot — before it adds anything. Newton with a sparsity pattern asks for it before
    /// the column groups ([`jacobian_group`](Self::jacobian_group)); the entries must lie in the
    /// pattern. `z` is the current iterate.
    fn jacobian_assemble(&mut self, z: &[T], sink: &mut dyn Sink<T>) -> bool {
        let _ = (z, sink);
        false
    }
    /// Writes `D²F(z)[e, e]`, `e = Σ_{j ∈ cols} e_j` — the second derivative of `F` along the
    /// group's indicator — into `out` and returns `true` when the problem has it in closed
    /// form; default `false`. Called right after [`jacobian_group`](Self::jacobian_group) for
    /// the same `z` and `cols`. For independent unknowns (one group of every column) row `i` is
    /// `∂²F_i/∂z_i²`, from which [`DiagonalNewton`] takes the root of each unknown's quadratic
    /// model: exact when `F` is quadratic in `z`.
    fn curvature_group(&mut self, z: &[T], cols: &[usize], out: &mut [T]) -> bool {
        let _ = (z, cols, out);
        false
    }
}

/// A solver for [`NonlinearProblem`]s that owns its workspace.
pub trait NonlinearSolver<T: Real> {
    /// Solves `F(z) = 0` starting from `z` (overwritten with the solution).
    /// On error `z` holds the last iterate.
    fn solve<P: NonlinearProblem<T>>(
        &mut self,
        problem: &mut P,
        z: &mut [T],
    ) -> Result<SolveReport<T>, NewtonError<P::Error>>;
}
