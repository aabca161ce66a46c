//! The discrete-gradient method with holonomic constraints (Gonzalez 1999).

use super::implicit::{GonzalezRule, GradientRule, noise_image};
use super::projection::{SecondHalf, fixed_mut, solve_second_half};
use super::{Flow, FlowStats, ProjectionOptions};
use crate::error::{NewtonError, SetupError, StepError};
use crate::nonlinear::{
    Newton, NewtonOptions, NonlinearProblem, NonlinearSolver, SMALL_MAX, SmallNewton, SolveReport,
};
use crate::real::Real;
use crate::system::{
    Case, Hamiltonian, HolonomicConstraint, StructureMatrix, System, check_initial_state,
    half_step_keeps_jacobian,
};
use crate::vector::{Vector, ops};
use num_traits::{Float as _, One, Zero};

/// The energy bookkeeping of the last step of a [`ConstrainedDiscreteGradient`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EnergyBalance<T> {
    /// `H(x_k)`.
    pub before: T,
    /// `H(x')` after the discrete-gradient step, before the hidden-constraint projection.
    pub after_step: T,
    /// `H(x_{k+1})`, after the projection (equal to `after_step` without one).
    pub after: T,
    /// `h F̄ᵀ M(x̄) F̄`, `F̄ = ∇̄H + ∇̄gᵀλ`: the energy the step supplies. The discrete-gradient
    /// identity is `after_step − before = supplied` (to round-off): `≤ 0` when `M + Mᵀ ⪯ 0`,
    /// `0` when `M` is skew. The constraint force does no work.
    pub supplied: T,
}

/// The discrete-gradient method for the constrained system `x' = M(x)(∇H + Gᵀλ)`, `g(x) = 0`
/// (Gonzalez, J. Nonlinear Sci. 9, 1999; Gonzalez, J. Nonlinear Sci. 6, 1996):
///
/// ```text
/// x_{k+1} = x_k + h M(x̄) (∇̄H(x_k, x_{k+1}) + ∇̄g(x_k, x_{k+1})ᵀ λ),     g(x_{k+1}) = 0,
/// ```
///
/// with Gonzalez's midpoint discrete gradient `∇̄` (see [`DiscreteGradient`](super::DiscreteGradient))
/// applied to `H` and to each constraint `gᵢ`. Since `∇̄gᵢ · Δ = gᵢ(x_{k+1}) − gᵢ(x_k) = 0`, the
/// constraint force does no work, and with `F̄ = ∇̄H + ∇̄gᵀλ`
///
/// ```text
/// H(x_{k+1}) − H(x_k) = ∇̄H · Δ = F̄ · Δ = h F̄ᵀ M(x̄) F̄
/// ```
///
/// holds to round-off for any `M`: energy is conserved when `M` is skew and never increases when
/// `M + Mᵀ ⪯ 0` ([`EnergyBalance`], [`energy_balance`](Self::energy_balance)). Order 2.
///
/// **Hidden constraint.** The step enforces `g = 0` but not the hidden constraint
/// `φ = G M ∇H = 0` of the degenerate (mechanical) case, which it keeps only to `O(h²)`. By
/// default each step is therefore followed by the projection `x ← x + M(x) G(x)ᵀ ν` with
/// `φ(x) = 0` (the direction of the projection half-steps of Zhang & Deng). For a mechanical
/// system (`g` depends on positions only, `H` quadratic in the momenta, `R` acting on momenta)
/// this changes only momenta, keeps `g = 0` exactly, and removes the kinetic energy of the
/// constraint-violating velocity: it never increases `H`. The step is then not symmetric.
/// [`without_hidden_projection`](Self::without_hidden_projection) turns it off (symmetric step,
/// `|φ| = O(h²)`). In the non-degenerate case there is no hidden constraint and no projection.
///
/// Each step solves for `(δ, hλ)` (`n + m` unknowns) by Newton, stored in `W` (heap `faer::Col`
/// by default, since `n + m` exceeds a stack vector's capacity `n`). When the model gives
/// `∇²H` ([`Hamiltonian::hessian_apply`]) and `DM` ([`StructureMatrix::derivative_apply_add`];
/// automatic for a constant `M`) the Newton matrix is assembled in closed form at every
/// iteration (full Newton); otherwise by differences, kept across steps. The hidden-constraint
/// projection of up to four constraints runs on stack arrays with closed-form columns, and is
/// one linear solve when `H` is quadratic and `M` constant. The increment is added with compensated summation. Workspace is
/// allocated at construction; a step allocates nothing; on error the state is unchanged.
pub struct ConstrainedDiscreteGradient<
    V: Vector,
    Ms,
    H,
    C,
    W: Vector<Real = V::Real> = faer::Col<<V as Vector>::Real>,
