//! Implicit flows for Hamiltonians without a closed-form flow: the implicit midpoint rule and
//! the Gonzalez discrete-gradient method, both `x_{k+1} = x_k + h M(x̄) ∇̄H`, `x̄` the midpoint,
//! differing in the gradient `∇̄H` ([`GradientRule`]).

use super::{Flow, FlowStats};
use crate::error::{SetupError, StepError};
use crate::linalg::LinearSolver;
use crate::nonlinear::{Newton, NewtonOptions, NonlinearProblem, NonlinearSolver};
use crate::real::Real;
use crate::system::{Hamiltonian, StructureMatrix};
use crate::vector::{Vector, ops};
use num_traits::{Float as _, One, Zero};

/// The implicit midpoint rule for `x' = M(x) ∇H(x)` (an [`IncrementFlow`] with [`MidpointRule`]):
///
/// ```text
/// x_{k+1} = x_k + h M(x̄) ∇H(x̄),     x̄ = (x_k + x_{k+1}) / 2.
/// ```
///
/// Symmetric, order 2, and it preserves every quadratic invariant of the flow exactly (up to the
/// Newton tolerance): quadratic Casimirs of `M` such as `|y|²` for Lie–Poisson `so(3)*`, and a
/// quadratic `H` when `M` is skew. Usable wherever a closed-form sub-flow is (as the inner flow
/// of a projection, or inside a composition). GNI §II.1, §IV.2 (Theorem 2.1), §VII.4.
///
/// Each step solves for the increment `δ = x_{k+1} − x_k`, `δ = h M(x + δ/2) ∇H(x + δ/2)`, by
/// [`Newton`] with a forward-difference Jacobian (`n` residual evaluations when it is rebuilt;
/// kept and Broyden-updated across steps otherwise) from the explicit Euler predictor, then
/// polishes `δ` with two fixed-point sweeps (contraction `O(h)`; discarded when they do not
/// contract, as under stiff damping), so that `δ` is accurate to its own round-off rather than
/// to Newton's absolute tolerance. The increment is added with
/// compensated summation (Kahan; GNI §VIII.5): the rounding error of `x + δ` is carried to the
/// next step as long as the caller passes back the state this flow returned. Over 10⁵ steps this
/// keeps quadratic invariants at the 1e-15 level instead of a linear drift of ~ε per step.
/// Workspace is allocated at construction; a step allocates nothing. On error the state is
/// unchanged.
pub type ImplicitMidpoint<V, Ms, H, L = <V as Vector>::Solver> =
    IncrementFlow<V, Ms, H, MidpointRule, L>;

/// The discrete-gradient method with Gonzalez's midpoint discrete gradient:
///
/// ```text
/// x_{k+1} = x_k + h M(x̄) ∇̄H(x_k, x_{k+1}),
/// ∇̄H(x, x') = ∇H(x̄) + (H(x') − H(x) − ∇H(x̄)·Δ) / |Δ|² · Δ,     Δ = x' − x,  x̄ = (x + x')/2.
/// ```
///
/// `∇̄H · Δ = H(x') − H(x)` exactly, so the discrete energy balance
/// `H(x_{k+1}) − H(x_k) = h ∇̄Hᵀ M(x̄) ∇̄H` holds to round-off for any `H`: energy is conserved
/// when `M` is skew and never increases when `M + Mᵀ ⪯ 0`. Symmetric, order 2.
/// O. Gonzalez, J. Nonlinear Sci. 6 (1996); McLachlan, Quispel & Robidoux, Phil. Trans. R. Soc. A
/// 357 (1999).
///
/// The correction is `0/0` as `x' → x`: its numerator is a difference of `O(1)` energies whose
/// rounding error, divided by `|Δ|²`, would swamp the gradient. Below
/// `|Δ|² ≤ ε^{2/3} (1 + |x|²)` the correction is dropped (it is `O(|Δ|)`); the balance is then off by
/// `O(|Δ|³) = O(ε)`, i.e. still at round-off. Same solver, polish and compensated summation as
/// [`ImplicitMidpoint`].
pub type DiscreteGradient<V, Ms, H, L = <V as Vector>::Solver> =
    IncrementFlow<V, Ms, H, GonzalezRule, L>;

