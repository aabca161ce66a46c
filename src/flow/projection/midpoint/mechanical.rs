//! [`ProjectedMidpoint`]'s joint solve for a model of mechanical form
//! ([`MechanicalForm`]): the momenta eliminated, Newton on `(δq, ν = (h²/2) λ_k)` with a sparse, kept
//! Newton matrix.

use super::{ProjectedMidpoint, STAGE_JOINT, increment_tolerance, stiff_floor};
use crate::error::StepError;
use crate::flow::forcing::Forcing;
use crate::flow::schur::{ReducedBlocks, position_rows};
use crate::linalg::LinearSolver;
use crate::nonlinear::NonlinearProblem;
use crate::real::Real;
use crate::system::{Hamiltonian, HolonomicConstraint, Model, StructureMatrix};
use crate::vector::{Vector, ops};
use num_traits::Float as _;
use num_traits::{One, Zero};

/// `F(δq, ν) = (δq − h W⁻¹ p̄,  g(q + δq))`, the midpoint rule's position rows and the
/// constraint, with the momenta eliminated: `p̄ = p̂ + δp/2`, `δp = −h ∇V(q̄) + B δq` (the
/// momentum rows, solved exactly), `p̂ = p − (h/2) G_q(q)ᵀ λ`, `q̄ = q + δq/2`:
///
/// ```text
/// F₁ = δq − (h/2) W⁻¹ B δq + (h²/2) W⁻¹ ∇V(q̄) − h W⁻¹ p̂
/// ```
///
/// With inputs, `δp` gains the impulse `φ = h F(q̄, p̂) u(t_n + h/2)` (`F` the momentum rows
/// of `B`) and `F₁` gains `−(h/2) W⁻¹ φ`.
struct Problem<'a, V: Vector, Sys, K> {
    h: V::Real,
    nq: usize,
    w: &'a [V::Real],
    x: &'a V,
    system: &'a Sys,
    inner: &'a K,
    /// The tolerance of the position rows over 4 (their noise floor).
    noise: V::Real,
    scaled: &'a mut [V::Real],
    /// `x̂ = (q, p̂)`.
    xhat: &'a mut V,
    /// `(q̄, p̂)`: `∇K` there has `∇V(q̄)` as its position part.
    xbar: &'a mut V,
    /// `y = (q + δq, p̂ + δp)`.
    y: &'a mut V,
    grad: &'a mut V,
    /// `(0, δq)`, then `M (0, δq) = (δq, B δq)`.
    u: &'a mut V,
    mu: &'a mut V,
    hv: &'a mut V,
    t1: &'a mut V,
    t2: &'a mut V,
    /// `g(y)` of the last evaluation.
    g: &'a mut [V::Real],
    /// The inputs, their values at `t_n + h/2` scaled by `h` (`None` for a closed system).
    forcing: Option<&'a mut Forcing<V>>,
}

impl<V, Sys, K> Problem<'_, V, Sys, K>
where
    V: Vector,
    Sys: Model<V>,
    K: Hamiltonian<V>,
{
    /// `x̂` of `λ` and the positions `q̄`, `q + δq` of `δq` (into `xbar`, `y`).
    fn place(&mut self, z: &[V::Real]) {
        let (dq, nu) = z.split_at(self.nq);
        // (h/2) λ = ν / h.
        for (s, &l) in self.scaled.iter_mut().zip(nu) {
            *s = l / self.h;
        }
        // (h/2) M Gᵀλ = (0, −(h/2) G_qᵀ λ).
        self.system
            .constraint_force(self.x, self.scaled, self.t1, self.t2);
        let one = V::Real::one();
        ops::add_scaled(
            self.xhat.as_mut_slice(),
            self.x.as_slice(),
            one,
            self.t2.as_slice(),
        );
        let nq = self.nq;
        let (x, xhat) = (self.x.as_slice(), self.xhat.as_slice());
        let (xbar, y) = (self.xbar.as_mut_slice(), self.y.as_mut_slice());
        for i in 0..nq {
            xbar[i] = x[i] + V::Real::lit(0.5) * dq[i];
            y[i] = x[i] + dq[i];
        }
        xbar[nq..].copy_from_slice(&xhat[nq..]);
    }
}