> {
    system: System<Ms, H, C>,
    newton: Newton<W>,
    hidden: Option<HiddenSolver<V>>,
    /// Unknowns `(δ, ℓ = hλ)`.
    z: W,
    /// The multiplier `λ` of the last step (warm start).
    lambda: Vec<V::Real>,
    nu: Vec<V::Real>,
    g0: Vec<V::Real>,
    g1: Vec<V::Real>,
    gd: Vec<V::Real>,
    start: V,
    xm: V,
    xe: V,
    grad: V,
    f: V,
    tmp: V,
    t2: V,
    comp: V,
    comp_next: V,
    /// Scratch for closed-form Jacobian columns.
    s1: V,
    s2: V,
    em: Vec<V::Real>,
    last: V,
    /// `x'` before the hidden-constraint projection.
    after_step: V,
    last_h: V::Real,
    have_step: bool,
    /// The rounding floor of `h M ∇H` at the step's start (see `IncrementFlow::step`).
    base_noise: V::Real,
    stats: FlowStats,
}

impl<V: Vector, Ms, H, C, W: Vector<Real = V::Real>> core::fmt::Debug
    for ConstrainedDiscreteGradient<V, Ms, H, C, W>
{
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("ConstrainedDiscreteGradient")
            .field("n", &self.start.len())
            .field("m", &self.g0.len())
            .field("hidden_projection", &self.hidden.is_some())
            .field("stats", &self.stats)
            .finish_non_exhaustive()
    }
}

