//! Newton's method for independent unknowns: a diagonal Jacobian, formed fresh at every
//! iteration from one grouped product, and the root of each unknown's quadratic model.

use super::stopping::{NOISE_FACTOR, converged_after_update, effective_residual};
use super::{NewtonOptions, NonlinearProblem, NonlinearSolver, SolveReport};
use crate::error::{LinearSolveError, NewtonError};
use crate::real::Real;
use crate::vector::ops;

/// Newton's method for a system whose unknowns are independent, `F_i(z) = F_i(z_i)`: a
/// diagonal Jacobian. The projection's multiplier systems are of this kind when no two
/// constraints read a common coordinate (particles each on its own sphere, bodies each on
/// its own surface).
///
/// Each iteration takes the whole diagonal from one product `J(z) 1`
/// ([`NonlinearProblem::jacobian_group`] with every column, no two sharing a row) — or, without
/// one, from one grouped forward difference — and divides; no matrix is stored or factored,
/// so rebuilding it at every iterate costs less than one residual evaluation of a projection,
/// and the iteration converges quadratically from the first step instead of keeping a stale
/// matrix. When the problem also gives the second derivatives along `1`
/// ([`NonlinearProblem::curvature_group`], `∂²F_i/∂z_i²` for independent unknowns), each
/// unknown steps to the root of its quadratic model `F_i + J_ii δ + ½ c_i δ² = 0` nearest the
/// Newton step, `δ = −2F_i / (J_ii + sgn(J_ii) √(J_ii² − 2 c_i F_i))` (the form without
/// cancellation): the exact root when `F_i` is quadratic, one iteration where Newton takes two.
///
/// The convergence tests are [`Newton`](super::Newton)'s with a fresh Jacobian (the residual
/// below `ftol`; the update test; within its noise floor and stalled or at the round-off of
/// `z`), and a step that does not decrease the residual is halved. Allocates its workspace at construction.
#[derive(Debug, Clone)]
pub struct DiagonalNewton<T> {
    options: NewtonOptions<T>,
    /// `0..k`, the one column group.
    all: Vec<usize>,
    f: Vec<T>,
    jac: Vec<T>,
    curv: Vec<T>,
    dz: Vec<T>,
    zp: Vec<T>,
    /// A diagonal had to be differenced (the problem has no closed-form product).
    differenced: bool,
}

impl<T: Real> DiagonalNewton<T> {
    /// The solver for `k` independent unknowns.
    pub fn new(k: usize, options: NewtonOptions<T>) -> Self {
        Self {
            options,
            all: (0..k).collect(),
            f: vec![T::zero(); k],
            jac: vec![T::zero(); k],
            curv: vec![T::zero(); k],
            dz: vec![T::zero(); k],
            zp: vec![T::zero(); k],
            differenced: false,
        }
    }

    /// `true` once a solve had to difference the diagonal: the problem has no closed-form
    /// product `J(z) 1`, and every iteration then costs two residual evaluations — a solver
    /// that keeps its Jacobian across solves ([`Newton`](super::Newton)) is the better choice.
    pub fn needs_differences(&self) -> bool {
        self.differenced
    }

    /// The number of unknowns.
    pub fn dim(&self) -> usize {
        self.all.len()
    }

    /// The diagonal at `z` (where `self.f = F(z)`) into `self.jac`: the problem's product
    /// `J(z) 1`, or one grouped forward difference. `true` when it came in closed form.
    fn jacobian<P: NonlinearProblem<T>>(
        &mut self,
        problem: &mut P,
        z: &[T],
        report: &mut SolveReport<T>,
    ) -> Result<bool, NewtonError<P::Error>> {
        if problem.jacobian_group(z, &self.all, &mut self.jac) {
            return Ok(true);
        }
        // Forward differences, every unknown at once (δ_j as in `Newton`).
        self.differenced = true;
        let inv = T::one() / problem.jacobian_scale().abs();
        let floor = if inv.is_finite() { inv } else { T::one() };
        let zmax = ops::norm_inf(z).max(floor);
        for (p, &zj) in self.zp.iter_mut().zip(z) {
            *p = zj + self.options.fd_step * zj.abs().max(zmax);
        }
        problem
            .residual(&self.zp, &mut self.jac)
            .map_err(NewtonError::Residual)?;
        report.residual_evaluations += 1;
        for ((j, (&p, &zj)), &fj) in self.jac.iter_mut().zip(self.zp.iter().zip(z)).zip(&self.f) {
            *j = (*j - fj) / (p - zj);
        }
        Ok(false)
    }