/// How an [`IncrementFlow`] evaluates its gradient `∇̄H` for the step `x → x + δ`.
pub trait GradientRule<V: Vector, H: Hamiltonian<V>> {
    /// A name for error messages.
    const NAME: &'static str;
    /// `out = ∇̄H(x, x + δ)`, given the midpoint `xm = x + δ/2`; `tmp` is workspace. Returns an
    /// estimate of the rounding noise in `out` along the unit vector `δ/|δ|` (0 if none).
    fn gradient(
        hamiltonian: &H,
        x: &V,
        delta: &[V::Real],
        xm: &V,
        tmp: &mut V,
        out: &mut V,
    ) -> V::Real;
}

/// `∇̄H = ∇H(x̄)`: the implicit midpoint rule.
#[derive(Debug, Clone, Copy, Default)]
pub struct MidpointRule;

impl<V: Vector, H: Hamiltonian<V>> GradientRule<V, H> for MidpointRule {
    const NAME: &'static str = "implicit midpoint";
    #[inline]
    fn gradient(
        hamiltonian: &H,
        _x: &V,
        _delta: &[V::Real],
        xm: &V,
        _tmp: &mut V,
        out: &mut V,
    ) -> V::Real {
        hamiltonian.gradient(xm, out);
        V::Real::zero()
    }
}

/// Gonzalez's midpoint discrete gradient (see [`DiscreteGradient`]).
#[derive(Debug, Clone, Copy, Default)]
pub struct GonzalezRule;

impl<V: Vector, H: Hamiltonian<V>> GradientRule<V, H> for GonzalezRule {
    const NAME: &'static str = "discrete gradient";
    #[inline]
    fn gradient(
        hamiltonian: &H,
        x: &V,
        delta: &[V::Real],
        xm: &V,
        tmp: &mut V,
        out: &mut V,
    ) -> V::Real {
        hamiltonian.gradient(xm, out);
        let d2 = delta.iter().fold(V::Real::zero(), |s, &d| s + d * d);
        let x2 = x.as_slice().iter().fold(V::Real::zero(), |s, &v| s + v * v);
        let eps = V::Real::epsilon();
        if !gonzalez_corrects(d2, x2) {
            return V::Real::zero();
        }
        ops::add_scaled(tmp.as_mut_slice(), x.as_slice(), V::Real::one(), delta);
        let (mut slope, mut slope_abs) = (V::Real::zero(), V::Real::zero());
        for (&g, &d) in out.as_slice().iter().zip(delta) {
            slope = slope + g * d;
            slope_abs = slope_abs + (g * d).abs();
        }
        let diff = hamiltonian.energy_difference(x, tmp);
        let c = (diff - slope) / d2;
        ops::axpy(out.as_mut_slice(), c, delta);
        // The numerator carries the rounding of the difference (for the default difference of
        // two energies ε|H|; less for a cancellation-free override, which this bound does not
        // know about) and of the slope; divided by |δ| it is the noise along δ/|δ|.
        eps * (hamiltonian.energy(x).abs() + diff.abs() + slope_abs) / d2.sqrt()
    }
}

/// Whether Gonzalez's correction `(ΔH − ∇H·δ)/|δ|² δ` is evaluated for a step of `|δ|² = d2`
/// from a point of `|x|² = x2`: above `ε^{2/3} (1 + |x|²)`; below, it is round-off.
#[inline]
pub(crate) fn gonzalez_corrects<T: Real>(d2: T, x2: T) -> bool {
    d2 > T::epsilon().powf(T::lit(2.0 / 3.0)) * (T::one() + x2)
}

/// A one-step method `x_{k+1} = x_k + δ`, `δ = h M(x + δ/2) ∇̄H(x, x + δ)`, with the gradient
/// rule `R`: [`ImplicitMidpoint`] or [`DiscreteGradient`].
pub struct IncrementFlow<V: Vector, Ms, H, R, L = <V as Vector>::Solver> {
    rule: core::marker::PhantomData<R>,
    structure: Ms,
    hamiltonian: H,
    newton: Newton<V, L>,
    start: V,
    /// The increment `δ` (Newton's unknown).
    delta: V,
    /// `δ` as Newton returned it, kept while polishing.
    saved: V,
    xm: V,
    grad: V,
    f: V,
    tmp: V,
    /// Workspace for closed-form Jacobian columns.
    jac: [V; 2],
    /// Compensation of the last `x + δ` (Kahan), valid while `x` is the state last returned.
    comp: V,
    last: V,
    stats: FlowStats,
}

