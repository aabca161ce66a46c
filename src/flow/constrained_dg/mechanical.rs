//! The constrained discrete gradient of a model of mechanical form ([`MechanicalForm`]):
//! the discrete gradient taken block by block, the momenta eliminated, Newton on
//! `(δq, ν = (h²/2) λ)` with a sparse, kept Newton matrix ([`Reduced`]).
//!
//! For `H = ½ pᵀW⁻¹p + V(q)`, `M = [[0, I], [−I, B]]` (`B` constant) and `g(q) = 0`, the
//! discrete gradient of the separable `H` block by block, `∇̄H = (∇̄V(q, q'), W⁻¹p̄)` with
//! Gonzalez's midpoint discrete gradient `∇̄V` of `V` alone (the kinetic part's is exact:
//! `T(p') − T(p) = p̄ᵀW⁻¹δp`), and `∇̄gᵢ(q, q')` likewise on the positions, turn the step
//! `x' = x + h M(x̄)(∇̄H + ∇̄gᵀλ)` into
//!
//! ```text
//! δq = h W⁻¹ p̄,   δp = −h (∇̄V + ∇̄gᵀλ) + B δq,   p̄ = p + δp/2,   g(q + δq) = 0.
//! ```
//!
//! The momentum rows are solved exactly, which leaves `n_q + m` equations
//!
//! ```text
//! F₁ = δq − (h/2) W⁻¹ B δq + (h²/2) W⁻¹ ∇̄V + W⁻¹ ∇̄gᵀν − h W⁻¹ p = 0,    F₂ = g(q + δq) = 0.
//! ```
//!
//! The energy identity holds as for the full-state discrete gradient:
//! `H(x') − H(x) = ∇̄V·δq + p̄ᵀW⁻¹δp = −λ·(g(q') − g(q)) + δqᵀB δq / h = h v̄ᵀB v̄`,
//! `v̄ = W⁻¹p̄ = δq/h`: zero for skew `B`, `≤ 0` when `B + Bᵀ ⪯ 0`.
//!
//! **Inputs** (`with_inputs`): the momentum rows gain the impulse `φ = h F(q̄) u(t_n + h/2)`,
//! `δp = −h(∇̄V + ∇̄gᵀλ) + B δq + φ`, so `F₁` gains `−(h/2) W⁻¹ φ` and the identity gains
//! `p̄ᵀW⁻¹φ = δqᵀφ / h`, the work `S_n` of the inputs along the step.

use super::ConstrainedDiscreteGradient;
use crate::error::StepError;
use crate::flow::forcing::Forcing;
use crate::flow::implicit::gonzalez_corrects;
use crate::flow::reduced::Reduced;
use crate::flow::schur::{ReducedBlocks, position_rows};
use crate::nonlinear::NonlinearProblem;
use crate::real::Real;
use crate::system::{Hamiltonian, HolonomicConstraint, Model, StructureMatrix};
use crate::vector::{Vector, ops};
use num_traits::Float as _;
use num_traits::{One, Zero};

/// The reduced step problem, borrowing the flow's workspace.
struct Problem<'a, V: Vector, Sys> {
    h: V::Real,
    nq: usize,
    w: &'a [V::Real],
    /// `max W⁻¹`.
    w_max: V::Real,
    x: &'a V,
    system: &'a Sys,
    /// `|H(x)|`, the scale of the energy difference's rounding.
    energy: V::Real,
    /// The noise floor of the position rows without Gonzalez's corrections, and with them at
    /// the last residual.
    base_noise: V::Real,
    noise: V::Real,
    g0: &'a [V::Real],
    g1: &'a mut [V::Real],
    gd: &'a mut [V::Real],
    em: &'a mut [V::Real],
    scaled: &'a mut [V::Real],
    /// `(q̄, p)`.
    xbar: &'a mut V,
    /// `(q + δq, p)` while the energy difference is formed, then `(q + δq, p + δp)`.
    y: &'a mut V,
    grad: &'a mut V,
    u: &'a mut V,
    mu: &'a mut V,
    hv: &'a mut V,
    t1: &'a mut V,
    t2: &'a mut V,
    /// `(δq, δp)` of the last residual.
    delta: &'a mut [V::Real],
    /// The inputs, their values at `t_n + h/2` scaled by `h` (`None` for a closed system).
    forcing: Option<&'a mut Forcing<V>>,
}

