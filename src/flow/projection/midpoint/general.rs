//! [`ProjectedMidpoint`]'s general path, for more than [`SMALL_MAX`](crate::nonlinear::SMALL_MAX)
//! constraints: [`Newton`] on the `n + m` unknowns `(δ, λ_k)` with the closed-form Jacobian
//! (dense), and the `λ_{k+1}` projection by [`Newton`] on `m` unknowns.

use super::{ProjectedMidpoint, STAGE_JOINT, guard, increment_tolerance, stiff_floor};
use crate::error::{LinearSolveError, StepError};
use crate::flow::projection::{Hidden, STAGE_LAMBDA_K1};
use crate::linalg::LinearSolver;
use crate::nonlinear::{Newton, NewtonOptions, NonlinearProblem, NonlinearSolver};
use crate::real::Real;
use crate::system::{Hamiltonian, HolonomicConstraint, StructureMatrix};
use crate::system::{MechanicalForm, Model};
use crate::vector::{Vector, ops};
use nalgebra::DVector;
use num_traits::Float as _;
use num_traits::{One, Zero};

/// The solvers and multiplier-sized workspace of the general path (allocated at construction).
pub(super) struct General<T: Real, L> {
    /// The joint system, `n + m` unknowns (dense: the Newton matrix couples every `δ_i` with
    /// the columns `M∇²K`, which are dense for a general model).
    /// `None` on the mechanical path.
    newton: Option<Newton<DVector<T>>>,
    /// The momenta eliminated (a model of mechanical form): Newton on `(δq, λ_k)`.
    pub(super) mechanical: Option<crate::flow::reduced::Reduced<T, L>>,
    /// The `λ_{k+1}` system, `m` unknowns.
    hidden: Newton<DVector<T>>,
    /// `(δ, λ_k)`.
    z: Vec<T>,
    /// `ν = (h/2) λ_{k+1}`.
    nu: Vec<T>,
    /// `(h/2) λ_k` (scratch of the residual).
    scaled: Vec<T>,
    /// A unit vector of multipliers (scratch of the `λ_{k+1}` system's columns).
    unit: Vec<T>,
    /// `g(y)` at the solution of the joint system.
    pub(super) g_y: Vec<T>,
    /// `g(x_{k+1})`, and scratch of the entry check.
    pub(super) g_next: Vec<T>,
}

impl<T: Real, L: LinearSolver<T>> General<T, L> {
    /// Forgets the kept Newton matrices (the next solves build them anew) and appends the
    /// unknowns that warm-start the next step.
    pub(super) fn save(&mut self, out: &mut Vec<T>) {
        self.invalidate();
        out.extend_from_slice(&self.z);
        out.extend_from_slice(&self.nu);
    }

    /// Reads back what [`save`](Self::save) appended.
    pub(super) fn restore(&mut self, from: &mut &[T]) {
        self.invalidate();
        for v in [self.z.as_mut_slice(), self.nu.as_mut_slice()] {
            let saved = crate::flow::take_memory(from, v.len());
            v[..saved.len()].copy_from_slice(saved);
        }
    }

    /// Forgets the kept Newton matrices.
    fn invalidate(&mut self) {
        if let Some(newton) = self.newton.as_mut() {
            newton.invalidate_jacobian();
        }
        if let Some(reduced) = self.mechanical.as_mut() {
            reduced.invalidate();
        }
        self.hidden.invalidate_jacobian();
    }

    /// The general path for `n` states and `m` constraints: on the `n_q + m` unknowns of the
    /// mechanical form when there is one, on `n + m` otherwise; `pattern`: the sparsity of the
    /// `λ_{k+1}` system, when known.
    pub(super) fn new(
        n: usize,
        m: usize,
        options: NewtonOptions<T>,
        form: Option<MechanicalForm<T>>,
        pattern: Option<&[(usize, usize)]>,
    ) -> Result<Self, LinearSolveError> {
        let (newton, mechanical, k) = match form {
            Some(form) => (
                None,
                Some(crate::flow::reduced::Reduced::new(
                    form,
                    m,
                    options,
                    false,
                    &[T::lit(0.5)],
                )?),
                0,
            ),
            None => (Some(Newton::new(n + m, options)?), None, n + m),
        };
        Ok(Self {
            newton,
            mechanical,
            // The multiplier system's sparsity, derived from the constraint's entries (constraints
            // couple when their gradients share a state variable).
            hidden: Newton::with_pattern(m, options, pattern)?,
            z: vec![T::zero(); k],
            nu: vec![T::zero(); m],
            scaled: vec![T::zero(); m],
            unit: vec![T::zero(); m],
            g_y: vec![T::zero(); m],
            g_next: vec![T::zero(); m],
        })
    }
}

