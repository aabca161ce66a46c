//! The general path: one residual type, [`Stage`], for the four multiplier systems ([`Mode`]),
//! solved by [`Newton`](crate::nonlinear::Newton) with kept, Broyden-updated, grouped or
//! closed-form Jacobians — any number of constraints, dense or sparse.

use super::gram::{Gram, Right, lead_drifts_freely};
use crate::error::StepError;
use crate::flow::{Flow, Ledger};
use crate::linalg::Sink;
use crate::nonlinear::NonlinearProblem;
use crate::real::Real;
use crate::system::Model;
use crate::system::{Hamiltonian, HolonomicConstraint, StructureMatrix};
use crate::vector::{Vector, ops};
use num_traits::Float as _;
use num_traits::{One, Zero};

/// Which multiplier system a [`Stage`] residual evaluates.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Mode {
    /// `λ_k ↦ g(Φ_h(x + h/2 M Gᵀ λ_k))` (decoupled).
    LambdaK,
    /// `λ_{k+1} ↦ φ(y + h/2 M(y) G(y)ᵀ λ_{k+1})` (decoupled).
    LambdaK1,
    /// `(λ_k, λ_{k+1}) ↦ (g(x'), φ(x'))`, `x'` implicit.
    Coupled,
    /// `λ ↦ g(x')`, same `λ` in both half-steps, `x'` implicit.
    Symmetric,
}

/// The residual of one multiplier system, borrowing the flow's pieces.
pub(super) struct Stage<'a, V: Vector, F, Sys> {
    pub(super) mode: Mode,
    pub(super) h: V::Real,
    pub(super) m: usize,
    pub(super) x: &'a V,
    pub(super) inner: &'a mut F,
    pub(super) ledger_in: Ledger<V::Real>,
    pub(super) ledger_y: &'a mut Ledger<V::Real>,
    pub(super) system: &'a Sys,
    pub(super) y: &'a mut V,
    pub(super) x_next: &'a mut V,
    pub(super) t1: &'a mut V,
    pub(super) t2: &'a mut V,
    pub(super) a_cached: &'a mut V,
    pub(super) y_valid: &'a mut bool,
    pub(super) hess_v: &'a mut V,
    pub(super) m_hess_v: &'a mut V,
    pub(super) indicator: &'a mut V,
    pub(super) g_y: &'a mut V,
    pub(super) fixed_point_max_iterations: usize,
    pub(super) fixed_point_tol: V::Real,
    /// `W⁻¹ = diag(w)` of a model of mechanical form ([`MechanicalForm`](crate::system::MechanicalForm)):
    /// the `λ_{k+1}` system is then `φ(y) − (h/2) G W⁻¹ Gᵀ λ_{k+1}`, affine, its Jacobian
    /// formed without the Hamiltonian's Hessian.
    pub(super) inverse_mass: Option<&'a [V::Real]>,
    /// The closed-form multiplier Jacobians of a model of mechanical form (with
    /// `inverse_mass`), when its constraint lists its entries.
    pub(super) gram: Option<&'a mut Gram<V::Real>>,
    /// The last `λ_k` group's directions in `hess_v` are the inner flow's exact tangents
    /// `DL_h M Gᵀ e` (not the approximation `(I + h M ∇²H) M Gᵀ e`).
    pub(super) tangent: bool,
}

