//! The constrained discrete gradient's nonlinear problem: the increment `δ` and the scaled
//! multipliers `ℓ` of one step, `F(δ, ℓ) = (δ − h M(x̄)(∇̄H + ∇̄gᵀℓ/h) − h B(x̄) u, g(x + δ))`
//! (the inputs' term at `t_n + h/2` when the system is open), with its closed-form Jacobian
//! columns (`D(B u)` left out) and noise floor.

use crate::error::StepError;
use crate::flow::forcing::Forcing;
use crate::flow::implicit::{GonzalezRule, GradientRule, gonzalez_corrects, noise_image};
use crate::nonlinear::NonlinearProblem;
use crate::real::Real;
use crate::system::Model;
use crate::system::{Hamiltonian, HolonomicConstraint, StructureMatrix};
use crate::vector::{Vector, ops};
use num_traits::{Float as _, One, Zero};

/// `F(δ, ℓ) = (δ − h M(x̄)(∇̄H + ∇̄gᵀℓ/h) − h B(x̄) u(t_n + h/2),  g(x + δ))`.
pub(super) struct Problem<'a, V: Vector, Sys> {
    pub(super) h: V::Real,
    pub(super) noise: V::Real,
    pub(super) base_noise: V::Real,
    pub(super) x: &'a V,
    pub(super) xm: &'a mut V,
    pub(super) xe: &'a mut V,
    pub(super) grad: &'a mut V,
    pub(super) f: &'a mut V,
    pub(super) tmp: &'a mut V,
    pub(super) g0: &'a [V::Real],
    pub(super) g1: &'a mut [V::Real],
    pub(super) gd: &'a mut [V::Real],
    pub(super) s1: &'a mut V,
    pub(super) s2: &'a mut V,
    pub(super) em: &'a mut [V::Real],
    pub(super) system: &'a Sys,
    /// The inputs, their values at `t_n + h/2` scaled by `h` (`None` for a closed system).
    pub(super) forcing: Option<&'a mut Forcing<V>>,
}

impl<V, Sys> Problem<'_, V, Sys>
where
    V: Vector,
    Sys: Model<V>,
{
    /// `|δ|²` above which Gonzalez's correction term is evaluated (below, it is round-off).
    fn corrected(&self, delta: &[V::Real]) -> Option<V::Real> {
        let d2 = ops::dot(delta, delta);
        let x2 = ops::dot(self.x.as_slice(), self.x.as_slice());
        gonzalez_corrects(d2, x2).then_some(d2)
    }
}

