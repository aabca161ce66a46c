//! The decoupled projected step around the implicit midpoint rule, with the inner increment and
//! `λ_k` found by one Newton iteration ([`ProjectedMidpoint`]).

use super::{STAGE_LAMBDA_K1, entry::EntryCheck, options::ProjectionOptions};
use crate::system::Model;
mod general;
mod joint;
mod mechanical;

use super::small::{SecondHalf, fixed, fixed_mut, second_half_is_affine, solve_second_half};
use super::warm::WarmStart;
use crate::error::{SetupError, StepError};
use crate::flow::forcing::Forcing;
use crate::flow::{Flow, FlowStats, Ledger, Multipliers};
use crate::linalg::LinearSolver;
use crate::nonlinear::{NewtonOptions, SMALL_MAX, SmallNewton, SolveReport};
use crate::real::Real;
use crate::system::{
    Case, Hamiltonian, HolonomicConstraint, StructureMatrix, check_initial_state, probe_decoupled,
};
use crate::vector::{Vector, ops, take};
use num_traits::Float as _;
use num_traits::{One, Zero};

/// The stage name errors of the joint solve carry.
const STAGE_JOINT: &str = "(increment, lambda_k) from the midpoint rule and g(x_{k+1}) = 0";

/// Residuals below this many times their tolerance may be at their round-off floor (the factor
/// [`Newton`](crate::nonlinear::Newton) uses).
const NOISE_FACTOR: f64 = 100.0;