impl<V, Ms, H, C, W> ConstrainedDiscreteGradient<V, Ms, H, C, W>
where
    V: Vector,
    Ms: StructureMatrix<V>,
    H: Hamiltonian<V>,
    C: HolonomicConstraint<V>,
    W: Vector<Real = V::Real>,
{
    /// The constrained discrete-gradient flow of `system` for states shaped like `x0`, which
    /// must satisfy `g(x0) = 0` to `options.manifold_tol`. The case (whether a hidden constraint
    /// exists) comes from `options.case` or the brackets at `x0`; `options.newton` is used for
    /// both Newton solves.
    pub fn try_new(
        system: System<Ms, H, C>,
        x0: &V,
        options: ProjectionOptions<V::Real>,
    ) -> Result<Self, SetupError> {
        // φ(x0) need not vanish: the first hidden-constraint projection restores it.
        let (case, _) = check_initial_state::<V, Ms, H, C, W::Solver>(
            &system,
            x0,
            &options.initial_checks(),
            false,
        )?;
        let (n, m) = (x0.len(), system.constraint.dim());
        let g0 = vec![V::Real::zero(); m];
        let hidden = match case {
            Case::Degenerate => Some(HiddenSolver::new(&system, x0, options.newton)?),
            Case::NonDegenerate => None,
        };
        Ok(Self {
            newton: Newton::new(n + m, options.newton)?,
            hidden,
            z: W::zeros(n + m),
            lambda: vec![V::Real::zero(); m],
            nu: vec![V::Real::zero(); m],
            g1: g0.clone(),
            gd: g0.clone(),
            g0,
            start: x0.zeros_like(),
            xm: x0.zeros_like(),
            xe: x0.zeros_like(),
            grad: x0.zeros_like(),
            f: x0.zeros_like(),
            tmp: x0.zeros_like(),
            t2: x0.zeros_like(),
            comp: x0.zeros_like(),
            comp_next: x0.zeros_like(),
            s1: x0.zeros_like(),
            s2: x0.zeros_like(),
            em: vec![V::Real::zero(); m],
            last: x0.zeros_like(),
            after_step: x0.zeros_like(),
            last_h: V::Real::zero(),
            have_step: false,
            base_noise: V::Real::zero(),
            stats: FlowStats::default(),
            system,
        })
    }

    /// Turns the hidden-constraint projection off: the step is the symmetric Gonzalez step,
    /// `φ` stays `O(h²)`.
    pub fn without_hidden_projection(mut self) -> Self {
        self.hidden = None;
        self
    }

    /// The system.
    pub fn system(&self) -> &System<Ms, H, C> {
        &self.system
    }

    /// The multipliers `λ` of the last step.
    pub fn multipliers(&self) -> &[V::Real] {
        &self.lambda
    }

    /// The energy bookkeeping of the last successful step (`None` before the first), recomputed
    /// from the stored step (costs one residual evaluation and three energies).
    pub fn energy_balance(&mut self) -> Option<EnergyBalance<V::Real>> {
        if !self.have_step {
            return None;
        }
        let h = self.last_h;
        let zs = self.z.as_slice().to_vec();
        let mut out = vec![V::Real::zero(); zs.len()];
        let mut problem = problem!(self, h);
        problem.residual(&zs, &mut out).ok()?;
        // grad = h F̄, f = h M(x̄) F̄.
        let supplied = ops::dot(problem.grad.as_slice(), problem.f.as_slice()) / h;
        let sys = &self.system;
        Some(EnergyBalance {
            before: sys.hamiltonian.energy(&self.start),
            after_step: sys.hamiltonian.energy(&self.after_step),
            after: sys.hamiltonian.energy(&self.last),
            supplied,
        })
    }
}

/// The step's nonlinear problem, borrowing the flow's fields one by one (so that the flow's
/// Newton solvers stay usable alongside).
macro_rules! problem {
    ($s:expr, $h:expr) => {
        Problem {
            h: $h,
            noise: V::Real::zero(),
            base_noise: $s.base_noise,
            x: &$s.start,
            xm: &mut $s.xm,
            xe: &mut $s.xe,
            grad: &mut $s.grad,
            f: &mut $s.f,
            tmp: &mut $s.tmp,
            g0: &$s.g0,
            g1: &mut $s.g1,
            gd: &mut $s.gd,
            s1: &mut $s.s1,
            s2: &mut $s.s2,
            em: &mut $s.em,
            system: &$s.system,
        }
    };
}
use problem;

/// `F(δ, ℓ) = (δ − h M(x̄)(∇̄H + ∇̄gᵀℓ/h),  g(x + δ))`.
struct Problem<'a, V: Vector, Ms, H, C> {
    h: V::Real,
    noise: V::Real,
    base_noise: V::Real,
    x: &'a V,
    xm: &'a mut V,
    xe: &'a mut V,
    grad: &'a mut V,
    f: &'a mut V,
    tmp: &'a mut V,
    g0: &'a [V::Real],
    g1: &'a mut [V::Real],
    gd: &'a mut [V::Real],
    s1: &'a mut V,
    s2: &'a mut V,
    em: &'a mut [V::Real],
    system: &'a System<Ms, H, C>,
}