impl<V, Sys, K> NonlinearProblem<V::Real> for Problem<'_, V, Sys, K>
where
    V: Vector,
    Sys: Model<V>,
    K: Hamiltonian<V>,
{
    type Error = StepError;

    fn dim(&self) -> usize {
        self.nq + self.g.len()
    }
    fn noise_floor(&self) -> V::Real {
        self.noise
    }
    fn noisy_rows(&self) -> usize {
        self.nq
    }
    fn residual(&mut self, z: &[V::Real], out: &mut [V::Real]) -> Result<(), StepError> {
        self.place(z);
        let (h, nq) = (self.h, self.nq);
        self.inner.gradient(self.xbar, self.grad);
        let u = self.u.as_mut_slice();
        u[..nq].iter_mut().for_each(|e| *e = V::Real::zero());
        u[nq..].copy_from_slice(&z[..nq]);
        self.system.structure().apply(self.x, self.u, self.mu);
        let (grad, bdq) = (&self.grad.as_slice()[..nq], &self.mu.as_slice()[nq..]);
        let phat = &self.xhat.as_slice()[nq..];
        let (r1, r2) = out.split_at_mut(nq);
        let y = self.y.as_mut_slice();
        let impulse = match self.forcing.as_deref_mut() {
            Some(forcing) => Some(&forcing.force_at(0, self.xbar).as_slice()[nq..]),
            None => None,
        };
        for i in 0..nq {
            // δp = −h ∇V(q̄) + B δq + φ;  p̄ = p̂ + δp/2.
            let phi = impulse.map_or(V::Real::zero(), |phi| phi[i]);
            let dp = bdq[i] - h * grad[i] + phi;
            let pbar = phat[i] + V::Real::lit(0.5) * dp;
            r1[i] = z[i] - h * (self.w[i] * pbar);
            y[nq + i] = phat[i] + dp;
        }
        self.system.constraint().residual(self.y, r2);
        self.g.copy_from_slice(r2);
        Ok(())
    }
    /// The columns of a group (no two share a row) as one product: for `v = (v_q, v_ν)`,
    /// `(v_q − (h/2) W⁻¹ B v_q + (h²/4) W⁻¹ ∇²V(q̄) v_q + W⁻¹ G_q(q)ᵀ v_ν,  G_q(y) v_q)`.
    /// `false` (differences) without [`Hamiltonian::hessian_apply`].
    fn jacobian_group(&mut self, z: &[V::Real], cols: &[usize], out: &mut [V::Real]) -> bool {
        let (h, nq) = (self.h, self.nq);
        self.place(z);
        let (r1, r2) = out.split_at_mut(nq);
        r1.iter_mut().for_each(|e| *e = V::Real::zero());
        r2.iter_mut().for_each(|e| *e = V::Real::zero());
        let positions = cols.iter().any(|&j| j < nq);
        let multipliers = cols.iter().any(|&j| j >= nq);
        let quarter = h * h * V::Real::lit(0.25);
        if positions {
            // t1 = (v_q, 0), u = (0, v_q).
            let (t1, u) = (self.t1.as_mut_slice(), self.u.as_mut_slice());
            ops::fill_zero(t1);
            ops::fill_zero(u);
            for &j in cols.iter().filter(|&&j| j < nq) {
                t1[j] = V::Real::one();
                u[nq + j] = V::Real::one();
            }
            if !self.inner.hessian_apply(self.xbar, self.t1, self.hv) {
                return false;
            }
            self.system.structure().apply(self.x, self.u, self.mu);
            let (hv, bv) = (&self.hv.as_slice()[..nq], &self.mu.as_slice()[nq..]);
            let t1 = &self.t1.as_slice()[..nq];
            let half = h * V::Real::lit(0.5);
            for i in 0..nq {
                r1[i] = t1[i] - self.w[i] * (half * bv[i] - quarter * hv[i]);
            }
            self.system.constraint().jacobian_apply(self.y, self.t1, r2);
        }
        if multipliers {
            self.scaled.iter_mut().for_each(|s| *s = V::Real::zero());
            for &j in cols.iter().filter(|&&j| j >= nq) {
                self.scaled[j - nq] = V::Real::one();
            }
            self.scaled_columns_add(r1);
        }
        true
    }
}

