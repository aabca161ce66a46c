//! Newton on an affine system ([`Newton::solve_affine`]) and the update with the kept
//! Jacobian that it and the iteration share.

use super::Newton;
use crate::error::NewtonError;
use crate::linalg::LinearSolver;
use crate::nonlinear::{NonlinearProblem, SolveReport, effective_residual};
use crate::vector::{Vector, ops};
use num_traits::{Float as _, One, Zero};

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
        if self.have_jacobian && self.summed && self.one_update && ratio.is_finite() {
            self.newton_step(z, ratio)?;
            let f = &mut self.f.as_mut_slice()[..k];
            problem.residual(z, f).map_err(NewtonError::Residual)?;
            report.residual_evaluations += 1;
            report.iterations = 1;
            report.residual = ops::norm_inf(f);
            if report.residual.is_finite() && effective_residual(problem, f) <= self.options.ftol {
                return Ok(report);
            }
            self.one_update = false;
        }
        self.have_jacobian = false;
        self.jacobian(problem, z, scale, &mut report)?;
        self.have_jacobian = true;
        self.jacobian_scale = scale;
        self.newton_step(z, V::Real::one())?;
        report.iterations += 1;
        report.residual = V::Real::zero();
        // Exact in one update: the next solve may start from this Jacobian.
        self.one_update = report.iterations == 1;
        Ok(report)
    }

    /// `z ← z − ratio · J⁻¹ F(z)` with the kept, factored Jacobian (`self.f = F(z)`); the
    /// update is left in `dz`.
    fn newton_step<E>(&mut self, z: &mut [V::Real], ratio: V::Real) -> Result<(), NewtonError<E>> {
        let k = self.k;
        let dz = &mut self.dz.as_mut_slice()[..k];
        for (d, &fi) in dz.iter_mut().zip(&self.f.as_slice()[..k]) {
            *d = -fi;
        }
        if k == 1 {
            dz[0] = dz[0] / self.j11;
        } else {
            for (d, &s) in dz.iter_mut().zip(&self.row_scale) {
                *d = *d * s;
            }
            self.lin.solve_in_place(dz)?;
        }
        ops::axpy(z, ratio, dz);
        Ok(())
    }
}
