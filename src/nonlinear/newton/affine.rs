//! Newton on an affine system ([`Newton::solve_affine`]): one evaluation, one Jacobian, one
//! update.

use super::Newton;
use crate::error::NewtonError;
use crate::linalg::LinearSolver;
use crate::nonlinear::{NonlinearProblem, SolveReport, effective_residual};
use crate::vector::{Vector, ops};
use num_traits::{Float as _, One, Zero};

/// The most solves [`Newton::solve_affine`] skips its kept Jacobian after failed attempts.
pub(super) const KEPT_BACKOFF_MAX: u8 = 31;

impl<V: Vector, L: LinearSolver<V::Real>> Newton<V, L> {
    /// Solves a system whose residual is affine in `z`, `F(z) = F(0) + J z`: from `z = 0`, one
    /// evaluation, one Jacobian (summed, grouped or differenced as [`solve`](NonlinearSolver::solve)
    /// forms it) and one solve. The residual is not evaluated at the solution (it is zero to
    /// rounding): the caller forms what it needs there. `report.residual` is `‖F(0)‖∞` when
    /// that already meets the tolerance (`z = 0`), else zero.
    pub fn solve_affine<P: NonlinearProblem<V::Real>>(
        &mut self,
        problem: &mut P,
        z: &mut [V::Real],
    ) -> Result<SolveReport<V::Real>, NewtonError<P::Error>> {
        let k = self.k;
        let z = &mut z[..k];
        ops::fill_zero(z);
        let mut report = SolveReport::default();
        let f = &mut self.f.as_mut_slice()[..k];
        problem.residual(z, f).map_err(NewtonError::Residual)?;
        report.residual_evaluations += 1;
        let raw = ops::norm_inf(f);
        if !raw.is_finite() {
            return Err(NewtonError::NonFinite { iteration: 0 });
        }
        report.residual = raw;
        if effective_residual(problem, f) <= self.options.ftol {
            return Ok(report);
        }
        let scale = problem.jacobian_scale();
        // A kept summed Jacobian that solved the last system in one update: one update with
        // it, kept when the residual there meets the tolerance (the system drifts slowly from
        // step to step); otherwise the fresh one below, from where this update left `z`.
        let ratio = self.jacobian_scale / scale;
        let kept = self.have_jacobian && self.summed && self.one_update && ratio.is_finite();
        if kept && self.kept_wait > 0 {
            self.kept_wait -= 1;
        } else if kept {
            self.newton_step(z, ratio)?;
            let f = &mut self.f.as_mut_slice()[..k];
            problem.residual(z, f).map_err(NewtonError::Residual)?;
            report.residual_evaluations += 1;
            report.iterations = 1;
            report.residual = ops::norm_inf(f);
            if !report.residual.is_finite() {
                // Back to z = 0, where F was finite, for the fresh Jacobian.
                ops::axpy(z, -V::Real::one(), &self.dz.as_slice()[..k]);
                let f = &mut self.f.as_mut_slice()[..k];
                problem.residual(z, f).map_err(NewtonError::Residual)?;
                report.residual_evaluations += 1;
            } else if effective_residual(problem, f) <= self.options.ftol {
                self.kept_backoff = 0;
                return Ok(report);
            }
            self.kept_backoff = (2 * self.kept_backoff + 1).min(KEPT_BACKOFF_MAX);
            self.kept_wait = self.kept_backoff;
        }
        self.have_jacobian = false;
        self.jacobian(problem, z, scale, &mut report)?;
        self.have_jacobian = true;
        self.jacobian_scale = scale;
        self.newton_step(z, V::Real::one())?;
        report.iterations += 1;
        report.residual = V::Real::zero();
        // A kept Jacobian that fell short here is not tried on the next solve (which builds
        // its own); one built here is.
        self.one_update = report.iterations == 1;
        Ok(report)
    }
}