impl<V, Sys> Problem<'_, V, Sys>
where
    V: Vector,
    Sys: Model<V>,
{
    /// `xbar = (q + δq/2, p)`, `y = (q + δq, p)`.
    fn place(&mut self, dq: &[V::Real]) {
        let nq = self.nq;
        let x = self.x.as_slice();
        let (xbar, y) = (self.xbar.as_mut_slice(), self.y.as_mut_slice());
        for i in 0..nq {
            xbar[i] = x[i] + V::Real::lit(0.5) * dq[i];
            y[i] = x[i] + dq[i];
        }
        xbar[nq..].copy_from_slice(&x[nq..]);
        y[nq..].copy_from_slice(&x[nq..]);
    }

    /// `|δq|²` when Gonzalez's corrections are above round-off (as for the full state).
    fn corrected(&self, dq: &[V::Real]) -> Option<V::Real> {
        let d2 = ops::dot(dq, dq);
        let q = &self.x.as_slice()[..self.nq];
        gonzalez_corrects(d2, ops::dot(q, q)).then_some(d2)
    }
}

impl<V, Sys> NonlinearProblem<V::Real> for Problem<'_, V, Sys>
where
    V: Vector,
    Sys: Model<V>,
{
    type Error = StepError;

    fn dim(&self) -> usize {
        self.nq + self.g0.len()
    }
    fn noise_floor(&self) -> V::Real {
        self.noise.max(self.base_noise)
    }
    fn noisy_rows(&self) -> usize {
        self.nq
    }
    fn residual(&mut self, z: &[V::Real], out: &mut [V::Real]) -> Result<(), StepError> {
        let (h, nq) = (self.h, self.nq);
        let (dq, nu) = z.split_at(nq);
        self.place(dq);
        let sys = self.system;
        let eps = V::Real::epsilon();
        // grad = ∇̄V(q, q') in the position part.
        sys.hamiltonian().gradient(self.xbar, self.grad);
        sys.constraint().residual(self.y, self.g1);
        // t1 = ∇̄g(q, q')ᵀ ν in the position part.
        ops::fill_zero(self.t1.as_mut_slice());
        sys.constraint()
            .jacobian_transpose_apply_add(self.xbar, nu, V::Real::one(), self.t1);
        let mut noise = V::Real::zero();
        if let Some(d2) = self.corrected(dq) {
            let grad = &mut self.grad.as_mut_slice()[..nq];
            let (mut slope, mut slope_abs) = (V::Real::zero(), V::Real::zero());
            for (&g, &d) in grad.iter().zip(dq) {
                slope = slope + g * d;
                slope_abs = slope_abs + (g * d).abs();
            }
            // V(q') − V(q), the same momenta on both sides.
            let diff = sys.hamiltonian().energy_difference(self.x, self.y);
            ops::axpy(grad, (diff - slope) / d2, dq);
            let rounding = eps * (self.energy + diff.abs() + slope_abs) / d2.sqrt();
            noise = h * h * V::Real::lit(0.5) * self.w_max * rounding;
            // cᵢ = (gᵢ(q') − gᵢ(q) − (G(q̄) δq)ᵢ) / |δq|²; t1 += (ν · c) δq.
            let u = self.u.as_mut_slice();
            u[..nq].copy_from_slice(dq);
            ops::fill_zero(&mut u[nq..]);
            sys.constraint().jacobian_apply(self.xbar, self.u, self.gd);
            sys.constraint()
                .jacobian_apply(self.xbar, self.xbar, self.em);
            let (mut lc, mut lc_abs) = (V::Real::zero(), V::Real::zero());
            for ((((&l, &g1), &g0), &gd), &e) in nu
                .iter()
                .zip(&*self.g1)
                .zip(self.g0)
                .zip(&*self.gd)
                .zip(&*self.em)
            {
                lc = lc + l * (g1 - g0 - gd);
                lc_abs = lc_abs + l.abs() * (g1.abs() + g0.abs() + gd.abs() + e.abs());
            }
            ops::axpy(&mut self.t1.as_mut_slice()[..nq], lc / d2, dq);
            noise = noise + self.w_max * eps * lc_abs / d2.sqrt();
        }
        self.noise = noise;
        // mu = M (0, δq) = (δq, B δq).
        let u = self.u.as_mut_slice();
        ops::fill_zero(&mut u[..nq]);
        u[nq..].copy_from_slice(dq);
        sys.structure().apply(self.x, self.u, self.mu);
        let (grad, force) = (&self.grad.as_slice()[..nq], &self.t1.as_slice()[..nq]);
        let bdq = &self.mu.as_slice()[nq..];
        let p = &self.x.as_slice()[nq..];
        let (half, two_over_h) = (h * V::Real::lit(0.5), V::Real::lit(2.0) / h);
        let hh = h * half;
        let (r1, r2) = out.split_at_mut(nq);
        let y = &mut self.y.as_mut_slice()[nq..];
        let (ddq, ddp) = self.delta.split_at_mut(nq);
        // φ = h F(q̄) u(t_n + h/2), at xbar = (q̄, p).
        let impulse = match self.forcing.as_deref_mut() {
            Some(forcing) => Some(&forcing.force_at(0, self.xbar).as_slice()[nq..]),
            None => None,
        };
        for i in 0..nq {
            // (h²/2)(∇̄V + ∇̄gᵀλ) = (h²/2) ∇̄V + ∇̄gᵀν;  δp = B δq − (2/h) of it + φ.
            let f = hh * grad[i] + force[i];
            let phi = impulse.map_or(V::Real::zero(), |phi| phi[i]);
            let dp = bdq[i] - two_over_h * f + phi;
            r1[i] = dq[i] - self.w[i] * (half * (bdq[i] + phi) - f + h * p[i]);
            ddq[i] = dq[i];
            ddp[i] = dp;
            y[i] = p[i] + dp;
        }
        r2.copy_from_slice(self.g1);
        Ok(())
    }

    /// The columns of a group (no two share a row) as one product, Gonzalez's correction terms
    /// left out (they vanish for quadratic `V` and `g`, and are dense columns outside the
    /// pattern; Newton tests the residual): for `v = (v_q, v_ν)`,
    /// `(v_q − (h/2) W⁻¹ B v_q + (h²/4) W⁻¹ ∇²V(q̄) v_q + ½ W⁻¹ Σᵢ νᵢ ∇²gᵢ(q̄) v_q
    /// + W⁻¹ G(q̄)ᵀ v_ν,  G(q') v_q)`, the constraint curvature by a central difference of
    /// `G(q̄)ᵀν`. `false` (differences) without [`Hamiltonian::hessian_apply`].
    fn jacobian_group(&mut self, z: &[V::Real], cols: &[usize], out: &mut [V::Real]) -> bool {
        let (h, nq) = (self.h, self.nq);
        let (dq, nu) = z.split_at(nq);
        self.place(dq);
        let sys = self.system;
        let (r1, r2) = out.split_at_mut(nq);
        ops::fill_zero(r1);
        ops::fill_zero(r2);
        if cols.iter().any(|&j| j < nq) {
            // t1 = (v_q, 0), u = (0, v_q).
            let (t1, u) = (self.t1.as_mut_slice(), self.u.as_mut_slice());
            ops::fill_zero(t1);
            ops::fill_zero(u);
            let mut scale = V::Real::zero();
            for &j in cols.iter().filter(|&&j| j < nq) {
                t1[j] = V::Real::one();
                u[nq + j] = V::Real::one();
                scale = scale.max(self.xbar.as_slice()[j].abs());
            }
            if !sys.hamiltonian().hessian_apply(self.xbar, self.t1, self.hv) {
                return false;
            }
            sys.structure().apply(self.x, self.u, self.mu);
            let (hv, bv) = (&self.hv.as_slice()[..nq], &self.mu.as_slice()[nq..]);
            let t1 = &self.t1.as_slice()[..nq];
            let (half, quarter) = (h * V::Real::lit(0.5), h * h * V::Real::lit(0.25));
            for i in 0..nq {
                r1[i] = t1[i] - self.w[i] * (half * bv[i] - quarter * hv[i]);
            }
            // Σ νᵢ ∇²gᵢ(q̄) v_q = ∂(G(q)ᵀν)/∂q · v_q by a central difference (exact for
            // quadratic constraints).
            let step = V::Real::epsilon().powf(V::Real::lit(1.0 / 3.0)) * (V::Real::one() + scale);
            let inv = V::Real::one() / (step + step);
            ops::fill_zero(self.mu.as_mut_slice());
            for sign in [V::Real::one(), -V::Real::one()] {
                ops::add_scaled(
                    self.t2.as_mut_slice(),
                    self.xbar.as_slice(),
                    sign * step,
                    self.t1.as_slice(),
                );
                sys.constraint()
                    .jacobian_transpose_apply_add(self.t2, nu, sign * inv, self.mu);
            }
            let curvature = &self.mu.as_slice()[..nq];
            for i in 0..nq {
                r1[i] = r1[i] + V::Real::lit(0.5) * self.w[i] * curvature[i];
            }
            sys.constraint().jacobian_apply(self.y, self.t1, r2);
        }
        if cols.iter().any(|&j| j >= nq) {
            ops::fill_zero(self.scaled);
            for &j in cols.iter().filter(|&&j| j >= nq) {
                self.scaled[j - nq] = V::Real::one();
            }
            self.scaled_columns_add(r1);
        }
        true
    }
}

