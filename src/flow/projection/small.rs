//! The small decoupled path: full Newton on stack arrays ([`SmallNewton`](crate::nonlinear::SmallNewton)) with closed-form
//! Jacobians for a few constraints, one problem type per multiplier system — [`FirstHalf`]
//! (`λ_k` from `g = 0`) and [`SecondHalf`] (`λ_{k+1}` from `φ = 0`, also the hidden-constraint
//! projection of the constrained discrete gradient).

use crate::error::NewtonError;
use crate::error::StepError;
use crate::flow::{Flow, Ledger};
use crate::nonlinear::{NewtonOptions, NonlinearProblem, SMALL_MAX, SmallNewton, SolveReport};
use crate::system::Model;
use crate::system::{Hamiltonian, HolonomicConstraint, StructureMatrix, half_step_keeps_jacobian};
use crate::vector::{Vector, ops};
use num_traits::Zero;

/// The decoupled scheme for a few constraints (`m ≤` [`SMALL_MAX`], dense `G`) and a
/// Hamiltonian with a Hessian ([`Hamiltonian::hessian_apply`]): each multiplier system is
/// solved by full Newton on stack arrays ([`SmallNewton`](crate::nonlinear::SmallNewton)) with closed-form Jacobians, and the
/// half-step directions `M Gᵀ e_j` are formed once per solve, so that a residual evaluation
/// is an axpy per multiplier plus the model's own arithmetic.
#[derive(Debug, Clone)]
pub(super) struct SmallPath<V: Vector> {
    pub(super) newton_k: SmallNewton<V::Real>,
    pub(super) newton_k1: SmallNewton<V::Real>,
    /// The half-step directions `d_j = (h/2) M Gᵀ e_j` at the half-step's base point (`x_k`
    /// for the first half-step, `y` for the second).
    pub(super) d: Vec<V>,
    /// `w_j = d_j + h M ∇²H d_j` at `x_k`.
    pub(super) w: Vec<V>,
    /// `g(y)` at the solution of the `λ_k` system (for the decoupling guard).
    pub(super) g_y: [V::Real; SMALL_MAX],
    /// `φ(y + (h/2) Σ λ_j e_j)` is affine in `λ_{k+1}`: quadratic `H`, constant `M`, and `G`
    /// unchanged along the second half-step (probed at `x0`). Solved by one linear solve.
    pub(super) affine_k1: bool,
    /// The `λ_k` solve offers its second derivatives (an affine lead, quadratic constraints):
    /// while the last solve needed them — it took the quadratic model's root, or Newton took
    /// two iterations. At small steps Newton's first step converges, and forming the second
    /// derivatives would only add their cost.
    pub(super) quadratic: bool,
}

impl<V: Vector> SmallPath<V> {
    /// `Some` when the model qualifies at `x0`: at most [`SMALL_MAX`] constraints and a
    /// Hamiltonian that answers [`Hamiltonian::hessian_apply`].
    pub(super) fn try_new<Sys>(
        system: &Sys,
        x0: &V,
        options: NewtonOptions<V::Real>,
    ) -> Option<Self>
    where
        Sys: Model<V>,
    {
        let m = system.constraint().dim();
        let newton_k = SmallNewton::new(m, options)?;
        let newton_k1 = SmallNewton::new(m, options)?;
        let mut out = x0.zeros_like();
        if !system.hamiltonian().hessian_apply(x0, x0, &mut out) {
            return None;
        }
        let affine_k1 = second_half_is_affine(system, x0);
        Some(Self {
            newton_k,
            newton_k1,
            d: vec![x0.zeros_like(); m],
            w: vec![x0.zeros_like(); m],
            g_y: [V::Real::zero(); SMALL_MAX],
            affine_k1,
            quadratic: true,
        })
    }
}

/// `φ(y + (h/2) Σ λ_j e_j)` is affine in `λ_{k+1}`: a quadratic `H` with a Hessian, a constant
/// `M`, and `G` unchanged along the second half-step (probed at `x0`).
pub(super) fn second_half_is_affine<V, Sys>(system: &Sys, x0: &V) -> bool
where
    V: Vector,
    Sys: Model<V>,
{
    let mut out = x0.zeros_like();
    system.hamiltonian().is_quadratic()
        && system.structure().is_constant()
        && system.hamiltonian().hessian_apply(x0, x0, &mut out)
        && half_step_keeps_jacobian(system, x0)
}