impl<V, Ms, H, C> Problem<'_, V, Ms, H, C>
where
    V: Vector,
    Ms: StructureMatrix<V>,
    H: Hamiltonian<V>,
    C: HolonomicConstraint<V>,
{
    /// `|δ|²` above which Gonzalez's correction term is evaluated (below, it is round-off).
    fn corrected(&self, delta: &[V::Real]) -> Option<V::Real> {
        let d2 = ops::dot(delta, delta);
        let x2 = ops::dot(self.x.as_slice(), self.x.as_slice());
        (d2 > V::Real::epsilon().powf(V::Real::lit(2.0 / 3.0)) * (V::Real::one() + x2))
            .then_some(d2)
    }
}

impl<V, Ms, H, C> NonlinearProblem<V::Real> for Problem<'_, V, Ms, H, C>
where
    V: Vector,
    Ms: StructureMatrix<V>,
    H: Hamiltonian<V>,
    C: HolonomicConstraint<V>,
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
            &sys.hamiltonian,
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
        sys.constraint.residual(self.xe, self.g1);
        sys.constraint
            .jacobian_transpose_apply_add(self.xm, ell, V::Real::one(), self.grad);
        // The rounding noise of grad along δ/|δ|: the energy's correction (scaled by h), and
        // the constraints' below.
        let mut noise = self.h.abs() * noise;
        if let Some(d2) = self.corrected(delta) {
            for (t, &d) in self.tmp.as_mut_slice().iter_mut().zip(delta) {
                *t = d;
            }
            sys.constraint.jacobian_apply(self.xm, self.tmp, self.gd);
            // G(x̄) x̄ bounds the size of the terms each gᵢ is formed from (|rᵢ|² for a rod),
            // so each difference gᵢ(x') − gᵢ(x) − (G δ)ᵢ rounds at about ε times that.
            sys.constraint.jacobian_apply(self.xm, self.xm, self.em);
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
        sys.structure.apply(self.xm, self.grad, self.f);
        self.noise = noise_image(
            &sys.structure,
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
            if !sys.hamiltonian.hessian_apply(self.xm, self.s1, self.s2) {
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
            sys.constraint
                .jacobian_transpose_apply_add(self.tmp, ell, inv, self.s2);
            self.tmp.as_mut_slice()[j] = xj - eps;
            sys.constraint
                .jacobian_transpose_apply_add(self.tmp, ell, -inv, self.s2);
            sys.structure.apply(self.xm, self.s2, self.tmp);
            if !sys.structure.derivative_apply_add(
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
            sys.constraint.jacobian_apply(self.tmp, self.s1, og);
        } else {
            let i = j - n;
            ops::fill_zero(self.em);
            self.em[i] = V::Real::one();
            ops::fill_zero(self.s2.as_mut_slice());
            sys.constraint
                .jacobian_transpose_apply_add(self.xm, self.em, V::Real::one(), self.s2);
            if let Some(d2) = self.corrected(delta) {
                // cᵢ δ, cᵢ = (gᵢ(x') − gᵢ(x) − (G(x̄) δ)ᵢ) / |δ|².
                self.s1.as_mut_slice().copy_from_slice(delta);
                sys.constraint.jacobian_apply(self.xm, self.s1, self.gd);
                let c = (self.g1[i] - self.g0[i] - self.gd[i]) / d2;
                ops::axpy(self.s2.as_mut_slice(), c, delta);
            }
            sys.structure.apply(self.xm, self.s2, self.tmp);
            for (o, &t) in od.iter_mut().zip(self.tmp.as_slice()) {
                *o = -t;
            }
            ops::fill_zero(og);
        }
        true
    }
}

/// `F(ν) = φ(x' + M(x') G(x')ᵀ ν)`: the hidden-constraint projection (also the `λ_{k+1}`
/// system of [`ProjectedMidpoint`](super::ProjectedMidpoint)'s general path, `ν = (h/2) λ_{k+1}`).
pub(super) struct Hidden<'a, V: Vector, Ms, H, C> {
    pub(super) base: &'a V,
    /// `M(x') G(x')ᵀ` applied to `ν` lands here: `x = base + dir(ν)`.
    pub(super) x: &'a mut V,
    pub(super) t1: &'a mut V,
    pub(super) t2: &'a mut V,
    pub(super) system: &'a System<Ms, H, C>,
    /// Scratch for closed-form Jacobian columns (a state and `m` multipliers), for a caller
    /// whose case makes them exact (see `jacobian_column`); `None`: differences.
    pub(super) columns: Option<(&'a mut V, &'a mut [V::Real])>,
}