/// The decoupled projected step of Zhang & Deng (2004, §3; RATTLE for an arbitrary structure
/// matrix) around the **implicit midpoint rule** of an inner Hamiltonian `K`, with the inner
/// increment and `λ_k` solved as **one** Newton system instead of nested solves.
///
/// The step is the same map as [`Projected`](super::Projected) around
/// [`ImplicitMidpoint`](crate::flow::ImplicitMidpoint) for `K` (up to the Newton tolerances):
///
/// ```text
/// x̂ = x + (h/2) Σ λ_j d_j,            d_j = M(x) G(x)ᵀ e_j
/// δ = h M(x̄) ∇K(x̄),                   x̄ = x̂ + δ/2            (midpoint rule, y = x̂ + δ)
/// g(y) = 0                                                    (m equations for λ_k)
/// x_{k+1} = y + (h/2) M Gᵀ(y) λ_{k+1},  φ(x_{k+1}) = 0          (as in Projected)
/// ```
///
/// With `K = H` it is the projection around the midpoint rule; with `K = H_N1 = H + μ g` it is
/// the paper's §2 scheme (`paper::modified_energy`). Nested, every residual of the `λ_k`
/// system is an implicit midpoint solve of its own; here Newton runs on `(δ, λ_k)` together
/// (`n + m` unknowns) and eliminates the blocks: with `A = I − (h/2) D(M∇K)(x̄)`
/// (the midpoint rule's Newton matrix, from [`Hamiltonian::hessian_apply`] and
/// [`StructureMatrix::derivative_apply_add`], differences for a model without them),
/// `F₁ = δ − h M∇K(x̄)`, `F₂ = g(y)`:
///
/// ```text
/// u = A⁻¹F₁,   c_j = (h/2)(2A⁻¹ − I) d_j   (= DΦ_h (h/2) d_j, the tangent map of the rule)
/// S Δλ = G(y) u − F₂,    S = G(y) [c_1 … c_m]
/// Δδ = −u + Σ Δλ_j (c_j − (h/2) d_j)
/// ```
///
/// which is exactly Newton's update for the joint system. `A`, `c_j` and `S` are built at the
/// first iterate and kept while each iteration contracts the scaled residual at least
/// fourfold, otherwise rebuilt where the iteration stands (with a kept matrix the update is an
/// inexact Newton step: `S` holds `G` where it was built, the right-hand side `G(y)` at the
/// current iterate; the fixed point is the same).
///
/// Stopping: `‖F₂‖∞ ≤ ftol` and `‖F₁‖∞ ≤ ε (2‖x‖∞ + 8‖δ₀‖∞)` with `δ₀` the explicit Euler
/// predictor (the increment resolved below the rounding of the state and of `h M∇K`), raised
/// after two updates that did not reach it to `4ε|h| ‖M∇²K(x) x‖∞` when that is larger (the
/// rounding floor of a stiff `h M∇K`: its gradient rounds at its Hessian times the state's
/// rounding);
/// or, once the iteration contracts at a rate `ρ` (the ratio of the last two updates of `δ`),
/// when the error it leaves in `δ`, about `ρ/(1 − ρ)` times the last update, is below half that
/// tolerance and `‖g(y)‖∞ ≤ ftol` is measured (Hairer & Wanner, *Solving Ordinary Differential
/// Equations II*, §IV.8: the stopping rule of implicit Runge–Kutta codes, which saves the last
/// evaluation of `M∇K`); or, within 100 times both, a residual that no longer halves after an
/// update with a freshly built matrix (the round-off floor). `λ_{k+1}` is solved as in
/// `Projected`'s small path (one linear solve when `φ` is affine in it).
///
/// **More than [`SMALL_MAX`] constraints** take the general path: the same equations, predictor
/// and tolerances, solved by [`Newton`](crate::nonlinear::Newton) on the `n + m` unknowns
/// `(δ, λ_k)` at once (dense, heap storage, its Jacobian in closed form from the same model
/// derivatives — differences without them — rebuilt at each step), the increment rows accepted at
/// their tolerance (the problem's noise floor) and `g` at `ftol`; `λ_{k+1}` by Newton on
/// `ν = (h/2) λ_{k+1}` with the exact columns `G M ∇²H M Gᵀ e_j` of the decoupled case.
///
/// Limits: the degenerate, decoupled case (probed at `x0` as in `Projected`; a step whose
/// second half-step moves `g` fails with [`StepError::CouplingViolated`]) and `2m ≤ n`; `A` (or
/// the joint matrix) is factored densely, `O(n³)` per factorization, so this is a path for models
/// of up to a few hundred unknowns — large sparse ones belong to `Projected` with a closed-form or
/// explicit inner flow. On any error the state, the warm start and the counters are unchanged. No
/// allocation per step.
pub struct ProjectedMidpoint<V: Vector, Sys, K, L = <V as Vector>::Solver> {
    system: Sys,
    inner: K,
    m: usize,
    newton: NewtonOptions<V::Real>,
    /// The `λ_{k+1}` solver of the small path (`None` on the general path).
    newton_k1: Option<SmallNewton<V::Real>>,
    /// The general path (more than [`SMALL_MAX`] constraints).
    general: Option<general::General<V::Real, L>>,
    /// `φ` is affine in `λ_{k+1}` (quadratic `H`, constant `M`, `G` unchanged along the second
    /// half-step): one linear solve.
    affine_k1: bool,
    guard_tol: V::Real,
    /// The midpoint rule's Newton matrix `A`, factored.
    lu: L,
    w: MidpointWork<V>,
    /// `(λ_k, λ_{k+1})` of the step in progress.
    z: V,
    warm: WarmStart<V>,
    entry: EntryCheck<V>,
    stats: FlowStats,
    /// The inputs `B(x) u(t)`, when the system is open ([`with_inputs`](Self::with_inputs)).
    forcing: Option<Forcing<V>>,
    /// The state the flow was built for (inputs are checked there).
    initial: V,
}

/// Workspace (allocated at construction).
struct MidpointWork<V> {
    /// `d_j = M Gᵀ e_j` at the half-step's base point (`x`, then `y`).
    d: Vec<V>,
    /// `c_j = (h/2)(2A⁻¹ − I) d_j`.
    c: Vec<V>,
    delta: V,
    xhat: V,
    xbar: V,
    grad: V,
    f: V,
    /// `F₁`, then `u = A⁻¹F₁`.
    r1: V,
    /// Scratch for the columns of `A`.
    hv: V,
    y: V,
    x_next: V,
    t1: V,
    t2: V,
}