/// `F(δ, λ) = (δ − h M(x̄) ∇K(x̄),  g(y))` with `x̂ = x + (h/2) M(x) G(x)ᵀ λ`, `x̄ = x̂ + δ/2`,
/// `y = x̂ + δ`: the midpoint rule's increment and the constraint at its end, as one system.
struct Joint<'a, V: Vector, Sys, K> {
    h: V::Real,
    x: &'a V,
    system: &'a Sys,
    inner: &'a K,
    /// The tolerance of the increment rows over 4 (their noise floor, see `noise_floor`).
    noise: V::Real,
    scaled: &'a mut [V::Real],
    xhat: &'a mut V,
    xbar: &'a mut V,
    y: &'a mut V,
    grad: &'a mut V,
    f: &'a mut V,
    hv: &'a mut V,
    t1: &'a mut V,
    t2: &'a mut V,
    /// `g(y)` of the last evaluation.
    g: &'a mut [V::Real],
}

impl<V, Sys, K> Joint<'_, V, Sys, K>
where
    V: Vector,
    Sys: Model<V>,
    K: Hamiltonian<V>,
{
    /// `x̂`, `x̄`, `y` of `z = (δ, λ)`, and `f = M(x̄) ∇K(x̄)` (gradient in `grad`).
    fn place(&mut self, z: &[V::Real]) {
        let (delta, lambda) = z.split_at(self.x.len());
        let half = self.h * V::Real::lit(0.5);
        for (s, &l) in self.scaled.iter_mut().zip(lambda) {
            *s = half * l;
        }
        self.system
            .constraint_force(self.x, self.scaled, self.t1, self.t2);
        let one = V::Real::one();
        ops::add_scaled(
            self.xhat.as_mut_slice(),
            self.x.as_slice(),
            one,
            self.t2.as_slice(),
        );
        ops::add_scaled(
            self.xbar.as_mut_slice(),
            self.xhat.as_slice(),
            V::Real::lit(0.5),
            delta,
        );
        ops::add_scaled(self.y.as_mut_slice(), self.xhat.as_slice(), one, delta);
        self.inner.gradient(self.xbar, self.grad);
        self.system.structure().apply(self.xbar, self.grad, self.f);
    }
}

impl<V, Sys, K> NonlinearProblem<V::Real> for Joint<'_, V, Sys, K>
where
    V: Vector,
    Sys: Model<V>,
    K: Hamiltonian<V>,
{
    type Error = StepError;

    fn dim(&self) -> usize {
        self.x.len() + self.g.len()
    }
    /// The increment rows round at their own floor (the state's and `h M∇K`'s rounding); the
    /// constraint rows must meet the tolerance.
    fn noise_floor(&self) -> V::Real {
        self.noise
    }
    fn noisy_rows(&self) -> usize {
        self.x.len()
    }
    fn residual(&mut self, z: &[V::Real], out: &mut [V::Real]) -> Result<(), StepError> {
        self.place(z);
        let n = self.x.len();
        let (r1, r2) = out.split_at_mut(n);
        for ((r, &d), &f) in r1.iter_mut().zip(&z[..n]).zip(self.f.as_slice()) {
            *r = d - self.h * f;
        }
        self.system.constraint().residual(self.y, r2);
        self.g.copy_from_slice(r2);
        Ok(())
    }
    /// Column `j < n` (`δ_j`): `(e_j − (h/2) D(M∇K)(x̄) e_j,  G(y) e_j)`; column `n + j` (`λ_j`),
    /// with `v = (h/2) M(x) G(x)ᵀ e_j` (`∂x̂/∂λ_j`): `(−h D(M∇K)(x̄) v,  G(y) v)`. From
    /// [`Hamiltonian::hessian_apply`] and [`StructureMatrix::derivative_apply_add`]; `false`
    /// (differences) for a model without them.
    fn jacobian_column(&mut self, z: &[V::Real], j: usize, out: &mut [V::Real]) -> bool {
        let n = self.x.len();
        if j == 0 {
            self.place(z);
        }
        let half = self.h * V::Real::lit(0.5);
        if j < n {
            ops::fill_zero(self.t1.as_mut_slice());
            self.t1.as_mut_slice()[j] = V::Real::one();
        } else {
            self.scaled.iter_mut().for_each(|s| *s = V::Real::zero());
            self.scaled[j - n] = half;
            self.system
                .constraint_force(self.x, self.scaled, self.hv, self.t1);
        }
        // t2 = D(M∇K)(x̄) t1.
        if !self.inner.hessian_apply(self.xbar, self.t1, self.hv) {
            return false;
        }
        self.system.structure().apply(self.xbar, self.hv, self.t2);
        if !self.system.structure().derivative_apply_add(
            self.xbar,
            self.t1,
            self.grad,
            V::Real::one(),
            self.t2,
        ) {
            return false;
        }
        let (c1, c2) = out.split_at_mut(n);
        if j < n {
            for (i, (o, &t)) in c1.iter_mut().zip(self.t2.as_slice()).enumerate() {
                let e = if i == j {
                    V::Real::one()
                } else {
                    V::Real::zero()
                };
                *o = e - half * t;
            }
        } else {
            for (o, &t) in c1.iter_mut().zip(self.t2.as_slice()) {
                *o = -self.h * t;
            }
        }
        self.system.constraint().jacobian_apply(self.y, self.t1, c2);
        true
    }
}