impl<V, Ms, H, C> Hidden<'_, V, Ms, H, C>
where
    V: Vector,
    Ms: StructureMatrix<V>,
    H: Hamiltonian<V>,
    C: HolonomicConstraint<V>,
{
    /// `x = base + M(base) G(base)ᵀ ν`.
    pub(super) fn place(&mut self, nu: &[V::Real]) {
        self.system
            .constraint_force(self.base, nu, self.t1, self.t2);
        ops::add_scaled(
            self.x.as_mut_slice(),
            self.base.as_slice(),
            V::Real::one(),
            self.t2.as_slice(),
        );
    }
}

impl<V, Ms, H, C> NonlinearProblem<V::Real> for Hidden<'_, V, Ms, H, C>
where
    V: Vector,
    Ms: StructureMatrix<V>,
    H: Hamiltonian<V>,
    C: HolonomicConstraint<V>,
{
    type Error = StepError;

    fn dim(&self) -> usize {
        self.system.constraint.dim()
    }

    fn residual(&mut self, nu: &[V::Real], out: &mut [V::Real]) -> Result<(), StepError> {
        self.place(nu);
        self.system.hidden_constraint(self.x, self.t1, self.t2, out);
        Ok(())
    }
    /// `∂φ(x)/∂ν_j = G(x) M(x) ∇²H(x) M(x') G(x')ᵀ e_j`: exact in the decoupled case, where
    /// `G` and `M Gᵀ` do not change along the projection (as `SecondHalf`'s columns).
    fn jacobian_column(&mut self, nu: &[V::Real], j: usize, out: &mut [V::Real]) -> bool {
        if self.columns.is_none() {
            return false;
        }
        if j == 0 {
            self.place(nu);
        }
        let Some((scratch, unit)) = self.columns.as_mut() else {
            return false;
        };
        unit.iter_mut().for_each(|u| *u = V::Real::zero());
        unit[j] = V::Real::one();
        let sys = self.system;
        sys.constraint_force(self.base, unit, self.t1, self.t2);
        if !sys.hamiltonian.hessian_apply(&*self.x, &*self.t2, self.t1) {
            return false;
        }
        sys.structure.apply(&*self.x, &*self.t1, scratch);
        sys.constraint.jacobian_apply(&*self.x, scratch, out);
        true
    }
}

/// The solver of the hidden-constraint projection `φ(x' + M Gᵀ ν) = 0`.
enum HiddenSolver<V: Vector> {
    /// `m ≤` [`SMALL_MAX`] and a Hamiltonian with a Hessian: full Newton on stack arrays with
    /// the closed-form columns `G M ∇²H M Gᵀ e_j` ([`SecondHalf`] with `h = 2`), and one
    /// linear solve when the system is affine in `ν` (quadratic `H`, constant `M`, `G`
    /// unchanged along `M Gᵀ`).
    Small {
        newton: SmallNewton<V::Real>,
        /// `M(x') G(x')ᵀ e_j`.
        dirs: Vec<V>,
        affine: bool,
    },
    /// Otherwise: [`Newton`] with a kept difference Jacobian.
    General(Newton<V>),
}