impl<V, F, Sys> Stage<'_, V, F, Sys>
where
    V: Vector,
    F: Flow<V>,
    Sys: Model<V>,
{
    /// Whether the lead maps a constraint impulse `G(x)ᵀμ` (`μ` quasi-random in `[1, 2)`: no
    /// two alike, no pattern a physical coupling shares) as a free drift does
    /// ([`lead_drifts_freely`]).
    fn impulse_drifts_freely(&mut self, w: &[V::Real]) -> bool {
        let (m, nq) = (self.m, w.len());
        if self.indicator.len() < m || self.hess_v.len() < 2 * nq {
            return false;
        }
        let mu = &mut self.indicator.as_mut_slice()[..m];
        for (i, x) in mu.iter_mut().enumerate() {
            *x = V::Real::one() + V::Real::lit((0.618_033_988_749_895 * (i + 1) as f64).fract());
        }
        self.system.constraint().jacobian_transpose_apply(
            self.x,
            &self.indicator.as_slice()[..m],
            self.m_hess_v,
        );
        let (q, p) = self.hess_v.as_mut_slice().split_at_mut(nq);
        ops::fill_zero(q);
        p.copy_from_slice(&self.m_hess_v.as_slice()[..nq]);
        lead_drifts_freely(&mut *self.inner, self.h, w, &*self.hess_v, self.m_hess_v)
    }

    /// `y = Φ_h(x + h/2 M(x) G(x)ᵀ a)`, reusing the last `y` when `a` is unchanged.
    fn compute_y(&mut self, a: &[V::Real]) -> Result<(), StepError> {
        let m = self.m;
        if *self.y_valid
            && self.a_cached.as_slice()[..m]
                .iter()
                .zip(a)
                .all(|(c, v)| c == v)
        {
            return Ok(());
        }
        *self.y_valid = false;
        if let Some(gram) = self.gram.as_deref_mut() {
            gram.forget_y();
        }
        let half = self.h * V::Real::lit(0.5);
        // x̂ = x + h/2 M Gᵀ a, written straight into y (the inner flow then steps it in place);
        // x̂ = x at a = 0 (a solve started from zero) without forming the zero force; from
        // the gram's values for a model of mechanical form.
        if a.iter().all(|v| v.is_zero()) {
            self.y.copy_from(self.x);
        } else if !self.gram_force(Right::AtX, a) {
            self.system.constraint_force(self.x, a, self.t1, self.t2);
            ops::add_scaled(
                self.y.as_mut_slice(),
                self.x.as_slice(),
                half,
                self.t2.as_slice(),
            );
        }
        let mut ledger = self.ledger_in;
        // The λ_k system reads g(y), which a trailing kick cannot change: the inner flow's
        // lead alone (its tail follows the solve); the implicit end points need all of y.
        if self.mode == Mode::LambdaK {
            self.inner.step_lead(&mut ledger, self.h, self.y)?;
        } else {
            self.inner.step_at(&mut ledger, self.h, self.y)?;
        }
        *self.ledger_y = ledger;
        // An element loop: `copy_from_slice` of a run-time length is a `memcpy` call, which
        // costs more than the copy for a handful of multipliers.
        for (c, &v) in self.a_cached.as_mut_slice()[..m].iter_mut().zip(a) {
            *c = v;
        }
        *self.y_valid = true;
        Ok(())
    }

    /// The `λ_{k+1}` system is affine with its Jacobian summed in closed form: a model of
    /// mechanical form whose half-steps keep `G` (`inverse_mass`), with a [`Gram`].
    pub(super) fn affine_k1(&self) -> bool {
        self.inverse_mass.is_some() && self.gram.as_ref().is_some_and(|g| g.usable())
    }

    /// `x' = y + h/2 M(y) G(y)ᵀ b` (decoupled: `M Gᵀ` at `y` equals `M Gᵀ` at `x'`); `x' = y`
    /// at `b = 0`.
    pub(super) fn end_point_explicit(&mut self, b: &[V::Real]) {
        if b.iter().all(|v| v.is_zero()) {
            self.x_next.copy_from(self.y);
            return;
        }
        if self.gram.as_deref().is_some_and(|g| g.y_fresh()) && self.gram_force(Right::AtY, b) {
            return;
        }
        let half = self.h * V::Real::lit(0.5);
        self.system.constraint_force(&*self.y, b, self.t1, self.t2);
        ops::add_scaled(
            self.x_next.as_mut_slice(),
            self.y.as_slice(),
            half,
            self.t2.as_slice(),
        );
    }

    /// The `λ_{k+1}` residual of a model of mechanical form from the [`Gram`]'s values at `y`
    /// (filled here once a solve, then read by the Jacobian): `x' = y + (h/2) M G(y)ᵀ b` moves
    /// only momenta, so `G(x') = G(y)` and `φ(x') = G(y) W⁻¹ p'` — one pass over `G`'s entries
    /// where the general residual evaluates `∇H`, `M` and the constraint. `false` (nothing
    /// written) without a usable gram.
    fn hidden_from_gram(&mut self, b: &[V::Real], f: &mut [V::Real]) -> bool {
        let (Some(w), Some(gram)) = (self.inverse_mass, self.gram.as_deref_mut()) else {
            return false;
        };
        if !gram.fill(self.system.constraint(), &*self.y, true, w) {
            return false;
        }
        self.end_point_explicit(b);
        let gram = self.gram.as_deref().expect("checked above");
        gram.velocity(&self.x_next.as_slice()[w.len()..], f);
        true
    }

    /// A half-step along the constraint force from the [`Gram`]'s values, for a model of
    /// mechanical form (`M Gᵀa = (0, −G_qᵀa)` whatever its damping block): `y = x + (h/2) M
    /// G(x)ᵀ a` (`AtX`, filling `G(x)` once a solve) or `x' = y + (h/2) M G(y)ᵀ a` (`AtY`, from
    /// the values the caller checked fresh). One pass over `G`'s entries instead of the
    /// constraint's own `Gᵀa` and `M`; `false` (nothing written) without a usable gram.
    fn gram_force(&mut self, at: Right, a: &[V::Real]) -> bool {
        let (Some(w), Some(gram)) = (self.inverse_mass, self.gram.as_deref_mut()) else {
            return false;
        };
        let (from, to) = match at {
            Right::AtX => {
                if !gram.fill(self.system.constraint(), self.x, false, w) {
                    return false;
                }
                (self.x, &mut *self.y)
            }
            Right::AtY => (&*self.y, &mut *self.x_next),
        };
        to.copy_from(from);
        let half = self.h * V::Real::lit(0.5);
        gram.transpose_add(at, a, -half, &mut to.as_mut_slice()[w.len()..]);
        true
    }

    /// `x' = y + h/2 M(x') G(x')ᵀ b` by fixed-point iteration from the explicit guess.
    /// The map contracts with factor `O(h |b|)`; iterate until the change is at round-off.
    fn end_point_implicit(&mut self, b: &[V::Real]) -> Result<(), StepError> {
        let half = self.h * V::Real::lit(0.5);
        self.end_point_explicit(b);
        let tol = self.fixed_point_tol;
        let mut change = V::Real::infinity();
        for _ in 0..self.fixed_point_max_iterations {
            self.system
                .constraint_force(&*self.x_next, b, self.t1, self.t2);
            change = V::Real::zero();
            for ((x_next, &y), &d) in self
                .x_next
                .as_mut_slice()
                .iter_mut()
                .zip(self.y.as_slice())
                .zip(self.t2.as_slice())
            {
                let new = y + half * d;
                change = change.max((new - *x_next).abs());
                *x_next = new;
            }
            if change <= tol * (V::Real::one() + ops::norm_inf(self.x_next.as_slice())) {
                return Ok(());
            }
            if !change.is_finite() {
                break;
            }
        }
        Err(StepError::FixedPointNotConverged {
            iterations: self.fixed_point_max_iterations,
            change: change.to_f64_lossy(),
        })
    }

    fn hidden(&mut self, out: &mut [V::Real]) {
        self.system
            .hidden_constraint(&*self.x_next, self.t1, self.t2, out);
    }
}