impl<V: Vector, Sys, K, L> core::fmt::Debug for ProjectedMidpoint<V, Sys, K, L> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("ProjectedMidpoint")
            .field("m", &self.m)
            .field("stats", &self.stats)
            .finish_non_exhaustive()
    }
}

impl<V, Sys, K, L> ProjectedMidpoint<V, Sys, K, L>
where
    V: Vector,
    Sys: Model<V>,
    K: Hamiltonian<V>,
    L: LinearSolver<V::Real>,
{
    /// The projection of `system` around the implicit midpoint rule of `inner` (with the
    /// system's structure matrix), for states shaped like `x0`. `options` as for
    /// [`Projected`](super::Projected) (its case and coupling must be the degenerate and
    /// decoupled ones, which are decided at `x0` when not given). Of its Newton options the
    /// joint solve uses `ftol` and `max_iterations` (no line search: a Newton matrix rebuilt
    /// where the iteration stands instead); the `λ_{k+1}` solve uses them as `Projected` does.
    ///
    /// Errors: those of `Projected` (non-finite or off-manifold `x0`, singular brackets), and
    /// [`SetupError::Dimension`] for the cases this path does not cover — the non-degenerate
    /// or coupled case, `2m > n`, no constraints on a model without a mechanical form.
    pub fn try_new(
        system: Sys,
        inner: K,
        x0: &V,
        options: ProjectionOptions<V::Real>,
    ) -> Result<Self, SetupError> {
        let (n, m) = (x0.len(), system.constraint().dim());
        let unsupported = |what: &str| {
            Err(SetupError::Dimension {
                what: format!("ProjectedMidpoint: {what}; use Projected around ImplicitMidpoint"),
            })
        };
        // The counts first: the initial-state analysis below costs O(m² n). Without
        // constraints the step is the implicit midpoint rule itself, which this path takes
        // only for a model of mechanical form (its momenta eliminated, its positions solved
        // with the model's sparsity): `ImplicitMidpoint` is that rule on any model.
        if m == 0
            && !matches!(
                crate::system::MechanicalForm::of(&system, &inner, x0),
                Ok(Some(_))
            )
        {
            return unsupported("no constraints and no mechanical form");
        }
        if 2 * m > n {
            return unsupported("need 2m <= n");
        }
        let (case, pattern) =
            check_initial_state::<V, Sys, L>(&system, x0, &options.initial_checks(), true)?;
        if case != Case::Degenerate {
            return unsupported("the non-degenerate case (<g,g> invertible)");
        }
        let decoupled = match options.coupling {
            Some(super::Coupling::Decoupled) => true,
            Some(super::Coupling::Coupled) => false,
            None => probe_decoupled(&system, x0),
        };
        if !decoupled {
            return unsupported("the coupled case (the second half-step moves g or its direction)");
        }
        let affine_k1 = second_half_is_affine(&system, x0);
        // A few constraints on stack arrays; more by Newton on n + m unknowns.
        let newton_k1 = SmallNewton::new(m, options.newton);
        let general = match newton_k1 {
            Some(_) => None,
            None => {
                let form = crate::system::MechanicalForm::of(&system, &inner, x0)?;
                let pattern = pattern.as_deref();
                Some(general::General::new(n, m, options.newton, form, pattern)?)
            }
        };
        let small = if general.is_none() { m } else { 0 };
        let zeros = x0.zeros_like();
        let w = MidpointWork {
            d: vec![zeros.clone(); small],
            c: vec![zeros.clone(); small],
            delta: zeros.clone(),
            xhat: zeros.clone(),
            xbar: zeros.clone(),
            grad: zeros.clone(),
            f: zeros.clone(),
            r1: zeros.clone(),
            hv: zeros.clone(),
            y: zeros.clone(),
            x_next: zeros.clone(),
            t1: zeros.clone(),
            t2: zeros,
        };
        Ok(Self {
            inner,
            m,
            newton: options.newton,
            newton_k1,
            general,
            affine_k1,
            guard_tol: options.newton.ftol,
            lu: L::with_dim(if small > 0 { n } else { 0 })?,
            w,
            z: V::zeros(2 * m),
            warm: WarmStart::new(m, 2 * m, affine_k1 && small > 0),
            entry: EntryCheck::new(options.manifold_tol, x0),
            system,
            stats: FlowStats::default(),
            forcing: None,
            initial: x0.clone(),
        })
    }

    /// The same scheme for the open system `x' = M (∇H + Gᵀλ) + B(x) u(t)`: `map` is `B`,
    /// `signals` the inputs `u`. The inner midpoint rule takes the input at the step's
    /// midpoint, `δ = h M(x̄)∇K(x̄) + h B(x̄) u(t_n + h/2)` (symmetric in `(t, x)`, so the
    /// compositions keep their orders), reads the time from the [`Ledger`] and advances it,
    /// and books the supplied work `S_n = h ∇H(x̄)ᵀ B(x̄) u(t_n + h/2)` (the midpoint rule of
    /// `∫ yᵀu dt`; the rule conserves no energy exactly, so the balance holds to its order).
    /// On a model of mechanical form `B` acts on the momenta and is taken at `(q̄, p̂)`: forces
    /// of the positions and time. The kept Newton matrices leave out `D(B u)` (Newton tests
    /// the residual, which has it).
    ///
    /// # Errors
    /// [`SetupError::Dimension`] when the signals and the map's inputs differ in number;
    /// [`SetupError::Scheme`] when an input moves a position of the mechanical form or what
    /// the constraints read, or on the general path of a model without a mechanical form (more
    /// than [`SMALL_MAX`] constraints), which has no input term.
    pub fn with_inputs(
        mut self,
        map: impl crate::port::InputMap<V> + 'static,
        signals: Vec<crate::port::Signal<V::Real>>,
    ) -> Result<Self, SetupError> {
        let nq = match self.general.as_ref() {
            None => None,
            Some(general) => match general.mechanical.as_ref() {
                Some(reduced) => Some(reduced.nq),
                None => {
                    return Err(SetupError::Scheme {
                        what: format!(
                            "the projected midpoint rule takes inputs with at most {SMALL_MAX} constraints or on a model of mechanical form: its general path has no input term"
                        ),
                    });
                }
            },
        };
        let forcing = Forcing::try_new(
            "projected midpoint rule",
            Box::new(map),
            signals,
            &self.system,
            &self.initial,
            nq,
        )?;
        self.forcing = Some(forcing);
        Ok(self)
    }

    /// `S_n = ∇H(x̄)ᵀ (h B(x̄) u)` of the step just taken, `x̄ = (x̂ + y)/2` (`w.xbar`, `w.grad`
    /// and `w.t1` are scratch here).
    fn input_work(&mut self) -> V::Real {
        let Some(forcing) = self.forcing.as_mut() else {
            return V::Real::zero();
        };
        let w = &mut self.w;
        for ((b, &a), &y) in w
            .xbar
            .as_mut_slice()
            .iter_mut()
            .zip(w.xhat.as_slice())
            .zip(w.y.as_slice())
        {
            *b = V::Real::lit(0.5) * (a + y);
        }
        self.system.hamiltonian().gradient(&w.xbar, &mut w.grad);
        let force = forcing.force_at(0, &w.xbar);
        ops::dot(w.grad.as_slice(), force.as_slice())
    }

    /// The system whose constraints are enforced.
    pub fn system(&self) -> &Sys {
        &self.system
    }

    /// The Hamiltonian of the inner midpoint rule.
    pub fn inner(&self) -> &K {
        &self.inner
    }

    /// `(λ_k, λ_{k+1})` of the last successful step (zeros before the first).
    pub fn multipliers(&self) -> (&[V::Real], &[V::Real]) {
        self.warm.last().as_slice()[..2 * self.m].split_at(self.m)
    }

    /// The joint solve converged with `λ_k = lam` and `g(y) = g` (`‖g‖∞ = n2`): counted, `λ_k`
    /// into `z[..M]`.
    #[inline(always)]
    fn accept<const M: usize>(
        &mut self,
        mut report: SolveReport<V::Real>,
        n2: V::Real,
        lam: [V::Real; M],
        g: [V::Real; M],
    ) -> [V::Real; M] {
        report.residual = n2;
        self.stats.record(&report);
        *fixed_mut(self.z.as_mut_slice()) = lam;
        g
    }

    /// `d_j = s M(base) G(base)ᵀ e_j` (`M` of them), the directions of a half-step from `base`
    /// scaled by `s`.
    #[inline(always)]
    fn directions<const M: usize>(system: &Sys, base: &V, s: V::Real, tmp: &mut V, d: &mut [V]) {
        let mut unit = [V::Real::zero(); M];
        for (j, dj) in d.iter_mut().enumerate() {
            unit[j] = s;
            system.constraint_force(base, &unit, tmp, dj);
            unit[j] = V::Real::zero();
        }
    }

    /// One step from `x` with `M` constraints; the result is left in `w.x_next`.
    #[inline(always)]
    fn step_impl<const M: usize>(&mut self, h: V::Real, x: &V) -> Result<(), StepError> {
        let half = h * V::Real::lit(0.5);
        let w = &mut self.w;
        Self::directions::<M>(&self.system, x, V::Real::one(), &mut w.t1, &mut w.d);
        self.warm.predict_lambda_k(M, h, self.z.as_mut_slice());
        let g_y = self.solve_joint::<M>(h, x)?;
        self.warm.record_lambda_k(M, h, self.z.as_slice());
        self.warm.predict_lambda_k1(M, h, self.z.as_mut_slice());
        // The second half-step along (h/2) M Gᵀ(y).
        let w = &mut self.w;
        Self::directions::<M>(&self.system, &w.y, half, &mut w.t1, &mut w.d);
        let d = fixed::<V, M>(&w.d);
        let mut problem = SecondHalf {
            h,
            y: &w.y,
            system: &self.system,
            d,
            x_next: &mut w.x_next,
            t1: &mut w.t1,
            t2: &mut w.t2,
        };
        let z: &mut [V::Real; M] = fixed_mut(&mut self.z.as_mut_slice()[M..]);
        let Some(newton_k1) = self.newton_k1.as_ref() else {
            unreachable!("the small path without its solver");
        };
        match solve_second_half(newton_k1, self.affine_k1, &mut problem, z) {
            Ok(report) => self.stats.record(&report),
            Err(e) => return Err(StepError::from_newton(STAGE_LAMBDA_K1, e)),
        }
        self.warm.record_lambda_k1(M, h, self.z.as_slice());
        // The decoupling assumption: the second half-step left g where it was.
        let mut g_next = [V::Real::zero(); M];
        self.system
            .constraint()
            .residual(&self.w.x_next, &mut g_next);
        guard(self.guard_tol, &g_next, &g_y)
    }
}