impl<V: Vector> HiddenSolver<V> {
    fn new<Ms, H, C>(
        system: &System<Ms, H, C>,
        x0: &V,
        options: NewtonOptions<V::Real>,
    ) -> Result<Self, SetupError>
    where
        Ms: StructureMatrix<V>,
        H: Hamiltonian<V>,
        C: HolonomicConstraint<V>,
    {
        let m = system.constraint.dim();
        let mut out = x0.zeros_like();
        match SmallNewton::new(m, options) {
            Some(newton) if system.hamiltonian.hessian_apply(x0, x0, &mut out) => {
                Ok(HiddenSolver::Small {
                    newton,
                    dirs: vec![x0.zeros_like(); m],
                    affine: system.hamiltonian.is_quadratic()
                        && system.structure.is_constant()
                        && half_step_keeps_jacobian(system, x0),
                })
            }
            _ => Ok(HiddenSolver::General(Newton::new(m, options)?)),
        }
    }
}

impl<V, Ms, H, C, W> ConstrainedDiscreteGradient<V, Ms, H, C, W>
where
    V: Vector,
    Ms: StructureMatrix<V>,
    H: Hamiltonian<V>,
    C: HolonomicConstraint<V>,
    W: Vector<Real = V::Real>,
{
    fn m(&self) -> usize {
        self.g0.len()
    }

    /// The hidden-constraint projection from `after_step` into `xe` (`nu` holds `ν`). `K = m`
    /// on the small path, `K = 0` on the general one.
    #[inline(always)]
    fn project_hidden<const K: usize>(
        &mut self,
    ) -> Result<SolveReport<V::Real>, NewtonError<StepError>> {
        let Some(hidden) = self.hidden.as_mut() else {
            unreachable!("project_hidden without a hidden projection");
        };
        match hidden {
            HiddenSolver::Small {
                newton,
                dirs,
                affine,
            } if K > 0 => {
                let e: &mut [V; K] = fixed_mut(dirs);
                let mut unit = [V::Real::zero(); K];
                for (j, ej) in e.iter_mut().enumerate() {
                    unit[j] = V::Real::one();
                    self.system
                        .constraint_force(&self.after_step, &unit, &mut self.tmp, ej);
                    unit[j] = V::Real::zero();
                }
                // x = x' + M Gᵀ ν: a half-step of "h = 2".
                let mut problem = SecondHalf {
                    h: V::Real::lit(2.0),
                    y: &self.after_step,
                    system: &self.system,
                    d: e,
                    x_next: &mut self.xe,
                    t1: &mut self.tmp,
                    t2: &mut self.t2,
                };
                let nu: &mut [V::Real; K] = fixed_mut(&mut self.nu);
                solve_second_half(newton, *affine, &mut problem, nu)
            }
            HiddenSolver::Small { .. } => unreachable!("the small hidden solver runs with K = m"),
            HiddenSolver::General(newton) => {
                let mut problem = Hidden {
                    base: &self.after_step,
                    x: &mut self.xe,
                    t1: &mut self.tmp,
                    t2: &mut self.t2,
                    system: &self.system,
                    columns: None,
                };
                let report = newton.solve(&mut problem, &mut self.nu)?;
                problem.place(&self.nu);
                Ok(report)
            }
        }
    }
}

fn newton_error(stage: &'static str, e: NewtonError<StepError>) -> StepError {
    StepError::from_newton(stage, e)
}

