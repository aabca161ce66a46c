//! [`ProjectedMidpoint`]'s small path: the midpoint increment `δ` and `λ_k` as one Newton
//! system on `n + m` unknowns, with its closed-form dense matrix.

use super::{
    MidpointWork, NOISE_FACTOR, ProjectedMidpoint, STAGE_JOINT, increment_tolerance, stiff_floor,
};
use crate::error::{LinearSolveError, NewtonError, StepError};
use crate::flow::projection::small::{fixed, fixed_mut, half_step};
use crate::linalg::LinearSolver;
use crate::nonlinear::{SolveReport, solve_dense};
use crate::real::Real;
use crate::system::Model;
use crate::system::{Hamiltonian, HolonomicConstraint, StructureMatrix};
use crate::vector::{Vector, ops};
use num_traits::Float as _;
use num_traits::{One, Zero};

impl<V, Sys, K, L> ProjectedMidpoint<V, Sys, K, L>
where
    V: Vector,
    Sys: Model<V>,
    K: Hamiltonian<V>,
    L: LinearSolver<V::Real>,
{
    /// `f = M(x̄) ∇K(x̄)` at `x̄ = x̂ + δ/2` (left in `w.xbar`, `w.grad`, `w.f`).
    #[inline(always)]
    fn field(system: &Sys, inner: &K, w: &mut MidpointWork<V>) {
        ops::add_scaled(
            w.xbar.as_mut_slice(),
            w.xhat.as_slice(),
            V::Real::lit(0.5),
            w.delta.as_slice(),
        );
        inner.gradient(&w.xbar, &mut w.grad);
        system.structure().apply(&w.xbar, &w.grad, &mut w.f);
    }

    /// Builds and factors `A = I − (h/2) D(M∇K)(x̄)` at the current `x̄` (where `w.grad` and
    /// `w.f` were just evaluated), then `c_j` and `S = G(y) [c_j]`.
    #[inline(always)]
    fn build_matrix<const M: usize>(
        &mut self,
        h: V::Real,
        s: &mut [[V::Real; M]; M],
    ) -> Result<(), LinearSolveError> {
        let (system, inner, lu) = (&self.system, &self.inner, &mut self.lu);
        let w = &mut self.w;
        let n = w.delta.len();
        let half = h * V::Real::lit(0.5);
        lu.clear();
        for j in 0..n {
            // t1 = e_j; t2 = D(M∇K)(x̄) e_j, from the model or by a forward difference.
            ops::fill_zero(w.t1.as_mut_slice());
            w.t1.as_mut_slice()[j] = V::Real::one();
            let exact = inner.hessian_apply(&w.xbar, &w.t1, &mut w.hv) && {
                system.structure().apply(&w.xbar, &w.hv, &mut w.t2);
                system.structure().derivative_apply_add(
                    &w.xbar,
                    &w.t1,
                    &w.grad,
                    V::Real::one(),
                    &mut w.t2,
                )
            };
            if !exact {
                let xj = w.xbar.as_slice()[j];
                let eta = V::Real::epsilon().sqrt() * (V::Real::one() + xj.abs());
                w.t1.copy_from(&w.xbar);
                w.t1.as_mut_slice()[j] = xj + eta;
                let eta = w.t1.as_slice()[j] - xj;
                inner.gradient(&w.t1, &mut w.hv);
                system.structure().apply(&w.t1, &w.hv, &mut w.t2);
                for (t, &f) in w.t2.as_mut_slice().iter_mut().zip(w.f.as_slice()) {
                    *t = (*t - f) / eta;
                }
            }
            // Column j of A = e_j − (h/2) D(M∇K) e_j, written into t2.
            for (i, t) in w.t2.as_mut_slice().iter_mut().enumerate() {
                let e = if i == j {
                    V::Real::one()
                } else {
                    V::Real::zero()
                };
                *t = e - half * *t;
            }
            match lu.column_mut(j) {
                Some(col) => col.copy_from_slice(w.t2.as_slice()),
                None => {
                    for (i, &v) in w.t2.as_slice().iter().enumerate() {
                        lu.add(i, j, v);
                    }
                }
            }
        }
        lu.factor()?;
        let mut col = [V::Real::zero(); M];
        for j in 0..M {
            let (c, d) = (&mut w.c[j], &w.d[j]);
            c.copy_from(d);
            lu.solve_in_place(c.as_mut_slice())?;
            for (ci, &di) in c.as_mut_slice().iter_mut().zip(d.as_slice()) {
                *ci = h * *ci - half * di;
            }
            system.constraint().jacobian_apply(&w.y, c, &mut col);
            for (row, &v) in s.iter_mut().zip(&col) {
                row[j] = v;
            }
        }
        Ok(())
    }

    /// The joint Newton solve for `(δ, λ_k)` from `x`; `λ_k` in `z[..M]` (warm start in, the
    /// solution out), `y = x̂ + δ` and `g(y)` (returned) at the solution.
    #[inline(always)]
    pub(super) fn solve_joint<const M: usize>(
        &mut self,
        h: V::Real,
        x: &V,
    ) -> Result<[V::Real; M], StepError> {
        let half = h * V::Real::lit(0.5);
        let opts = self.newton;
        let one = V::Real::one();
        let noise = V::Real::lit(NOISE_FACTOR);
        let fail = |source: NewtonError| StepError::Newton {
            stage: STAGE_JOINT,
            source,
        };
        let mut lam: [V::Real; M] = *fixed_mut(self.z.as_mut_slice());
        let mut report = SolveReport::default();
        // Explicit Euler predictor for δ at x̂ of the predicted λ_k.
        {
            let w = &mut self.w;
            half_step(&mut w.xhat, x, half, &lam, fixed::<V, M>(&w.d));
            self.inner.gradient(&w.xhat, &mut w.grad);
            self.system.structure().apply(&w.xhat, &w.grad, &mut w.f);
            for (d, &f) in w.delta.as_mut_slice().iter_mut().zip(w.f.as_slice()) {
                *d = h * f;
            }
        }
        // The tolerance of F₁ at the predictor's scale: ε (2‖x‖∞ + 8‖δ‖∞); raised below to
        // the rounding floor of h M∇K itself when the iteration stays above it.
        let tol1 = increment_tolerance(x.as_slice(), self.w.delta.as_slice());
        let (mut inv_tol1, inv_ftol) = (
            one / tol1.max(V::Real::min_positive_value()),
            one / opts.ftol.max(V::Real::min_positive_value()),
        );
        let mut floor_known = false;
        let mut s = [[V::Real::zero(); M]; M];
        let mut have_matrix = false;
        let mut prev = V::Real::infinity();
        let mut last_update = V::Real::infinity();
        // The last update used a matrix built at its own iterate; the larger raw residual norm.
        let (mut fresh, mut last_residual) = (false, V::Real::infinity());
        let mut g = [V::Real::zero(); M];
        for it in 0..=opts.max_iterations {
            // Residuals at (δ, λ): F₁ = δ − h M∇K(x̄), F₂ = g(x̂ + δ).
            Self::field(&self.system, &self.inner, &mut self.w);
            let w = &mut self.w;
            for ((r, &d), &f) in
                w.r1.as_mut_slice()
                    .iter_mut()
                    .zip(w.delta.as_slice())
                    .zip(w.f.as_slice())
            {
                *r = d - h * f;
            }
            // With inputs, F₁ = δ − h M∇K(x̄) − h B(x̄) u(t_n + h/2).
            if let Some(forcing) = self.forcing.as_mut() {
                let force = forcing.force_at(0, &w.xbar);
                for (r, &b) in w.r1.as_mut_slice().iter_mut().zip(force.as_slice()) {
                    *r = *r - b;
                }
            }
            ops::add_scaled(
                w.y.as_mut_slice(),
                w.xhat.as_slice(),
                one,
                w.delta.as_slice(),
            );
            self.system.constraint().residual(&w.y, &mut g);
            report.residual_evaluations += 1;
            let (n1, n2) = (ops::norm_inf(w.r1.as_slice()), ops::norm_inf(&g));
            if !(n1.is_finite() && n2.is_finite()) {
                return Err(fail(NewtonError::NonFinite { iteration: it }));
            }
            let mut scaled = (n1 * inv_tol1).max(n2 * inv_ftol);
            if scaled > one && it >= 2 && !floor_known {
                // Two updates and still above the tolerances: not below the rounding floor of
                // h M∇K, where a stiff term's gradient rounds at its Hessian times the state's
                // rounding, 4ε |h| ‖M ∇²K(x) x‖∞ (as in IncrementFlow; computed only here, off
                // the common path).
                floor_known = true;
                let floor = stiff_floor(&self.system, &self.inner, h, x, &mut w.hv, &mut w.t2);
                if let Some(floor) = floor.filter(|&f| f > tol1) {
                    inv_tol1 = one / floor;
                    scaled = (n1 * inv_tol1).max(n2 * inv_ftol);
                }
            }
            last_residual = n1.max(n2);
            // Converged; or at the round-off floor: near the tolerances, and an update with a
            // freshly built matrix no longer halved the residual (with a kept matrix slow
            // contraction says nothing about round-off: the matrix is rebuilt below).
            if scaled <= one || (fresh && scaled <= noise && scaled >= V::Real::lit(0.5) * prev) {
                return Ok(self.accept(report, n2, lam, g));
            }
            if it == opts.max_iterations {
                break;
            }
            // A kept matrix that contracts less than fourfold is rebuilt here.
            fresh = !have_matrix || scaled > V::Real::lit(0.25) * prev;
            if fresh {
                self.build_matrix::<M>(h, &mut s)
                    .map_err(|e| fail(NewtonError::Linear(e)))?;
                report.factorizations += 1;
                have_matrix = true;
            }
            prev = scaled;
            let w = &mut self.w;
            // u = A⁻¹F₁; S Δλ = G(y) u − F₂; Δδ = −u + Σ Δλ_j (c_j − (h/2) d_j).
            self.lu
                .solve_in_place(w.r1.as_mut_slice())
                .map_err(|e| fail(NewtonError::Linear(e)))?;
            let mut dl = [V::Real::zero(); M];
            self.system
                .constraint()
                .jacobian_apply(&w.y, &w.r1, &mut dl);
            for (v, &gi) in dl.iter_mut().zip(&g) {
                *v = *v - gi;
            }
            let mut a = s;
            solve_dense(&mut a, &mut dl).map_err(|e| fail(NewtonError::Linear(e)))?;
            let mut update = V::Real::zero();
            for (i, (d, &u)) in w
                .delta
                .as_mut_slice()
                .iter_mut()
                .zip(w.r1.as_slice())
                .enumerate()
            {
                let mut change = -u;
                for ((c, d), &l) in w.c.iter().zip(&w.d).zip(&dl) {
                    change = change + l * (c.as_slice()[i] - half * d.as_slice()[i]);
                }
                *d = *d + change;
                update = update.max(change.abs());
            }
            for (l, &v) in lam.iter_mut().zip(&dl) {
                *l = *l + v;
            }
            half_step(&mut w.xhat, x, half, &lam, fixed::<V, M>(&w.d));
            report.iterations += 1;
            // Once the iteration contracts (rate ρ from the last two updates: from the second
            // update on), the error left in δ is about ρ/(1 − ρ) times this update: below the
            // tolerance of F₁, only g needs measuring (Hairer & Wanner, Solving ODEs II,
            // §IV.8). ρ u ≤ (1 − ρ)/2 with ρ = u/u_last, without a division.
            let update = update * inv_tol1;
            if last_update.is_finite()
                && update < last_update
                && update * update <= V::Real::lit(0.5) * (last_update - update)
            {
                ops::add_scaled(
                    w.y.as_mut_slice(),
                    w.xhat.as_slice(),
                    one,
                    w.delta.as_slice(),
                );
                self.system.constraint().residual(&w.y, &mut g);
                let n2 = ops::norm_inf(&g);
                if n2 <= opts.ftol {
                    return Ok(self.accept(report, n2, lam, g));
                }
            }
            last_update = update;
        }
        Err(fail(NewtonError::NotConverged {
            iterations: report.iterations,
            residual: last_residual.to_f64_lossy(),
        }))
    }
}