impl<V, Sys, K, L> Flow<V> for ProjectedMidpoint<V, Sys, K, L>
where
    V: Vector,
    Sys: Model<V>,
    K: Hamiltonian<V>,
    L: LinearSolver<V::Real>,
{
    fn save_memory(&mut self, out: &mut Vec<V::Real>) {
        if let Some(g) = self.general.as_mut() {
            g.save(out);
        }
        self.warm.save(out);
        out.extend_from_slice(self.z.as_slice());
    }
    fn restore_memory(&mut self, from: &mut &[V::Real]) {
        if let Some(g) = self.general.as_mut() {
            g.restore(from);
        }
        self.warm.restore(from);
        let z = self.z.as_mut_slice();
        let saved = crate::flow::take_memory(from, z.len());
        z[..saved.len()].copy_from_slice(saved);
    }
    fn step(&mut self, h: V::Real, x: &mut V) -> Result<(), StepError> {
        self.step_at(&mut Ledger::default(), h, x)
    }
    /// The step from `ledger.t`; with inputs it adds their work to `ledger.supplied` and
    /// advances `ledger.t` by `h`.
    fn step_at(
        &mut self,
        ledger: &mut Ledger<V::Real>,
        h: V::Real,
        x: &mut V,
    ) -> Result<(), StepError> {
        if x.len() != self.w.x_next.len() {
            return Err(StepError::StateLength {
                flow: "ProjectedMidpoint",
                expected: self.w.x_next.len(),
                got: x.len(),
            });
        }
        let nonzero = crate::flow::check_step_size(h)?;
        let from_last = self.entry.is_last(x);
        if !from_last && let Some(component) = ops::first_non_finite(x.as_slice()) {
            return Err(StepError::NonFinite { component });
        }
        if !nonzero {
            return Ok(());
        }
        if let Some(forcing) = self.forcing.as_mut() {
            forcing.begin(ledger.t, h, &[V::Real::lit(0.5)], h)?;
        }
        if !from_last {
            let w = &mut self.w;
            let mut small = [V::Real::zero(); SMALL_MAX];
            let r = match self.general.as_mut() {
                Some(general) => &mut general.g_next[..],
                None => &mut small[..self.m],
            };
            self.entry
                .check(&self.system, x, true, r, &mut w.t1, &mut w.t2)?;
        }
        let stats = self.stats;
        let result = match self.m {
            _ if self.general.is_some() => self.step_general(h, x),
            1 => self.step_impl::<1>(h, x),
            2 => self.step_impl::<2>(h, x),
            3 => self.step_impl::<3>(h, x),
            _ => self.step_impl::<SMALL_MAX>(h, x),
        }
        .and_then(|()| match ops::first_non_finite(self.w.x_next.as_slice()) {
            Some(component) => Err(StepError::NonFinite { component }),
            None => Ok(()),
        });
        if let Err(e) = result {
            self.stats = stats;
            return Err(e);
        }
        if self.forcing.is_some() {
            // The step carries the time of its inputs.
            ledger.supplied = ledger.supplied + self.input_work();
            ledger.t = ledger.t + h;
        }
        take(x, &mut self.w.x_next);
        self.entry.record(x);
        self.warm.commit(&mut self.z, h, true);
        self.stats.projected_steps += 1;
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
    fn multipliers(&self) -> Option<Multipliers<'_, V::Real>> {
        Some(ProjectedMidpoint::multipliers(self))
    }
    fn dissipates(&self) -> bool {
        self.system.structure().is_dissipative()
    }
}