impl<V, Sys> Problem<'_, V, Sys>
where
    V: Vector,
    Sys: Model<V>,
{
    /// `out += W⁻¹ G(q̄)ᵀ v` for `v` in `scaled`.
    fn scaled_columns_add(&mut self, out: &mut [V::Real]) {
        ops::fill_zero(self.t2.as_mut_slice());
        self.system.constraint().jacobian_transpose_apply_add(
            self.xbar,
            self.scaled,
            V::Real::one(),
            self.t2,
        );
        let f = &self.t2.as_slice()[..self.nq];
        for ((o, &w), &f) in out.iter_mut().zip(self.w).zip(f) {
            *o = *o + w * f;
        }
    }
}

impl<V, Sys> ReducedBlocks<V::Real> for Problem<'_, V, Sys>
where
    V: Vector,
    Sys: Model<V>,
{
    fn multiplier_columns_add(&mut self, v: &[V::Real], out: &mut [V::Real]) {
        self.scaled.copy_from_slice(v);
        self.scaled_columns_add(out);
    }
    /// `G(q + δq) v`.
    fn constraint_rows(&mut self, v: &[V::Real], out: &mut [V::Real]) {
        position_rows(self.system.constraint(), self.y, v, self.t1, out);
    }
}

impl<V, Sys, W> ConstrainedDiscreteGradient<V, Sys, W>
where
    V: Vector,
    Sys: Model<V>,
    W: Vector<Real = V::Real>,
{
    /// The step on the mechanical path from `start`: `(δq, δp)` into `z[..n]`, `ℓ = hλ` into
    /// `z[n..]`. `continued`: `start` is where the last step of this size ended.
    pub(super) fn solve_reduced(
        &mut self,
        h: V::Real,
        continued: bool,
    ) -> Result<crate::nonlinear::SolveReport<V::Real>, StepError> {
        let Some(reduced) = self.mechanical.as_mut() else {
            unreachable!("the reduced solve without a mechanical form");
        };
        let Reduced {
            nq,
            w,
            z,
            scaled,
            solver,
            ..
        } = reduced;
        let nq = *nq;
        let n = self.start.len();
        solver.begin(h, continued);
        let energy = self.system.hamiltonian().energy(&self.start).abs();
        let w_max = w.iter().fold(V::Real::zero(), |a, &b| a.max(b.abs()));
        // Predictor: the explicit Euler step δq = h W⁻¹ p, ν = (h²/2) λ_prev, unless past
        // steps predict better.
        let x = self.start.as_slice();
        for ((d, &wi), &p) in z[..nq].iter_mut().zip(w.iter()).zip(&x[nq..]) {
            *d = h * (wi * p);
        }
        let nu_per_lambda = h * h * V::Real::lit(0.5);
        for (nu, &l) in z[nq..].iter_mut().zip(&self.lambda) {
            *nu = nu_per_lambda * l;
        }
        let tol = V::Real::epsilon()
            * (V::Real::lit(2.0) * ops::norm_inf(x) + V::Real::lit(8.0) * ops::norm_inf(&z[..nq]));
        solver.predict(z);
        let (delta, ell) = self.z.as_mut_slice().split_at_mut(n);
        let mut problem = Problem {
            h,
            nq,
            w,
            w_max,
            x: &self.start,
            system: &self.system,
            energy,
            base_noise: tol.max(self.base_noise) * V::Real::lit(0.25),
            noise: V::Real::zero(),
            g0: &self.g0,
            g1: &mut self.g1,
            gd: &mut self.gd,
            em: &mut self.em,
            scaled,
            xbar: &mut self.xm,
            y: &mut self.xe,
            grad: &mut self.grad,
            u: &mut self.s1,
            mu: &mut self.f,
            hv: &mut self.s2,
            t1: &mut self.tmp,
            t2: &mut self.t2,
            delta,
            forcing: self.forcing.as_mut(),
        };
        let report = solver
            .solve(&mut problem, z)
            .map_err(|e| StepError::from_newton("constrained discrete gradient", e))?;
        // The last evaluation was at the solution: `delta` is its (δq, δp).
        let two_over_h = V::Real::lit(2.0) / h;
        for (l, &nu) in ell.iter_mut().zip(&z[nq..]) {
            *l = two_over_h * nu;
        }
        solver.record(z, continued);
        Ok(report)
    }

    /// `h v̄ᵀB v̄ = δqᵀB δq / h` of the last step on the mechanical path: the energy it supplied.
    pub(super) fn supplied_reduced(&mut self, h: V::Real) -> V::Real {
        let n = self.start.len();
        let nq = n / 2;
        let u = self.s1.as_mut_slice();
        ops::fill_zero(&mut u[..nq]);
        u[nq..].copy_from_slice(&self.z.as_slice()[..nq]);
        self.system
            .structure()
            .apply(&self.start, &self.s1, &mut self.f);
        ops::dot(&self.z.as_slice()[..nq], &self.f.as_slice()[nq..]) / h
    }

    /// `S_n = δqᵀφ / h` of the last step on the mechanical path (`φ = h F(q̄) u(t_n + h/2)`,
    /// formed again at its `q̄`): the work of the inputs; zero without.
    pub(super) fn input_work(&mut self, h: V::Real) -> V::Real {
        let Some(forcing) = self.forcing.as_mut() else {
            return V::Real::zero();
        };
        let n = self.start.len();
        let nq = n / 2;
        let dq = &self.z.as_slice()[..nq];
        let (x, xm) = (self.start.as_slice(), self.xm.as_mut_slice());
        for i in 0..nq {
            xm[i] = x[i] + V::Real::lit(0.5) * dq[i];
        }
        xm[nq..].copy_from_slice(&x[nq..]);
        let phi = &forcing.force_at(0, &self.xm).as_slice()[nq..];
        ops::dot(dq, phi) / h
    }

    /// The last step's energy account on the mechanical path: `(removed, supplied)`, the
    /// damping's `−h v̄ᵀB v̄` plus the kinetic energy the hidden-constraint projection removed,
    /// and the work of the inputs.
    pub(super) fn account(&mut self, h: V::Real) -> (V::Real, V::Real) {
        let mut removed = self.removed_by_projection();
        if self.system.structure().is_dissipative() {
            removed = removed - self.supplied_reduced(h);
        }
        (removed, self.input_work(h))
    }
}