impl<V, Ms, H, C, W> Flow<V> for ConstrainedDiscreteGradient<V, Ms, H, C, W>
where
    V: Vector,
    Ms: StructureMatrix<V>,
    H: Hamiltonian<V>,
    C: HolonomicConstraint<V>,
    W: Vector<Real = V::Real>,
{
    fn step(&mut self, h: V::Real, x: &mut V) -> Result<(), StepError> {
        let n = self.start.len();
        if x.len() != n {
            return Err(StepError::StateLength {
                flow: "constrained discrete gradient",
                expected: n,
                got: x.len(),
            });
        }
        if !super::check_step(h, x)? {
            return Ok(());
        }
        // The stored step is overwritten below; report no balance unless this step succeeds.
        self.have_step = false;
        self.start.copy_from(x);
        self.system.constraint.residual(&self.start, &mut self.g0);
        // The rounding floor of h M ∇H itself (a stiff term's gradient rounds at its Hessian
        // times the state's rounding): ε |h M ∇²H(x) x|∞ when the model has a Hessian.
        self.base_noise = V::Real::zero();
        if self
            .system
            .hamiltonian
            .hessian_apply(&self.start, &self.start, &mut self.tmp)
        {
            self.system
                .structure
                .apply(&self.start, &self.tmp, &mut self.f);
            self.base_noise = V::Real::epsilon() * h.abs() * ops::norm_inf(self.f.as_slice());
        }
        // Predictor: δ = M(x)(h ∇H(x) + G(x)ᵀ ℓ), ℓ = h λ_prev.
        {
            let (zd, zl) = self.z.as_mut_slice().split_at_mut(n);
            for (l, &lp) in zl.iter_mut().zip(&self.lambda) {
                *l = h * lp;
            }
            let sys = &self.system;
            sys.hamiltonian.gradient(&self.start, &mut self.grad);
            for g in self.grad.as_mut_slice() {
                *g = *g * h;
            }
            sys.constraint.jacobian_transpose_apply_add(
                &self.start,
                zl,
                V::Real::one(),
                &mut self.grad,
            );
            sys.structure.apply(&self.start, &self.grad, &mut self.f);
            zd.copy_from_slice(self.f.as_slice());
        }
        let solved = {
            let mut problem = problem!(self, h);
            self.newton.solve(&mut problem, self.z.as_mut_slice())
        };
        let report = match solved {
            Ok(report) => report,
            Err(e) => {
                self.newton.invalidate_jacobian();
                return Err(newton_error("constrained discrete gradient", e));
            }
        };
        self.stats.record(&report);
        let delta = &self.z.as_slice()[..n];
        if let Some(component) = ops::first_non_finite(self.z.as_slice()) {
            self.newton.invalidate_jacobian();
            return Err(StepError::NonFinite {
                component: component.min(n - 1),
            });
        }
        // x' = x + δ, compensated (only for the state this flow returned last).
        self.after_step.copy_from(&self.start);
        if self.start.as_slice() != self.last.as_slice() {
            ops::fill_zero(self.comp.as_mut_slice());
        }
        self.comp_next.copy_from(&self.comp);
        ops::add_compensated(
            self.after_step.as_mut_slice(),
            delta,
            self.comp_next.as_mut_slice(),
        );
        // Hidden-constraint projection x'' = x' + M(x') G(x')ᵀ ν, φ(x'') = 0.
        self.last.copy_from(&self.after_step);
        if self.hidden.is_some() {
            ops::fill_zero(&mut self.nu);
            let solved = match self.m() {
                1 => self.project_hidden::<1>(),
                2 => self.project_hidden::<2>(),
                3 => self.project_hidden::<3>(),
                4 => self.project_hidden::<SMALL_MAX>(),
                _ => self.project_hidden::<0>(),
            };
            let report = match solved {
                Ok(r) => r,
                Err(e) => {
                    if let Some(HiddenSolver::General(n)) = self.hidden.as_mut() {
                        n.invalidate_jacobian();
                    }
                    return Err(newton_error("hidden-constraint projection", e));
                }
            };
            self.stats.record(&report);
            self.last.copy_from(&self.xe);
        }
        if let Some(component) = ops::first_non_finite(self.last.as_slice()) {
            self.newton.invalidate_jacobian();
            return Err(StepError::NonFinite { component });
        }
        core::mem::swap(&mut self.comp, &mut self.comp_next);
        for (l, &e) in self.lambda.iter_mut().zip(&self.z.as_slice()[n..]) {
            *l = e / h;
        }
        self.last_h = h;
        self.have_step = true;
        x.copy_from(&self.last);
        Ok(())
    }
    fn order(&self) -> u32 {
        2
    }
    fn is_symmetric(&self) -> bool {
        self.hidden.is_none()
    }
    fn stats(&self) -> FlowStats {
        self.stats
    }
    fn dissipates(&self) -> bool {
        self.system.structure.is_dissipative()
    }
}