impl<V, Sys> NonlinearProblem<V::Real> for Problem<'_, V, Sys>
where
    V: Vector,
    Sys: Model<V>,
{
    type Error = StepError;

    fn dim(&self) -> usize {
        self.x.len() + self.g0.len()
    }

    fn noise_floor(&self) -> V::Real {
        self.noise.max(self.base_noise)
    }

    fn noisy_rows(&self) -> usize {
        self.x.len()
    }

    fn residual(&mut self, z: &[V::Real], out: &mut [V::Real]) -> Result<(), StepError> {
        let n = self.x.len();
        let (delta, ell) = z.split_at(n);
        let x = self.x.as_slice();
        ops::add_scaled(self.xm.as_mut_slice(), x, V::Real::lit(0.5), delta);
        ops::add_scaled(self.xe.as_mut_slice(), x, V::Real::one(), delta);
        let sys = self.system;
        // grad = h ∇̄H.
        let noise = GonzalezRule::gradient(
            sys.hamiltonian(),
            self.x,
            delta,
            self.xm,
            self.tmp,
            self.grad,
        );
        for gi in self.grad.as_mut_slice() {
            *gi = *gi * self.h;
        }
        // grad += ∇̄gᵀ ℓ = G(x̄)ᵀ ℓ + (ℓ · c) δ,  cᵢ = (gᵢ(x') − gᵢ(x) − (G(x̄) δ)ᵢ) / |δ|².
        sys.constraint().residual(self.xe, self.g1);
        sys.constraint()
            .jacobian_transpose_apply_add(self.xm, ell, V::Real::one(), self.grad);
        // The rounding noise of grad along δ/|δ|: the energy's correction (scaled by h), and
        // the constraints' below.
        let mut noise = self.h.abs() * noise;
        if let Some(d2) = self.corrected(delta) {
            for (t, &d) in self.tmp.as_mut_slice().iter_mut().zip(delta) {
                *t = d;
            }
            sys.constraint().jacobian_apply(self.xm, self.tmp, self.gd);
            // G(x̄) x̄ bounds the size of the terms each gᵢ is formed from (|rᵢ|² for a rod),
            // so each difference gᵢ(x') − gᵢ(x) − (G δ)ᵢ rounds at about ε times that.
            sys.constraint().jacobian_apply(self.xm, self.xm, self.em);
            let (mut lc, mut lc_abs) = (V::Real::zero(), V::Real::zero());
            for ((((&l, &g1), &g0), &gd), &e) in ell
                .iter()
                .zip(&*self.g1)
                .zip(self.g0)
                .zip(&*self.gd)
                .zip(&*self.em)
            {
                lc = lc + l * (g1 - g0 - gd);
                lc_abs = lc_abs + l.abs() * (g1.abs() + g0.abs() + gd.abs() + e.abs());
            }
            ops::axpy(self.grad.as_mut_slice(), lc / d2, delta);
            // Near rest |δ| is small and the correction (exactly zero for a quadratic g) is
            // that rounding divided by |δ|: above the tolerance, and no iterate reduces it.
            noise = noise + V::Real::epsilon() * lc_abs / d2.sqrt();
        }
        sys.structure().apply(self.xm, self.grad, self.f);
        self.noise = noise_image(
            sys.structure(),
            self.xm,
            delta,
            noise,
            V::Real::one(),
            self.tmp,
            self.xe,
        );
        let (od, og) = out.split_at_mut(n);
        for ((o, &d), &fi) in od.iter_mut().zip(delta).zip(self.f.as_slice()) {
            *o = d - fi;
        }
        if let Some(forcing) = self.forcing.as_deref_mut() {
            let force = forcing.force_at(0, self.xm);
            for (o, &b) in od.iter_mut().zip(force.as_slice()) {
                *o = *o - b;
            }
        }
        og.copy_from_slice(self.g1);
        Ok(())
    }

    /// Closed-form columns of `∂F/∂(δ, ℓ)` at the last residual's point, from the model's
    /// derivatives:
    /// - `δ_j`: `e_j − ½ M(x̄)(h ∇²H(x̄) + Σᵢ ℓᵢ ∇²gᵢ(x̄)) e_j − ½ DM(x̄)[e_j] F̄` over
    ///   `G(x') e_j`, the constraint Hessian term as a central difference of `G(x)ᵀℓ`
    ///   (exact for quadratic constraints);
    /// - `ℓᵢ`: `−M(x̄) ∇̄gᵢ(x, x')ᵀ` over `0`.
    ///
    /// Gonzalez's correction terms enter only through `∇̄gᵢ`; their `δ`-derivatives (zero for
    /// quadratic `H` and `g`) are left out, so for other models the matrix is a close
    /// approximation and Newton, which tests the residual, converges slightly slower.
    /// Declines (differences instead) when the model has no `∇²H` or `DM`.
    fn jacobian_column(&mut self, z: &[V::Real], j: usize, out: &mut [V::Real]) -> bool {
        let n = self.x.len();
        let (delta, ell) = z.split_at(n);
        let (od, og) = out.split_at_mut(n);
        let sys = self.system;
        let half = V::Real::lit(0.5);
        if j < n {
            ops::fill_zero(self.s1.as_mut_slice());
            self.s1.as_mut_slice()[j] = V::Real::one();
            if !sys.hamiltonian().hessian_apply(self.xm, self.s1, self.s2) {
                return false;
            }
            for v in self.s2.as_mut_slice() {
                *v = *v * self.h;
            }
            // Σ ℓᵢ ∇²gᵢ e_j = ∂(G(x)ᵀℓ)/∂x_j by a central difference.
            let xj = self.xm.as_slice()[j];
            let eps =
                V::Real::epsilon().powf(V::Real::lit(1.0 / 3.0)) * (V::Real::one() + xj.abs());
            let inv = V::Real::one() / (eps + eps);
            self.tmp.copy_from(self.xm);
            self.tmp.as_mut_slice()[j] = xj + eps;
            sys.constraint()
                .jacobian_transpose_apply_add(self.tmp, ell, inv, self.s2);
            self.tmp.as_mut_slice()[j] = xj - eps;
            sys.constraint()
                .jacobian_transpose_apply_add(self.tmp, ell, -inv, self.s2);
            sys.structure().apply(self.xm, self.s2, self.tmp);
            if !sys.structure().derivative_apply_add(
                self.xm,
                self.s1,
                self.grad,
                V::Real::one(),
                self.tmp,
            ) {
                return false;
            }
            for (i, (o, &t)) in od.iter_mut().zip(self.tmp.as_slice()).enumerate() {
                let e = if i == j {
                    V::Real::one()
                } else {
                    V::Real::zero()
                };
                *o = e - half * t;
            }
            // G(x') e_j, x' = x + δ (the residual used `xe` as scratch after forming x').
            ops::add_scaled(
                self.tmp.as_mut_slice(),
                self.x.as_slice(),
                V::Real::one(),
                delta,
            );
            sys.constraint().jacobian_apply(self.tmp, self.s1, og);
        } else {
            let i = j - n;
            ops::fill_zero(self.em);
            self.em[i] = V::Real::one();
            ops::fill_zero(self.s2.as_mut_slice());
            sys.constraint().jacobian_transpose_apply_add(
                self.xm,
                self.em,
                V::Real::one(),
                self.s2,
            );
            if let Some(d2) = self.corrected(delta) {
                // cᵢ δ, cᵢ = (gᵢ(x') − gᵢ(x) − (G(x̄) δ)ᵢ) / |δ|².
                self.s1.as_mut_slice().copy_from_slice(delta);
                sys.constraint().jacobian_apply(self.xm, self.s1, self.gd);
                let c = (self.g1[i] - self.g0[i] - self.gd[i]) / d2;
                ops::axpy(self.s2.as_mut_slice(), c, delta);
            }
            sys.structure().apply(self.xm, self.s2, self.tmp);
            for (o, &t) in od.iter_mut().zip(self.tmp.as_slice()) {
                *o = -t;
            }
            ops::fill_zero(og);
        }
        true
    }
}