/// `&mut v[..K]` as an array; `v` has at least `K` entries (the small path sizes its vectors
/// to `m` and dispatches on `K = m`).
#[inline(always)]
pub(crate) fn fixed_mut<T, const K: usize>(v: &mut [T]) -> &mut [T; K] {
    match <&mut [T; K]>::try_from(&mut v[..K]) {
        Ok(a) => a,
        Err(_) => unreachable!("a slice of length K converts to [T; K]"),
    }
}

/// `&v[..K]` as an array; `v` has at least `K` entries (see [`fixed_mut`]).
#[inline(always)]
pub(crate) fn fixed<T, const K: usize>(v: &[T]) -> &[T; K] {
    match <&[T; K]>::try_from(&v[..K]) {
        Ok(a) => a,
        Err(_) => unreachable!("a slice of length K converts to [T; K]"),
    }
}

/// `out = x + (h/2) Σ_j z_j d_j`.
#[inline(always)]
pub(crate) fn half_step<V: Vector, const K: usize>(
    out: &mut V,
    x: &V,
    half: V::Real,
    z: &[V::Real],
    d: &[V; K],
) {
    let scaled: [V::Real; K] = core::array::from_fn(|j| half * z[j]);
    shift(out, x, &scaled, d);
}

/// `out = x + Σ_j z_j d_j`.
#[inline(always)]
pub(crate) fn shift<V: Vector, const K: usize>(out: &mut V, x: &V, z: &[V::Real], d: &[V; K]) {
    ops::add_scaled(out.as_mut_slice(), x.as_slice(), z[0], d[0].as_slice());
    for j in 1..K {
        ops::axpy(out.as_mut_slice(), z[j], d[j].as_slice());
    }
}

/// `λ_k ↦ g(L_h(x + Σ λ_j d_j))`, `d_j = (h/2) M Gᵀ e_j`, with the columns `G(y) DL_h d_j`
/// (small path); `L_h` is the inner flow's lead ([`Flow::step_lead`]: all of it, or all but a
/// trailing kick, which cannot change `g`).
pub(super) struct FirstHalf<'a, V: Vector, F, Sys, const K: usize> {
    pub(crate) h: V::Real,
    pub(crate) x: &'a V,
    pub(crate) inner: &'a mut F,
    pub(crate) ledger_in: Ledger<V::Real>,
    pub(crate) ledger_y: &'a mut Ledger<V::Real>,
    pub(crate) system: &'a Sys,
    /// The half-step directions `(h/2) M Gᵀ e_j` at `x`.
    pub(super) d: &'a [V; K],
    /// `w_j = d_j + h M ∇²H d_j` at `x`, the columns' directions when the inner flow has no
    /// tangent map: formed on the first column asked for (`w_state`), never when it has one.
    pub(super) w: &'a mut [V; K],
    pub(super) w_state: Columns,
    pub(crate) y: &'a mut V,
    /// `g(y)` of the last evaluation.
    pub(crate) g: &'a mut [V::Real; K],
    /// Scratch for the inner flow's tangent map and for `w`.
    pub(crate) scratch: &'a mut V,
    pub(crate) scratch2: &'a mut V,
    /// Offer the second derivatives ([`SmallPath::quadratic`]).
    pub(super) quadratic: bool,
}

/// Whether [`FirstHalf`]'s approximate column directions `w_j` are formed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Columns {
    /// Not yet.
    Unformed,
    /// `w_j` holds the inner flow's tangents `a_j = DL_h d_j` (the exact columns' directions).
    Tangents,
    /// Formed: `w_j = d_j + h M ∇²H d_j`.
    Formed,
    /// The Hamiltonian has no Hessian product: no closed-form column.
    Unavailable,
}

impl<V, F, Sys, const K: usize> FirstHalf<'_, V, F, Sys, K>
where
    V: Vector,
    Sys: Model<V>,
{
    /// Forms `w_j = d_j + h M(x) ∇²H(x) d_j` (`Unavailable` without a Hessian product).
    #[inline(always)]
    fn form_columns(&mut self) {
        let (sys, h) = (self.system, self.h);
        for (dj, wj) in self.d.iter().zip(self.w.iter_mut()) {
            if !sys.hamiltonian().hessian_apply(self.x, dj, self.scratch) {
                self.w_state = Columns::Unavailable;
                return;
            }
            sys.structure().apply(self.x, self.scratch, self.scratch2);
            let (wj, dj, t2) = (wj.as_mut_slice(), dj.as_slice(), self.scratch2.as_slice());
            for ((o, &dv), &tv) in wj.iter_mut().zip(dj).zip(t2) {
                *o = dv + h * tv;
            }
        }
        self.w_state = Columns::Formed;
    }
}