impl<V, F, Sys> NonlinearProblem<V::Real> for Stage<'_, V, F, Sys>
where
    V: Vector,
    F: Flow<V>,
    Sys: Model<V>,
{
    type Error = StepError;

    fn dim(&self) -> usize {
        if self.mode == Mode::Coupled {
            2 * self.m
        } else {
            self.m
        }
    }

    /// `∂g/∂λ_k ≈ (h²/2) G M ∇²H M Gᵀ` in the degenerate case (the `O(h)` term is
    /// `(h/2) G M Gᵀ = 0`); the other systems scale like `h` (the coupled one after dividing
    /// its `g` rows by `h`).
    fn jacobian_scale(&self) -> V::Real {
        match self.mode {
            Mode::LambdaK => self.h * self.h,
            _ => self.h,
        }
    }

    /// Closed-form Jacobian groups of the decoupled systems, from the model's Hessian
    /// ([`Hamiltonian::hessian_apply`]); `e` is the indicator of `cols`:
    /// - `λ_k`: `J e = G(y) DΦ_h (h/2) M Gᵀ e` with `DΦ_h ≈ I + h M ∇²H` —
    ///   `(h/2) G(y) M Gᵀ e + (h²/2) G(y) M ∇²H M Gᵀ e` (`M`, `∇²H` at the step's start `x`),
    ///   exact when the inner flow's tangent map is `I + h M ∇²H` with a constant Hessian (a
    ///   kick–drift–kick with a potential linear in each particle, such as gravity), `O(h²)`
    ///   relative otherwise;
    /// - `λ_{k+1}`: `J e = (h/2) G(x') M(x') ∇²H(x') M(y) G(y)ᵀ e`, exact in the decoupled case.
    fn jacobian_group(&mut self, z: &[V::Real], cols: &[usize], out: &mut [V::Real]) -> bool {
        let (m, h) = (self.m, self.h);
        if self.hess_v.len() < self.x.len() || self.indicator.len() < m {
            return false; // no scratch: the flow was built without a pattern
        }
        let half = h * V::Real::lit(0.5);
        let mode = self.mode;
        // The points the Jacobian is taken at: y for λ_k (cached per λ_k), x' for λ_{k+1}
        // (recomputed, one pass).
        match mode {
            Mode::LambdaK => {
                if self.compute_y(z).is_err() {
                    return false;
                }
            }
            // Mechanical form: `G(x') = G(y)`, and no Hessian at `x'` is needed.
            Mode::LambdaK1 if self.inverse_mass.is_some() => {}
            Mode::LambdaK1 => self.end_point_explicit(z),
            Mode::Coupled | Mode::Symmetric => return false,
        }
        let e = &mut self.indicator.as_mut_slice()[..m];
        ops::fill_zero(e);
        for &j in cols {
            e[j] = V::Real::one();
        }
        let e = &self.indicator.as_slice()[..m];
        let (sys, x) = (self.system, self.x);
        if mode == Mode::LambdaK {
            sys.constraint_force(x, e, self.t1, self.t2);
            // An inner flow that applies its own tangent map (of the lead at `y`'s
            // evaluation, the last one) gives the exact group `G(y) DΦ_h (h/2) M Gᵀ e`.
            self.tangent = self.inner.lead_tangent_apply(&*self.t2, self.hess_v);
            if !self.tangent {
                // With dissipation the inner flow's tangent is not `I + h M ∇²H`: the exact
                // damping flow moves positions by `(1 − e^{−ch/m}) p / c`, not `h p / m`, so
                // the closed form is off by a factor up to `c h / m` and Newton would crawl.
                // Differences of the flow itself (one residual per colour group) are exact to
                // `fd_step` instead.
                if sys.structure().is_dissipative()
                    || !sys
                        .hamiltonian()
                        .hessian_apply(self.x, &*self.t2, self.hess_v)
                {
                    return false;
                }
                sys.structure().apply(self.x, &*self.hess_v, self.m_hess_v);
                ops::add_scaled(
                    self.hess_v.as_mut_slice(),
                    self.t2.as_slice(),
                    h,
                    self.m_hess_v.as_slice(),
                );
            }
            sys.constraint()
                .jacobian_apply(&*self.y, &*self.hess_v, out);
        } else if let Some(w) = self.inverse_mass {
            // ∂φ/∂λ_{k+1} e = (h/2) G(y) W⁻¹ (M Gᵀ e)_p: the force's momentum part, scaled by
            // W⁻¹ into the position slots (G reads positions alone).
            sys.constraint_force(&*self.y, e, self.t1, self.t2);
            let nq = w.len();
            let (q, p) = self.m_hess_v.as_mut_slice().split_at_mut(nq);
            for ((qi, &wi), &fi) in q.iter_mut().zip(w).zip(&self.t2.as_slice()[nq..]) {
                *qi = wi * fi;
            }
            ops::fill_zero(p);
            sys.constraint()
                .jacobian_apply(&*self.y, &*self.m_hess_v, out);
        } else {
            sys.constraint_force(&*self.y, e, self.t1, self.t2);
            if !sys
                .hamiltonian()
                .hessian_apply(&*self.x_next, &*self.t2, self.hess_v)
            {
                return false;
            }
            sys.structure()
                .apply(&*self.x_next, &*self.hess_v, self.m_hess_v);
            sys.constraint()
                .jacobian_apply(&*self.x_next, &*self.m_hess_v, out);
        }
        out.iter_mut().for_each(|v| *v = *v * half);
        true
    }

    /// The decoupled systems' Jacobians of a model of mechanical form, summed from `G`'s
    /// entries ([`Gram`]): `−(h/2) G(y) W⁻¹ G(y)ᵀ` for `λ_{k+1}` (exact: the system is affine),
    /// `−(h²/2) G(y) W⁻¹ G(x)ᵀ` for `λ_k` when the lead drifts freely from a momentum change
    /// (exact then; the grouped products otherwise).
    fn jacobian_assemble(&mut self, z: &[V::Real], sink: &mut dyn Sink<V::Real>) -> bool {
        let (Some(w), true) = (self.inverse_mass, self.gram.is_some()) else {
            return false;
        };
        let (h, half) = (self.h, self.h * V::Real::lit(0.5));
        let constraint = self.system.constraint();
        let right = match self.mode {
            Mode::LambdaK => {
                if self.compute_y(z).is_err() || !self.impulse_drifts_freely(w) {
                    return false;
                }
                Right::AtX
            }
            Mode::LambdaK1 => Right::AtY,
            Mode::Coupled | Mode::Symmetric => return false,
        };
        let Some(gram) = self.gram.as_deref_mut() else {
            return false;
        };
        if !gram.fill(constraint, &*self.y, true, w)
            || (right == Right::AtX && !gram.fill(constraint, self.x, false, w))
        {
            return false;
        }
        let scale = match right {
            Right::AtX => -(half * h),
            Right::AtY => -half,
        };
        gram.add_to(scale, right, sink);
        true
    }

    /// `λ_k`: `D²g(y)[a, a]` with `a = DL_h (h/2) M Gᵀ e` from the group just formed — the
    /// exact second derivative along `e` when the lead is affine along the half-step's
    /// (momentum) directions ([`Flow::lead_is_affine_in_momenta`]), so that `y` is affine in
    /// `λ_k`; the constraint's Hessian form ([`HolonomicConstraint::hessian_form`]) at `y`,
    /// constant for quadratic constraints. The other systems have none.
    fn curvature_group(&mut self, _z: &[V::Real], _cols: &[usize], out: &mut [V::Real]) -> bool {
        if self.mode != Mode::LambdaK || !self.tangent || !self.inner.lead_is_affine_in_momenta() {
            return false;
        }
        if !self
            .system
            .constraint()
            .hessian_form(&*self.y, &*self.hess_v, &*self.hess_v, out)
        {
            return false;
        }
        let quarter = self.h * self.h * V::Real::lit(0.25);
        out.iter_mut().for_each(|v| *v = *v * quarter);
        true
    }

    fn residual(&mut self, z: &[V::Real], f: &mut [V::Real]) -> Result<(), StepError> {
        let m = self.m;
        match self.mode {
            Mode::LambdaK => {
                self.compute_y(z)?;
                self.system.constraint().residual(&*self.y, f);
                for (g, &v) in self.g_y.as_mut_slice().iter_mut().zip(&*f) {
                    *g = v;
                }
            }
            Mode::LambdaK1 => {
                if !self.hidden_from_gram(z, f) {
                    self.end_point_explicit(z);
                    self.hidden(f);
                }
            }
            Mode::Coupled => {
                self.compute_y(&z[..m])?;
                self.end_point_implicit(&z[m..])?;
                let (fg, fp) = f.split_at_mut(m);
                self.system.constraint().residual(&*self.x_next, fg);
                // g-rows of the Jacobian scale like h², φ-rows like h: g/h puts every row on the
                // scale h that `jacobian_scale` reports (and asks |g| ≤ |h| ftol).
                let inv_h = V::Real::one() / self.h;
                fg.iter_mut().for_each(|v| *v = *v * inv_h);
                self.hidden(fp);
            }
            Mode::Symmetric => {
                self.compute_y(z)?;
                self.end_point_implicit(z)?;
                self.system.constraint().residual(&*self.x_next, f);
            }
        }
        Ok(())
    }
}