/// The decoupling assumption: the second half-step left `g` where it was (`g(x_{k+1})` against
/// `g(y)`, within `tol`).
fn guard<T: Real>(tol: T, g_next: &[T], g_y: &[T]) -> Result<(), StepError> {
    let change = ops::dist_inf(g_next, g_y);
    if change.is_nan() || change > tol {
        return Err(StepError::CouplingViolated {
            residual: change.to_f64_lossy(),
        });
    }
    Ok(())
}

/// The tolerance of the midpoint increment's residual at the predictor's scale,
/// `ε (2‖x‖∞ + 8‖δ₀‖∞)`: the increment resolved below the rounding of the state and of `h M∇K`.
#[inline(always)]
fn increment_tolerance<T: Real>(x: &[T], delta0: &[T]) -> T {
    T::epsilon() * (T::lit(2.0) * ops::norm_inf(x) + T::lit(8.0) * ops::norm_inf(delta0))
}

/// The rounding floor of a stiff `h M∇K`, `4ε |h| ‖M ∇²K(x) x‖∞` (a stiff term's gradient
/// rounds at its Hessian times the state's rounding; as in `IncrementFlow`); `None` without
/// [`Hamiltonian::hessian_apply`]. `hv`, `out` are scratch.
fn stiff_floor<V, Sys, K>(
    system: &Sys,
    inner: &K,
    h: V::Real,
    x: &V,
    hv: &mut V,
    out: &mut V,
) -> Option<V::Real>
where
    V: Vector,
    Sys: Model<V>,
    K: Hamiltonian<V>,
{
    if !inner.hessian_apply(x, x, hv) {
        return None;
    }
    system.structure().apply(x, hv, out);
    Some(V::Real::lit(4.0) * V::Real::epsilon() * h.abs() * ops::norm_inf(out.as_slice()))
}