impl<V: Vector, Ms, H, R, L> core::fmt::Debug for IncrementFlow<V, Ms, H, R, L> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("IncrementFlow")
            .field("n", &self.start.len())
            .field("stats", &self.stats)
            .finish_non_exhaustive()
    }
}

impl<V, Ms, H, R, L> IncrementFlow<V, Ms, H, R, L>
where
    V: Vector,
    Ms: StructureMatrix<V>,
    H: Hamiltonian<V>,
    R: GradientRule<V, H>,
    L: LinearSolver<V::Real>,
{
    /// The flow of `M ∇H` for states shaped like `x0`.
    pub fn try_new(
        structure: Ms,
        hamiltonian: H,
        x0: &V,
        newton: NewtonOptions<V::Real>,
    ) -> Result<Self, SetupError> {
        if let Some(component) = ops::first_non_finite(x0.as_slice()) {
            return Err(SetupError::NonFiniteState { component });
        }
        let n = x0.len();
        Ok(Self {
            rule: core::marker::PhantomData,
            structure,
            hamiltonian,
            newton: Newton::new(n, newton)?,
            start: x0.zeros_like(),
            delta: x0.zeros_like(),
            saved: x0.zeros_like(),
            xm: x0.zeros_like(),
            grad: x0.zeros_like(),
            f: x0.zeros_like(),
            tmp: x0.zeros_like(),
            jac: [x0.zeros_like(), x0.zeros_like()],
            comp: x0.zeros_like(),
            last: x0.zeros_like(),
            stats: FlowStats::default(),
        })
    }
}

/// `F(δ) = δ − h M(x + δ/2) ∇̄H(x, x + δ)`.
struct Increment<'a, V: Vector, Ms, H, R> {
    rule: core::marker::PhantomData<R>,
    h: V::Real,
    noise: V::Real,
    /// The rounding floor of `h M ∇H` at the step's start (see `IncrementFlow::step`).
    base_noise: V::Real,
    x: &'a V,
    xm: &'a mut V,
    grad: &'a mut V,
    f: &'a mut V,
    tmp: &'a mut V,
    jac: &'a mut [V; 2],
    structure: &'a Ms,
    hamiltonian: &'a H,
}

impl<V, Ms, H, R> Increment<'_, V, Ms, H, R>
where
    V: Vector,
    Ms: StructureMatrix<V>,
    H: Hamiltonian<V>,
    R: GradientRule<V, H>,
{
    /// `f = M(x + δ/2) ∇̄H(x, x + δ)`; records the rounding noise of `h f`.
    fn increment_field(&mut self, delta: &[V::Real]) {
        ops::add_scaled(
            self.xm.as_mut_slice(),
            self.x.as_slice(),
            V::Real::lit(0.5),
            delta,
        );
        let noise = R::gradient(
            self.hamiltonian,
            self.x,
            delta,
            self.xm,
            self.tmp,
            self.grad,
        );
        self.structure.apply(self.xm, self.grad, self.f);
        self.noise = noise_image(
            self.structure,
            self.xm,
            delta,
            noise,
            self.h,
            self.tmp,
            self.grad,
        );
    }
}

/// The rounding noise `noise` of a discrete gradient, which lies along `δ/|δ|`, as it shows in
/// the increment: `|h| noise ‖M(x̄) δ/|δ|‖∞`. `tmp` and `out` are workspace.
pub(crate) fn noise_image<V: Vector, Ms: StructureMatrix<V>>(
    structure: &Ms,
    xm: &V,
    delta: &[V::Real],
    noise: V::Real,
    h: V::Real,
    tmp: &mut V,
    out: &mut V,
) -> V::Real {
    if noise <= V::Real::zero() {
        return V::Real::zero();
    }
    let dn = ops::dot(delta, delta).sqrt();
    for (t, &d) in tmp.as_mut_slice().iter_mut().zip(delta) {
        *t = d / dn;
    }
    structure.apply(xm, tmp, out);
    h.abs() * noise * ops::norm_inf(out.as_slice())
}