impl<V, F, Sys, const K: usize> NonlinearProblem<V::Real> for FirstHalf<'_, V, F, Sys, K>
where
    V: Vector,
    F: Flow<V>,
    Sys: Model<V>,
{
    type Error = StepError;

    fn dim(&self) -> usize {
        K
    }
    fn jacobian_scale(&self) -> V::Real {
        self.h * self.h
    }
    #[inline(always)]
    fn residual(&mut self, z: &[V::Real], f: &mut [V::Real]) -> Result<(), StepError> {
        let constraint = self.system.constraint();
        if V::CLONE_IS_COPY {
            // A stack state: work on a local copy the compiler can keep in registers through
            // the half-step, the inner flow and the constraint, and store it once.
            let mut y = self.x.clone();
            shift(&mut y, self.x, z, self.d);
            let mut ledger = self.ledger_in;
            self.inner.step_lead(&mut ledger, self.h, &mut y)?;
            *self.ledger_y = ledger;
            constraint.residual(&y, f);
            *self.y = y;
        } else {
            shift(self.y, self.x, z, self.d);
            let mut ledger = self.ledger_in;
            self.inner.step_lead(&mut ledger, self.h, self.y)?;
            *self.ledger_y = ledger;
            constraint.residual(&*self.y, f);
        }
        for (g, &v) in self.g.iter_mut().zip(&*f) {
            *g = v;
        }
        Ok(())
    }
    /// `y ← y + Σ dz_j a_j` with the exact columns' directions `a_j = DL_h d_j` and `g` there:
    /// `L_h(x + Σ z_j d_j)` without running the inner flow, when its lead is affine and leaves
    /// the ledger as it is whatever the state ([`Flow::lead_ledger_is_constant`]).
    #[inline(always)]
    fn residual_after_shift(
        &mut self,
        _z: &[V::Real],
        dz: &[V::Real],
        f: &mut [V::Real],
    ) -> Result<bool, StepError> {
        if self.w_state != Columns::Tangents
            || !self.inner.lead_is_affine()
            || !self.inner.lead_ledger_is_constant()
        {
            return Ok(false);
        }
        let y = self.y.as_mut_slice();
        for (j, wj) in self.w.iter().enumerate() {
            ops::axpy(y, dz[j], wj.as_slice());
        }
        self.system.constraint().residual(&*self.y, f);
        for (g, &v) in self.g.iter_mut().zip(&*f) {
            *g = v;
        }
        Ok(true)
    }
    /// `∂g(y)/∂λ_j = G(y) DL_h d_j`: exact when the inner flow applies its own tangent map
    /// ([`Flow::lead_tangent_apply`], at the point of the last evaluation). Otherwise
    /// `DL_h ≈ I + h M ∇²H` at `x`: exact for a drift, or a kick–drift–kick with a potential
    /// linear in the constrained coordinates, `O(h²)` relative otherwise.
    #[inline(always)]
    fn jacobian_column(&mut self, _z: &[V::Real], j: usize, out: &mut [V::Real]) -> bool {
        if matches!(self.w_state, Columns::Unformed | Columns::Tangents) {
            // The inner flow's tangent `a_j = DL_h d_j`, kept in `w_j` (the second derivatives
            // of an affine lead read it); without one, the approximate directions.
            if self.inner.lead_tangent_apply(&self.d[j], &mut self.w[j]) {
                self.w_state = Columns::Tangents;
                self.system
                    .constraint()
                    .jacobian_apply(&*self.y, &self.w[j], out);
                return true;
            }
            self.form_columns();
        }
        if self.w_state == Columns::Unavailable {
            return false;
        }
        self.system
            .constraint()
            .jacobian_apply(&*self.y, &self.w[j], out);
        true
    }
    /// `∂²g_i/∂λ_j∂λ_k = a_jᵀ ∇²g_i a_k` with `a_j = DL_h d_j`: exact and constant when the
    /// lead is affine (`y` is affine in `λ`) and `g` quadratic (its Hessians constant).
    #[inline(always)]
    fn second_derivative(
        &mut self,
        _z: &[V::Real],
        j: usize,
        k: usize,
        out: &mut [V::Real],
    ) -> bool {
        self.quadratic
            && self.w_state == Columns::Tangents
            && self.inner.lead_is_affine()
            && self
                .system
                .constraint()
                .hessian_form(&*self.y, &self.w[j], &self.w[k], out)
    }
}