impl<V, Sys, K, L> ProjectedMidpoint<V, Sys, K, L>
where
    V: Vector,
    Sys: Model<V>,
    K: Hamiltonian<V>,
    L: LinearSolver<V::Real>,
{
    /// One step from `x` on the general path; the result is left in `w.x_next`. The same
    /// equations, predictor and tolerances as the small path (`solve_joint`), solved by
    /// [`Newton`] with the increment rows' tolerance as their noise floor.
    pub(super) fn step_general(&mut self, h: V::Real, x: &V) -> Result<(), StepError> {
        let Some(general) = self.general.as_mut() else {
            unreachable!("step_general without a general path");
        };
        let m = self.m;
        let half = h * V::Real::lit(0.5);
        self.warm.predict_lambda_k(m, h, self.z.as_mut_slice());
        if general.mechanical.is_some() {
            self.solve_reduced(h, x)?;
        } else {
            self.solve_joint_general(h, x)?;
        }
        let Some(general) = self.general.as_mut() else {
            unreachable!("step_general without a general path");
        };
        let w = &mut self.w;
        self.warm.record_lambda_k(m, h, self.z.as_slice());
        self.warm.predict_lambda_k1(m, h, self.z.as_mut_slice());
        // λ_{k+1} from φ(y + M(y) G(y)ᵀ ν) = 0, ν = (h/2) λ_{k+1}.
        for (nu, &l) in general.nu.iter_mut().zip(&self.z.as_slice()[m..2 * m]) {
            *nu = half * l;
        }
        let mut hidden = Hidden {
            base: &w.y,
            x: &mut w.x_next,
            t1: &mut w.t1,
            t2: &mut w.t2,
            system: &self.system,
            columns: Some((&mut w.hv, &mut general.unit)),
        };
        match general.hidden.solve(&mut hidden, &mut general.nu) {
            Ok(report) => self.stats.record(&report),
            Err(e) => {
                general.hidden.invalidate_jacobian();
                return Err(StepError::from_newton(STAGE_LAMBDA_K1, e));
            }
        }
        hidden.place(&general.nu);
        for (l, &nu) in self.z.as_mut_slice()[m..2 * m].iter_mut().zip(&general.nu) {
            *l = nu / half;
        }
        self.warm.record_lambda_k1(m, h, self.z.as_slice());
        // The decoupling assumption: the second half-step left g where it was.
        self.system
            .constraint()
            .residual(&w.x_next, &mut general.g_next);
        guard(self.guard_tol, &general.g_next, &general.g_y)
    }

    /// The joint solve for `(δ, λ_k)` on `n + m` unknowns: `λ_k` into `z[..m]`, `y` into `w.y`,
    /// `g(y)` into the general path's `g_y`.
    fn solve_joint_general(&mut self, h: V::Real, x: &V) -> Result<(), StepError> {
        let Some(general) = self.general.as_mut() else {
            unreachable!("the joint solve without a general path");
        };
        let (n, m) = (x.len(), self.m);
        let w = &mut self.w;
        let mut problem = Joint {
            h,
            x,
            system: &self.system,
            inner: &self.inner,
            noise: V::Real::zero(),
            scaled: &mut general.scaled,
            xhat: &mut w.xhat,
            xbar: &mut w.xbar,
            y: &mut w.y,
            grad: &mut w.grad,
            f: &mut w.f,
            hv: &mut w.hv,
            t1: &mut w.t1,
            t2: &mut w.t2,
            g: &mut general.g_y,
        };
        // The explicit Euler predictor for δ at x̂ of the predicted λ_k.
        let z = &mut general.z;
        z[n..].copy_from_slice(&self.z.as_slice()[..m]);
        z[..n].iter_mut().for_each(|d| *d = V::Real::zero());
        problem.place(z);
        for (d, &f) in z[..n].iter_mut().zip(problem.f.as_slice()) {
            *d = h * f;
        }
        // The tolerance of the increment rows: ε (2‖x‖∞ + 8‖δ₀‖∞), or the rounding floor of a
        // stiff h M∇K, 4ε |h| ‖M ∇²K(x) x‖∞, when that is larger (as on the small path).
        let tol1 = increment_tolerance(x.as_slice(), &z[..n]);
        let floor = stiff_floor(&self.system, &self.inner, h, x, problem.hv, problem.t2);
        problem.noise = tol1.max(floor.unwrap_or(tol1)) * V::Real::lit(0.25);
        let Some(newton) = general.newton.as_mut() else {
            unreachable!("the joint solve without its solver");
        };
        let report = match newton.solve(&mut problem, z) {
            Ok(report) => report,
            Err(e) => {
                newton.invalidate_jacobian();
                return Err(StepError::from_newton(STAGE_JOINT, e));
            }
        };
        self.stats.record(&report);
        self.z.as_mut_slice()[..m].copy_from_slice(&z[n..]);
        Ok(())
    }
}