impl<V, Ms, H, R> NonlinearProblem<V::Real> for Increment<'_, V, Ms, H, R>
where
    V: Vector,
    Ms: StructureMatrix<V>,
    H: Hamiltonian<V>,
    R: GradientRule<V, H>,
{
    type Error = StepError;

    fn dim(&self) -> usize {
        self.x.len()
    }

    fn noise_floor(&self) -> V::Real {
        self.noise.max(self.base_noise)
    }

    /// `∂F/∂δ_j = e_j − (h/2) (DM(x̄)[e_j] ∇H(x̄) + M(x̄) ∇²H(x̄) e_j)` from the model's
    /// derivatives (the midpoint rule's Jacobian; for the discrete gradient it is exact when
    /// `H` is quadratic and `O(|δ|)` off otherwise, which Newton absorbs).
    fn jacobian_column(&mut self, z: &[V::Real], j: usize, out: &mut [V::Real]) -> bool {
        let half = V::Real::lit(0.5);
        ops::add_scaled(self.xm.as_mut_slice(), self.x.as_slice(), half, z);
        ops::fill_zero(self.tmp.as_mut_slice());
        self.tmp.as_mut_slice()[j] = V::Real::one();
        let [hv, col] = &mut *self.jac;
        if !self.hamiltonian.hessian_apply(self.xm, self.tmp, hv) {
            return false;
        }
        self.structure.apply(self.xm, hv, col);
        if j == 0 {
            self.hamiltonian.gradient(self.xm, self.grad);
        }
        if !self
            .structure
            .derivative_apply_add(self.xm, self.tmp, self.grad, V::Real::one(), col)
        {
            return false;
        }
        let c = self.h * half;
        for (i, (o, &v)) in out.iter_mut().zip(col.as_slice()).enumerate() {
            *o = if i == j {
                V::Real::one()
            } else {
                V::Real::zero()
            } - c * v;
        }
        true
    }

    fn residual(&mut self, z: &[V::Real], out: &mut [V::Real]) -> Result<(), StepError> {
        self.increment_field(z);
        for ((o, &zi), &fi) in out.iter_mut().zip(z).zip(self.f.as_slice()) {
            *o = zi - self.h * fi;
        }
        Ok(())
    }
}