impl<V, Sys, K> Problem<'_, V, Sys, K>
where
    V: Vector,
    Sys: Model<V>,
    K: Hamiltonian<V>,
{
    /// `out += W⁻¹ G_q(q)ᵀ v` for `v` in `scaled`: minus `W⁻¹` times the momentum part of
    /// `M Gᵀ v`.
    fn scaled_columns_add(&mut self, out: &mut [V::Real]) {
        self.system
            .constraint_force(self.x, self.scaled, self.t1, self.t2);
        let f = &self.t2.as_slice()[self.nq..];
        for ((o, &w), &f) in out.iter_mut().zip(self.w).zip(f) {
            *o = *o - w * f;
        }
    }
}

impl<V, Sys, K> ReducedBlocks<V::Real> for Problem<'_, V, Sys, K>
where
    V: Vector,
    Sys: Model<V>,
    K: Hamiltonian<V>,
{
    fn multiplier_columns_add(&mut self, v: &[V::Real], out: &mut [V::Real]) {
        self.scaled.copy_from_slice(v);
        self.scaled_columns_add(out);
    }
    /// `G_q(q + δq) v`.
    fn constraint_rows(&mut self, v: &[V::Real], out: &mut [V::Real]) {
        position_rows(self.system.constraint(), self.y, v, self.t1, out);
    }
}

impl<V, Sys, K, L> ProjectedMidpoint<V, Sys, K, L>
where
    V: Vector,
    Sys: Model<V>,
    K: Hamiltonian<V>,
    L: LinearSolver<V::Real>,
{
    /// The joint solve on the mechanical path: `λ_k` into `z[..m]`, `y` into `w.y`, `g(y)` into
    /// the general path's `g_y`. The same equations, predictor and tolerances as
    /// `solve_joint_general` with the momentum rows solved exactly.
    pub(super) fn solve_reduced(&mut self, h: V::Real, x: &V) -> Result<(), StepError> {
        let Some(general) = self.general.as_mut() else {
            unreachable!("the reduced solve without a general path");
        };
        let Some(reduced) = general.mechanical.as_mut() else {
            unreachable!("the reduced solve without a mechanical form");
        };
        let (nq, m) = (reduced.nq, self.m);
        let continued = self.entry.is_last(x);
        reduced.solver.begin(h, continued);
        let w = &mut self.w;
        let mut problem = Problem {
            h,
            nq,
            w: &reduced.w,
            x,
            system: &self.system,
            inner: &self.inner,
            noise: V::Real::zero(),
            scaled: &mut reduced.scaled,
            xhat: &mut w.xhat,
            xbar: &mut w.xbar,
            y: &mut w.y,
            grad: &mut w.grad,
            u: &mut w.delta,
            mu: &mut w.f,
            hv: &mut w.hv,
            t1: &mut w.t1,
            t2: &mut w.t2,
            g: &mut general.g_y,
            forcing: self.forcing.as_mut(),
        };
        // The explicit Euler predictor δq = h W⁻¹ p̂ at x̂ of the predicted λ_k.
        let z = &mut reduced.z;
        let nu_per_lambda = h * h * V::Real::lit(0.5);
        for (nu, &l) in z[nq..].iter_mut().zip(&self.z.as_slice()[..m]) {
            *nu = nu_per_lambda * l;
        }
        z[..nq].iter_mut().for_each(|d| *d = V::Real::zero());
        problem.place(z);
        let phat = &problem.xhat.as_slice()[nq..];
        for ((d, &wi), &p) in z[..nq].iter_mut().zip(problem.w).zip(phat) {
            *d = h * (wi * p);
        }
        let tol1 = increment_tolerance(x.as_slice(), &z[..nq]);
        let floor = stiff_floor(&self.system, &self.inner, h, x, problem.hv, problem.t2);
        problem.noise = tol1.max(floor.unwrap_or(tol1)) * V::Real::lit(0.25);
        // Past steps predict better than the explicit Euler step, when there are two.
        reduced.solver.predict(z);
        let report = reduced
            .solver
            .solve(&mut problem, z)
            .map_err(|e| StepError::from_newton(STAGE_JOINT, e))?;
        // The last evaluation was at the solution: y and g(y) are its.
        self.stats.record(&report);
        for (l, &nu) in self.z.as_mut_slice()[..m].iter_mut().zip(&z[nq..]) {
            *l = nu / nu_per_lambda;
        }
        reduced.solver.record(z, continued);
        Ok(())
    }
}