    /// The step `−F_i / J_ii`, or each quadratic model's root nearest it (see the type docs)
    /// when the curvatures are in `self.curv`.
    fn step(&mut self, quadratic: bool) -> Result<(), LinearSolveError> {
        let half = T::lit(0.5);
        let two = T::lit(2.0);
        for (i, ((d, &f), (&j, &c))) in self
            .dz
            .iter_mut()
            .zip(&self.f)
            .zip(self.jac.iter().zip(&self.curv))
            .enumerate()
        {
            if !j.is_finite() {
                return Err(LinearSolveError::NonFinite { row: i, col: i });
            }
            if j == T::zero() {
                return Err(LinearSolveError::Singular {
                    pivot: i,
                    magnitude: 0.0,
                    ratio: 0.0,
                });
            }
            *d = -f / j;
            if quadratic {
                let disc = j * j - two * c * f;
                // Leaves `½ c δ²` after the Newton step: below half the tolerance the next
                // evaluation converges anyway; a negative discriminant has no real root near.
                if (half * c * *d * *d).abs() > half * self.options.ftol && disc >= T::zero() {
                    *d = -two * f / (j + disc.sqrt().copysign(j));
                }
            }
        }
        Ok(())
    }

    /// Solves a system whose residual is affine in `z` with a constant diagonal Jacobian,
    /// `F(z) = F(0) + diag(J) z`: from `z = 0`, one evaluation and one product, `z = −F(0)/J`.
    /// The residual is not evaluated at the solution (it is `F(0) + J z`, zero to rounding):
    /// the caller forms what it needs there. `report.residual` is `‖F(0)‖∞` when that already
    /// meets the tolerance (`z = 0`), else zero.
    pub fn solve_affine<P: NonlinearProblem<T>>(
        &mut self,
        problem: &mut P,
        z: &mut [T],
    ) -> Result<SolveReport<T>, NewtonError<P::Error>> {
        let k = self.all.len();
        let z = &mut z[..k];
        z.iter_mut().for_each(|v| *v = T::zero());
        let mut report = SolveReport::default();
        problem
            .residual(z, &mut self.f)
            .map_err(NewtonError::Residual)?;
        report.residual_evaluations += 1;
        let raw = ops::norm_inf(&self.f);
        if !raw.is_finite() {
            return Err(NewtonError::NonFinite { iteration: 0 });
        }
        report.residual = raw;
        if effective_residual(problem, &self.f) <= self.options.ftol {
            return Ok(report);
        }
        self.jacobian(problem, z, &mut report)?;
        report.factorizations += 1;
        self.step(false)?;
        z.copy_from_slice(&self.dz);
        report.iterations = 1;
        report.residual = T::zero();
        Ok(report)
    }
}

impl<T: Real> NonlinearSolver<T> for DiagonalNewton<T> {
    fn solve<P: NonlinearProblem<T>>(
        &mut self,
        problem: &mut P,
        z: &mut [T],
    ) -> Result<SolveReport<T>, NewtonError<P::Error>> {
        let k = self.all.len();
        debug_assert_eq!(problem.dim(), k, "problem and solver dimensions differ");
        let z = &mut z[..k];
        let mut report = SolveReport::default();
        let eval = |p: &mut P, z: &[T], f: &mut [T], rep: &mut SolveReport<T>| {
            p.residual(z, f).map_err(NewtonError::Residual)?;
            rep.residual_evaluations += 1;
            Ok::<_, NewtonError<P::Error>>((ops::norm_inf(f), effective_residual(p, f)))
        };
        let (mut raw, mut r) = eval(problem, z, &mut self.f, &mut report)?;
        if !raw.is_finite() {
            return Err(NewtonError::NonFinite { iteration: 0 });
        }
        let opts = self.options;
        let one = T::one();
        let half = T::lit(0.5);
        let noise = T::lit(NOISE_FACTOR) * opts.ftol;
        for it in 0..opts.max_iterations {
            report.residual = raw;
            if r <= opts.ftol {
                return Ok(report);
            }
            let closed_form = self.jacobian(problem, z, &mut report)?;
            report.factorizations += 1;
            let quadratic = closed_form && problem.curvature_group(z, &self.all, &mut self.curv);
            self.step(quadratic)?;
            if quadratic {
                report.quadratic_steps += 1;
            }
            ops::axpy(z, one, &self.dz);
            report.iterations += 1;
            let mut r_new;
            (raw, r_new) = eval(problem, z, &mut self.f, &mut report)?;
            // The direction descends ‖F‖ (a fresh Jacobian): halve until it decreases.
            let mut halvings = 0;
            if r > noise {
                while (r_new.is_nan() || r_new >= r) && halvings < opts.max_halvings {
                    self.dz.iter_mut().for_each(|d| *d = *d * half);
                    ops::axpy(z, -one, &self.dz);
                    halvings += 1;
                    report.halvings += 1;
                    (raw, r_new) = eval(problem, z, &mut self.f, &mut report)?;
                }
            }
            if !raw.is_finite() {
                return Err(NewtonError::NonFinite { iteration: it + 1 });
            }
            report.residual = raw;
            if r_new <= opts.ftol {
                return Ok(report);
            }
            // Newton's tests with a fresh Jacobian.
            if converged_after_update(&opts, r, r_new, halvings, true, &self.dz, z) {
                return Ok(report);
            }
            r = r_new;
        }
        Err(NewtonError::NotConverged {
            iterations: report.iterations,
            residual: raw.to_f64_lossy(),
        })
    }
}