/// `λ_{k+1} ↦ φ(y + Σ λ_j d_j)`, `d_j = (h/2) M Gᵀ(y) e_j`, with exact columns (small path).
///
/// At `λ = 0` the residual is `φ(y)` itself: no shift along `d` (whose `y + 0 · d` the
/// compiler must compute), two operations less on the latency chain of the affine solve,
/// which starts there.
pub(crate) struct SecondHalf<'a, V: Vector, Sys, const K: usize> {
    pub(crate) h: V::Real,
    pub(crate) y: &'a V,
    pub(crate) system: &'a Sys,
    /// The half-step directions `(h/2) M Gᵀ(y) e_j`.
    pub(crate) d: &'a [V; K],
    pub(crate) x_next: &'a mut V,
    pub(crate) t1: &'a mut V,
    pub(crate) t2: &'a mut V,
}

impl<V, Sys, const K: usize> NonlinearProblem<V::Real> for SecondHalf<'_, V, Sys, K>
where
    V: Vector,
    Sys: Model<V>,
{
    type Error = StepError;

    fn dim(&self) -> usize {
        K
    }
    fn jacobian_scale(&self) -> V::Real {
        self.h
    }
    #[inline(always)]
    fn residual(&mut self, z: &[V::Real], f: &mut [V::Real]) -> Result<(), StepError> {
        let at_y = z.iter().all(|v| v.is_zero());
        if V::CLONE_IS_COPY {
            // Stack states: local copies the compiler can keep in registers (see FirstHalf).
            let (mut x_next, mut t1, mut t2) = (self.y.clone(), self.y.clone(), self.y.clone());
            if !at_y {
                shift(&mut x_next, self.y, z, self.d);
            }
            self.system.hidden_constraint(&x_next, &mut t1, &mut t2, f);
            *self.x_next = x_next;
        } else {
            if at_y {
                self.x_next.copy_from(self.y);
            } else {
                shift(self.x_next, self.y, z, self.d);
            }
            self.system
                .hidden_constraint(&*self.x_next, self.t1, self.t2, f);
        }
        Ok(())
    }
    /// `∂φ(x')/∂λ_j = G(x') M(x') ∇²H(x') d_j`: exact in the decoupled case, where `G` and
    /// `M Gᵀ` do not change along the second half-step.
    #[inline(always)]
    fn jacobian_column(&mut self, _z: &[V::Real], j: usize, out: &mut [V::Real]) -> bool {
        let sys = self.system;
        // A model that knows it along momentum-only directions (a scene: `G_q W⁻¹ d_p`).
        if sys
            .constraint()
            .hidden_derivative_direct(&*self.x_next, &self.d[j], out)
        {
            return true;
        }
        if !sys
            .hamiltonian()
            .hessian_apply(&*self.x_next, &self.d[j], self.t1)
        {
            return false;
        }
        sys.structure().apply(&*self.x_next, &*self.t1, self.t2);
        sys.constraint()
            .jacobian_apply(&*self.x_next, &*self.t2, out);
        true
    }
}

/// Solves the `λ_{k+1}` system `problem` for `z` (the warm start in, the solution out): by one
/// linear solve from zero when `φ` is affine in `λ_{k+1}` (the closed form; the warm start is
/// not read) — forming `x_{k+1}` at the solution, where that solve does not evaluate — and by
/// full Newton otherwise (`x_{k+1}` from its last evaluation).
#[inline(always)]
pub(crate) fn solve_second_half<V, Sys, const K: usize>(
    newton: &SmallNewton<V::Real>,
    affine: bool,
    problem: &mut SecondHalf<'_, V, Sys, K>,
    z: &mut [V::Real; K],
) -> Result<SolveReport<V::Real>, NewtonError<StepError>>
where
    V: Vector,
    Sys: Model<V>,
{
    if affine {
        // From zero: the closed form `λ_{k+1} = −J⁻¹ φ(y)`, any start giving the same root.
        z.iter_mut().for_each(|v| *v = V::Real::zero());
        let r = newton.solve_affine_fixed(problem, z);
        shift(problem.x_next, problem.y, &*z, problem.d);
        r
    } else {
        newton.solve_fixed(problem, z)
    }
}