impl<V, Ms, H, R, L> Flow<V> for IncrementFlow<V, Ms, H, R, L>
where
    V: Vector,
    Ms: StructureMatrix<V>,
    H: Hamiltonian<V>,
    R: GradientRule<V, H>,
    L: LinearSolver<V::Real>,
{
    fn save_memory(&mut self, out: &mut Vec<V::Real>) {
        self.newton.invalidate_jacobian();
        for v in [self.comp.as_slice(), self.last.as_slice()] {
            out.extend_from_slice(v);
        }
    }
    fn restore_memory(&mut self, from: &mut &[V::Real]) {
        self.newton.invalidate_jacobian();
        for v in [self.comp.as_mut_slice(), self.last.as_mut_slice()] {
            let saved = crate::flow::take_memory(from, v.len());
            v[..saved.len()].copy_from_slice(saved);
        }
    }
    fn step(&mut self, h: V::Real, x: &mut V) -> Result<(), StepError> {
        if x.len() != self.start.len() {
            return Err(StepError::StateLength {
                flow: R::NAME,
                expected: self.start.len(),
                got: x.len(),
            });
        }
        if !super::check_step(h, x)? {
            return Ok(());
        }
        self.start.copy_from(x);
        // The rounding floor of h M ∇H itself: the gradient of a stiff term rounds at its
        // Hessian times the state's rounding (a spring k (r − L) at ε k |q|, far above ε |∇H|
        // when r ≈ L), estimated once per step as ε |h M ∇²H(x) x|∞ when the model has a
        // Hessian. Without it Newton cannot tell that floor from slow convergence.
        let mut base_noise = V::Real::zero();
        if self
            .hamiltonian
            .hessian_apply(&self.start, &self.start, &mut self.tmp)
        {
            self.structure.apply(&self.start, &self.tmp, &mut self.f);
            base_noise = V::Real::epsilon() * h.abs() * ops::norm_inf(self.f.as_slice());
        }
        // Explicit Euler predictor δ = h M(x) ∇H(x).
        self.hamiltonian.gradient(&self.start, &mut self.grad);
        self.structure.apply(&self.start, &self.grad, &mut self.f);
        for (d, &fi) in self.delta.as_mut_slice().iter_mut().zip(self.f.as_slice()) {
            *d = h * fi;
        }
        let mut problem = Increment {
            rule: core::marker::PhantomData::<R>,
            h,
            noise: V::Real::zero(),
            base_noise,
            x: &self.start,
            xm: &mut self.xm,
            grad: &mut self.grad,
            f: &mut self.f,
            tmp: &mut self.tmp,
            jac: &mut self.jac,
            structure: &self.structure,
            hamiltonian: &self.hamiltonian,
        };
        let solved = self.newton.solve(&mut problem, self.delta.as_mut_slice());
        if solved.is_ok() {
            // Polish δ below Newton's absolute tolerance: δ ← h f(x + δ/2) contracts by
            // h ‖∂f/∂x‖ / 2, small unless the problem is stiff. Keep the sweeps only if the
            // second change is below half the first (they contract); otherwise (stiff damping)
            // Newton's δ is the better answer.
            self.saved.copy_from(&self.delta);
            let mut changes = [V::Real::zero(); 2];
            for change in changes.iter_mut() {
                problem.increment_field(self.delta.as_slice());
                for (d, &fi) in self
                    .delta
                    .as_mut_slice()
                    .iter_mut()
                    .zip(problem.f.as_slice())
                {
                    let new = h * fi;
                    *change = change.max((new - *d).abs());
                    *d = new;
                }
            }
            let round_off =
                V::Real::lit(4.0) * V::Real::epsilon() * ops::norm_inf(self.delta.as_slice());
            if changes[1].is_nan()
                || (changes[1] > V::Real::lit(0.5) * changes[0] && changes[1] > round_off)
            {
                self.delta.copy_from(&self.saved);
            }
        }
        match solved {
            Ok(report) => {
                self.stats.record(&report);
            }
            Err(e) => {
                self.newton.invalidate_jacobian();
                return Err(StepError::from_newton(R::NAME, e));
            }
        }
        if let Some(component) = ops::first_non_finite(self.delta.as_slice()) {
            self.newton.invalidate_jacobian();
            return Err(StepError::NonFinite { component });
        }
        // Compensated summation x ← x + δ; the compensation only applies to the state this
        // flow returned last time (anything else starts afresh).
        if x.as_slice() != self.last.as_slice() {
            ops::fill_zero(self.comp.as_mut_slice());
        }
        ops::add_compensated(
            x.as_mut_slice(),
            self.delta.as_slice(),
            self.comp.as_mut_slice(),
        );
        self.last.copy_from(x);
        Ok(())
    }
    fn order(&self) -> u32 {
        2
    }
    fn is_symmetric(&self) -> bool {
        true
    }
    fn stats(&self) -> FlowStats {
        self.stats
    }
    fn dissipates(&self) -> bool {
        self.structure.is_dissipative()
    }
    /// `DΦ_h v = 2 J⁻¹ v − v` with `J = ∂F/∂δ` the Newton matrix of the increment (kept and
    /// factored by the last solve): for `F(δ; x) = δ − h M(x̄) ∇H(x̄)`, `x̄ = x + δ/2`, the
    /// derivative in `x` is `∂F/∂x = 2(J − I)`, so `dδ/dx = 2J⁻¹ − 2I` and `DΦ = I + dδ/dx`.
    /// Exact for the midpoint rule with a closed-form Newton matrix (up to its age, the last
    /// iterate; `tests/flows/implicit.rs`: 6e-11 against differences); with a kept difference or
    /// Broyden-updated matrix, or the discrete-gradient rule (whose correction term the formula
    /// leaves out), a close approximation — all a Newton matrix built from it needs.
    fn tangent_apply(&mut self, v: &V, out: &mut V) -> bool {
        out.copy_from(v);
        if !self.newton.apply_kept_inverse(out.as_mut_slice()) {
            return false;
        }
        for (o, &vi) in out.as_mut_slice().iter_mut().zip(v.as_slice()) {
            *o = *o + *o - vi;
        }
        true
    }
}
