//! The projection half-steps of Zhang & Deng (2004, §3) and Hairer's symmetric projection.
//!
//! For `x' = M(x)(∇H + Gᵀλ)`, `g(x) = 0`, one step around an inner flow `Φ_h`:
//!
//! ```text
//! x̂       = x_k     + (h/2) M(x_k) G(x_k)ᵀ λ_k
//! y       = Φ_h(x̂)
//! x_{k+1} = y       + (h/2) M(x_{k+1}) G(x_{k+1})ᵀ λ_{k+1}
//! ```
//!
//! - **Degenerate case** (`⟨g,g⟩ = G M Gᵀ = 0`, every mechanical model): `λ_k` and `λ_{k+1}` are
//!   chosen so that `g(x_{k+1}) = 0` and `φ(x_{k+1}) = ⟨g,H⟩(x_{k+1}) = 0` (the hidden constraint).
//!   In general the two are coupled and `x_{k+1}` is implicit: Newton on `(λ_k, λ_{k+1})` with a
//!   fixed-point inner loop for `x_{k+1}` ([`Scheme::Coupled`]). When the second half-step cannot
//!   change `g` nor its own direction (position constraints, `M Gᵀ` acting on momenta only) the
//!   systems decouple: `λ_k` from `g(y) = 0`, then `λ_{k+1}` from `φ = 0` ([`Scheme::Decoupled`]);
//!   this is RATTLE (Andersen 1983; Leimkuhler & Reich 1994) for an arbitrary structure matrix.
//! - **Non-degenerate case** (`⟨g,g⟩` invertible): `φ = 0` is not a constraint of the true
//!   solution. Hairer's symmetric projection (BIT 40, 2000) uses one `λ` in both half-steps and
//!   `g(x_{k+1}) = 0` ([`Scheme::Symmetric`]).
//!
//! Every variant is symmetric when the inner flow is, and then of order 2 (composition raises it).
//! The multipliers are warm-started from the previous step.

mod warm;

use super::{CompositionTable, Flow, FlowStats};
use crate::error::{NewtonError, SetupError, StepError};
use crate::linalg::{LinearSolver, SolverChoice, Structure, Triplets};
use crate::nonlinear::{
    Newton, NewtonOptions, NonlinearProblem, NonlinearSolver, SMALL_MAX, SmallNewton, SolveReport,
};
use crate::real::Real;
use crate::system::{Brackets, Case, Hamiltonian, HolonomicConstraint, StructureMatrix, System};
use crate::vector::{Vector, ops};
use num_traits::Float as _;
use num_traits::{One, Zero};
use warm::WarmStart;

/// How the two multiplier systems of the degenerate case are solved.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Coupling {
    /// `λ_k` then `λ_{k+1}`, each an `m × m` Newton solve. Valid when the second half-step changes
    /// neither `g` nor `M Gᵀ` (checked after every step).
    Decoupled,
    /// One `2m × 2m` Newton solve for `(λ_k, λ_{k+1})` with `x_{k+1}` implicit.
    Coupled,
}

/// The variant a [`Projected`] flow runs, resolved at construction.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scheme {
    /// Degenerate case, decoupled solves (RATTLE-like).
    Decoupled,
    /// Degenerate case, coupled solve.
    Coupled,
    /// Non-degenerate case: Hairer's symmetric projection.
    Symmetric,
}

/// Options of [`Projected`].
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub struct ProjectionOptions<T> {
    /// The case; `None` decides from the brackets at the initial state.
    pub case: Option<Case>,
    /// The coupling in the degenerate case; `None` probes the model at the initial state.
    pub coupling: Option<Coupling>,
    /// Newton options for the multiplier systems.
    pub newton: NewtonOptions<T>,
    /// `⟨g,g⟩` counts as zero when `‖⟨g,g⟩‖∞ ≤ degeneracy_tol · n ‖Gᵀ‖ ‖M Gᵀ‖`. Default `√ε`.
    pub degeneracy_tol: T,
    /// A bracket matrix counts as singular when its smallest LU pivot is below `rcond` times its
    /// largest entry. Default `1e-8` (the brackets with `φ` are finite differences).
    pub rcond: T,
    /// Iteration limit of the fixed point for the implicit end point. Default 50.
    pub fixed_point_max_iterations: usize,
    /// The initial state must satisfy `‖g(x₀)‖∞ ≤ manifold_tol` (and `‖φ(x₀)‖∞ ≤ manifold_tol` in
    /// the degenerate case), or construction fails with [`SetupError::OffManifold`]: the
    /// scheme's symmetry and invariants hold on the manifold. `None` skips the check (the first
    /// step then projects onto `g = 0`, `φ = 0`). Default `√ε`.
    pub manifold_tol: Option<T>,
}

impl<T: Real> Default for ProjectionOptions<T> {
    fn default() -> Self {
        Self {
            case: None,
            coupling: None,
            newton: NewtonOptions::default(),
            degeneracy_tol: T::epsilon().sqrt(),
            rcond: T::lit(1e-8),
            fixed_point_max_iterations: 50,
            manifold_tol: Some(T::epsilon().sqrt()),
        }
    }
}

impl<T: Real> ProjectionOptions<T> {
    /// Forces the case instead of deciding it from the brackets.
    pub fn with_case(mut self, case: Case) -> Self {
        self.case = Some(case);
        self
    }
    /// Forces the coupling of the degenerate case.
    pub fn with_coupling(mut self, coupling: Coupling) -> Self {
        self.coupling = Some(coupling);
        self
    }
    /// Sets the Newton options.
    pub fn with_newton(mut self, newton: NewtonOptions<T>) -> Self {
        self.newton = newton;
        self
    }
    /// Sets (or with `None` disables) the check that the initial state is on the manifold.
    pub fn with_manifold_tol(mut self, tol: Option<T>) -> Self {
        self.manifold_tol = tol;
        self
    }
}

/// Workspace: states of length `n`, multipliers in vectors of at least `2m` entries.
#[derive(Debug, Clone)]
struct Work<V: Vector> {
    y: V,
    /// The previous stage's `y`: the base point of a fused stage (see `step_fused`).
    prev: V,
    xe: V,
    t1: V,
    t2: V,
    /// `(λ_k, λ_{k+1})` being solved for (the last successful ones are in `warm`).
    z: V,
    /// Warm starts, double-buffered (see [`warm`]).
    warm: WarmStart<V>,
    /// `λ_k` for which `y` was last computed.
    a_cached: V,
    y_valid: bool,
    /// Scratch for `m` residual entries.
    r: V,
    /// `g(y)` of the last `λ_k` residual evaluation (general path), for the decoupling guard.
    g_y: V,
    /// Scratch for closed-form Jacobian groups: two states and an indicator of `m` entries.
    u1: V,
    u2: V,
    ec: V,
}

/// The projected flow of Zhang & Deng (2004, §3) around an inner flow `F` (see the module docs).
///
/// Built with [`FlowExt::projected`](super::FlowExt::projected). Order `min(2, order(F))`,
/// symmetric when `F` is. The multiplier systems are solved by [`Newton`] with the linear solver
/// `L` (default: the state storage's dense solver); workspace is allocated at construction,
/// so a step allocates nothing.
pub struct Projected<V: Vector, F, Ms, H, C, L = <V as Vector>::Solver> {
    inner: F,
    system: System<Ms, H, C>,
    scheme: Scheme,
    m: usize,
    /// Newton for `λ_k` (decoupled), `(λ_k, λ_{k+1})` (coupled) or `λ` (symmetric).
    newton: Newton<V, L>,
    /// Newton for `λ_{k+1}` (decoupled only): a separate solver keeps its own Jacobian.
    newton_k1: Option<Newton<V, L>>,
    /// The small decoupled path (see [`SmallPath`]), when it applies.
    small: Option<SmallPath<V>>,
    fixed_point_max_iterations: usize,
    /// Bound on `|g(x_{k+1}) − g(y)|` in the decoupled variant (exactly 0 when it applies).
    guard_tol: V::Real,
    /// Relative tolerance of the fixed point for the implicit end point.
    fixed_point_tol: V::Real,
    w: Work<V>,
    stats: FlowStats,
}

impl<V, F, Ms, H, C, L> core::fmt::Debug for Projected<V, F, Ms, H, C, L>
where
    V: Vector,
{
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Projected")
            .field("scheme", &self.scheme)
            .field("m", &self.m)
            .field("stats", &self.stats)
            .finish_non_exhaustive()
    }
}

impl<V, F, Ms, H, C, L> Projected<V, F, Ms, H, C, L>
where
    V: Vector,
    F: Flow<V>,
    Ms: StructureMatrix<V>,
    H: Hamiltonian<V>,
    C: HolonomicConstraint<V>,
    L: LinearSolver<V::Real>,
{
    /// Builds the projected flow, deciding case and coupling at `x0` unless `options` fix them.
    ///
    /// Errors: non-finite `x0`; `⟨g,g⟩` and `⟨φ,g⟩` both singular (redundant constraints, a
    /// Casimir of `M`); `⟨g,g⟩` neither zero nor invertible; a linear solver too small.
    pub fn try_new(
        mut inner: F,
        system: System<Ms, H, C>,
        x0: &V,
        options: ProjectionOptions<V::Real>,
    ) -> Result<Self, SetupError> {
        let (case, pattern) = check_initial_state::<V, Ms, H, C, L>(&system, x0, &options, true)?;
        let (n, m) = (x0.len(), system.constraint.dim());
        if case == Case::Degenerate && 2 * m > n {
            return Err(SetupError::Dimension {
                what: format!(
                    "{m} constraints and {m} hidden constraints on a state of dimension {n}: need 2m <= n"
                ),
            });
        }
        let scheme = match case {
            Case::NonDegenerate => Scheme::Symmetric,
            Case::Degenerate => match options.coupling {
                Some(Coupling::Decoupled) => Scheme::Decoupled,
                Some(Coupling::Coupled) => Scheme::Coupled,
                None => {
                    if probe_decoupled(&system, x0) {
                        Scheme::Decoupled
                    } else {
                        Scheme::Coupled
                    }
                }
            },
        };
        let k = if scheme == Scheme::Coupled { 2 * m } else { m };
        // With a sparse G, the decoupled multiplier systems couple constraints whose gradients
        // share a state variable (when M ∇²H M does not couple those variables further; a
        // closed-form Jacobian outside the pattern is reported as PatternIncomplete). The
        // coupled and symmetric systems carry more couplings (M(x') and x' implicit): dense.
        let pattern = pattern.filter(|_| scheme == Scheme::Decoupled);
        let pattern_m = pattern.as_deref();
        let grouped = pattern.is_some();
        let newton = Newton::with_pattern(k, options.newton, pattern.as_deref())?;
        let newton_k1 = match scheme {
            Scheme::Decoupled => Some(Newton::with_pattern(m, options.newton, pattern_m)?),
            _ => None,
        };
        let small = if grouped || scheme != Scheme::Decoupled {
            None
        } else {
            SmallPath::try_new(&system, x0, options.newton)
        };
        inner.prepare(x0);
        let k_z = if scheme == Scheme::Symmetric {
            m
        } else {
            2 * m
        };
        let zeros = x0.zeros_like();
        let w = Work {
            y: zeros.clone(),
            prev: zeros.clone(),
            xe: zeros.clone(),
            t1: zeros.clone(),
            t2: zeros,
            z: V::zeros(k_z),
            warm: WarmStart::new(m, k_z),
            a_cached: V::zeros(m),
            y_valid: false,
            r: V::zeros(m),
            g_y: V::zeros(m),
            // Only grouped (sparse) Jacobians use these: no memory for them otherwise.
            u1: V::zeros(if grouped { n } else { 0 }),
            u2: V::zeros(if grouped { n } else { 0 }),
            ec: V::zeros(if grouped { m } else { 0 }),
        };
        Ok(Self {
            inner,
            system,
            scheme,
            m,
            newton,
            newton_k1,
            small,
            fixed_point_max_iterations: options.fixed_point_max_iterations,
            guard_tol: options.newton.ftol,
            fixed_point_tol: options.newton.xtol,
            w,
            stats: FlowStats::default(),
        })
    }

    /// The variant in use.
    pub fn scheme(&self) -> Scheme {
        self.scheme
    }

    /// The model.
    pub fn system(&self) -> &System<Ms, H, C> {
        &self.system
    }

    /// `true` when the flow runs the small decoupled path: the decoupled scheme with a dense
    /// `G` of at most [`SMALL_MAX`] constraints and a Hamiltonian with a Hessian — full Newton
    /// on stack arrays with closed-form Jacobians ([`SmallNewton`]), and one linear solve for
    /// `λ_{k+1}` when `H` is quadratic and `M` constant. Otherwise the multiplier systems go
    /// to [`Newton`] with kept, Broyden-updated or grouped Jacobians.
    pub fn uses_small_path(&self) -> bool {
        self.small.is_some()
    }

    /// The inner flow.
    pub fn inner(&self) -> &F {
        &self.inner
    }

    /// The Newton solver of the first multiplier system (`λ_k`, or all multipliers when
    /// coupled), for instance to see which linear solver backend it uses.
    pub fn newton(&self) -> &Newton<V, L> {
        &self.newton
    }

    /// The multipliers `(λ_k, λ_{k+1})` of the last step (`λ_k = λ_{k+1}` for the symmetric
    /// projection).
    pub fn multipliers(&self) -> (&[V::Real], &[V::Real]) {
        let z = self.w.warm.last().as_slice();
        match self.scheme {
            Scheme::Symmetric => (&z[..self.m], &z[..self.m]),
            _ => (&z[..self.m], &z[self.m..2 * self.m]),
        }
    }

    fn record(&mut self, r: &SolveReport<V::Real>) {
        self.stats.newton_solves += 1;
        self.stats.newton_iterations += r.iterations as u64;
        self.stats.residual_evaluations += r.residual_evaluations as u64;
        self.stats.factorizations += r.factorizations as u64;
    }

    /// Solves one multiplier system. Newton evaluates the residual last at the iterate it
    /// returns, so afterwards `y` and `x_{k+1}` in the workspace belong to the solution.
    fn solve(
        &mut self,
        mode: Mode,
        h: V::Real,
        base: Base<'_, V>,
        stage: &'static str,
    ) -> Result<(), StepError> {
        let m = self.m;
        let range = match mode {
            Mode::LambdaK | Mode::Symmetric => 0..m,
            Mode::LambdaK1 => m..2 * m,
            Mode::Coupled => 0..2 * m,
        };
        let Work {
            y,
            g_y,
            xe,
            t1,
            t2,
            z,
            a_cached,
            y_valid,
            u1,
            u2,
            ec,
            prev,
            ..
        } = &mut self.w;
        let x = base.resolve(prev);
        let mut problem = Stage {
            mode,
            h,
            m,
            x,
            inner: &mut self.inner,
            system: &self.system,
            y,
            xe,
            t1,
            t2,
            a_cached,
            y_valid,
            u1,
            u2,
            ec,
            g_y,
            fixed_point_max_iterations: self.fixed_point_max_iterations,
            fixed_point_tol: self.fixed_point_tol,
        };
        let newton = match (mode, self.newton_k1.as_mut()) {
            (Mode::LambdaK1, Some(n)) => n,
            _ => &mut self.newton,
        };
        let result = newton.solve(&mut problem, &mut z.as_mut_slice()[range]);
        match result {
            Ok(report) => {
                self.record(&report);
                Ok(())
            }
            Err(NewtonError::Residual(e)) => Err(*e),
            Err(source) => Err(StepError::Newton { stage, source }),
        }
    }

    /// Solves one decoupled multiplier system on the small path (`K = m` multipliers). As
    /// with [`Self::solve`], `y` (for `λ_k`) or `x_{k+1}` (for `λ_{k+1}`) in the workspace
    /// belong to the solution.
    #[inline(always)]
    fn solve_small<const K: usize>(
        &mut self,
        second: bool,
        h: V::Real,
        base: Base<'_, V>,
    ) -> Result<(), StepError> {
        let Some(small) = self.small.as_mut() else {
            unreachable!("solve_small without a small path");
        };
        let w = &mut self.w;
        let x = base.resolve(&w.prev);
        let half = h * V::Real::lit(0.5);
        let d: &mut [V; K] = fixed_mut(&mut small.d);
        // The directions of this half-step, fixed for the whole solve.
        let base = if second { &w.y } else { x };
        let mut unit = [V::Real::zero(); K];
        for (j, dj) in d.iter_mut().enumerate() {
            unit[j] = V::Real::one();
            self.system.constraint_force(base, &unit, &mut w.t1, dj);
            unit[j] = V::Real::zero();
        }
        let d: &[V; K] = d;
        let (result, stage) = if second {
            let mut problem = SecondHalf {
                h,
                half,
                y: &w.y,
                system: &self.system,
                e: d,
                xe: &mut w.xe,
                t1: &mut w.t1,
                t2: &mut w.t2,
            };
            let z: &mut [V::Real; K] = fixed_mut(&mut w.z.as_mut_slice()[K..]);
            let result = if small.affine_k1 {
                // One linear solve; x_{k+1} at the solution is formed here, not by Newton.
                let r = small.newton_k1.solve_affine_fixed(&mut problem, z);
                half_step(problem.xe, problem.y, half, &*z, d);
                r
            } else {
                small.newton_k1.solve_fixed(&mut problem, z)
            };
            (result, "lambda_{k+1} from phi(x_{k+1}) = 0")
        } else {
            // w_j = (h/2)(d_j + h M(x) ∇²H(x) d_j), so that G(y) w_j is column j of ∂g/∂λ_k.
            let cols: &mut [V; K] = fixed_mut(&mut small.w);
            let mut exact = true;
            for (dj, wj) in d.iter().zip(cols.iter_mut()) {
                if !self.system.hamiltonian.hessian_apply(x, dj, &mut w.t1) {
                    exact = false;
                    break;
                }
                self.system.structure.apply(x, &w.t1, &mut w.t2);
                let (wj, dj, t2) = (wj.as_mut_slice(), dj.as_slice(), w.t2.as_slice());
                for ((o, &dv), &tv) in wj.iter_mut().zip(dj).zip(t2) {
                    *o = half * (dv + h * tv);
                }
            }
            let mut problem = FirstHalf {
                h,
                half,
                x,
                inner: &mut self.inner,
                constraint: &self.system.constraint,
                d,
                w: exact.then_some(&*cols),
                y: &mut w.y,
                g: fixed_mut(&mut small.g_y),
            };
            let z: &mut [V::Real; K] = fixed_mut(w.z.as_mut_slice());
            (
                small.newton_k.solve_fixed(&mut problem, z),
                "lambda_k from g(x_{k+1}) = 0",
            )
        };
        match result {
            Ok(report) => {
                self.record(&report);
                Ok(())
            }
            Err(NewtonError::Residual(e)) => Err(*e),
            Err(source) => Err(StepError::Newton { stage, source }),
        }
    }

    /// The decoupled step (RATTLE-like): `λ_k` from `g(x_{k+1}) = 0`, then `λ_{k+1}` from
    /// `φ(x_{k+1}) = 0`. `K = m` on the small path (every loop over the multipliers unrolls),
    /// `K = 0` on the general one.
    #[inline(always)]
    fn step_decoupled<const K: usize>(&mut self, h: V::Real, x: &V) -> Result<(), StepError> {
        let m = if K == 0 { self.m } else { K };
        self.w.warm.predict_lambda_k(m, h, self.w.z.as_mut_slice());
        if K == 0 {
            self.solve(
                Mode::LambdaK,
                h,
                Base::Given(x),
                "lambda_k from g(x_{k+1}) = 0",
            )?;
        } else {
            self.solve_small::<K>(false, h, Base::Given(x))?;
        }
        self.w.warm.record_lambda_k(m, h, self.w.z.as_slice());
        self.w.warm.predict_lambda_k1(m, h, self.w.z.as_mut_slice());
        if K == 0 {
            self.solve(
                Mode::LambdaK1,
                h,
                Base::Given(x),
                "lambda_{k+1} from phi(x_{k+1}) = 0",
            )?;
        } else {
            self.solve_small::<K>(true, h, Base::Given(x))?;
        }
        self.w.warm.record_lambda_k1(m, h, self.w.z.as_slice());
        self.decoupling_guard::<K>(m)
    }

    /// The decoupling assumption: the second half-step did not move `g` (for position
    /// constraints and a momentum-only direction, `g(x_{k+1})` and `g(y)` are the same
    /// floating-point numbers).
    #[inline(always)]
    fn decoupling_guard<const K: usize>(&mut self, m: usize) -> Result<(), StepError> {
        let w = &mut self.w;
        let gx = &mut w.r.as_mut_slice()[..m];
        self.system.constraint.residual(&w.xe, gx);
        // g(y) is the λ_k system's last residual.
        let change = match self.small.as_ref() {
            Some(small) if K > 0 => ops::dist_inf(gx, &small.g_y[..m]),
            _ => ops::dist_inf(gx, &w.g_y.as_slice()[..m]),
        };
        if change.is_nan() || change > self.guard_tol {
            return Err(StepError::CouplingViolated {
                residual: change.to_f64_lossy(),
            });
        }
        Ok(())
    }

    /// A composition's stages as one fused step (decoupled scheme). Stage `i`'s second
    /// half-step `y_i + (h_i/2) M Gᵀ(y_i) λ_{k+1}` and stage `i+1`'s first half-step act along
    /// the same direction `M Gᵀ(y_i)` (which the second half-step does not change), so together
    /// they are one shift `y_i + (h_{i+1}/2) M Gᵀ λ̃` with `λ̃ = λ_k + (h_i/h_{i+1}) λ_{k+1}`, and
    /// `g(y_{i+1}) = 0` determines `λ̃` alone: the interior `λ_{k+1}` (fixed by `φ = 0` at a
    /// point the composition never returns) does not change the result. One multiplier solve
    /// per stage, plus the last stage's `λ_{k+1}` so that the result is on `g = 0`, `φ = 0`:
    /// the same map as the stage-by-stage composition, up to the Newton tolerance.
    #[inline(always)]
    fn step_fused<const K: usize>(
        &mut self,
        h: V::Real,
        table: &CompositionTable,
        x: &V,
    ) -> Result<V::Real, StepError> {
        let m = if K == 0 { self.m } else { K };
        let stage = "lambda_k from g(x_{k+1}) = 0";
        let one = V::Real::one();
        let mut h_prev = table.gamma_in::<V::Real>(0) * h;
        self.w
            .warm
            .predict_lambda_k(m, h_prev, self.w.z.as_mut_slice());
        if K == 0 {
            self.solve(Mode::LambdaK, h_prev, Base::Given(x), stage)?;
        } else {
            self.solve_small::<K>(false, h_prev, Base::Given(x))?;
        }
        self.w.warm.record_lambda_k(m, h_prev, self.w.z.as_slice());
        for i in 1..table.stages {
            let hi = table.gamma_in::<V::Real>(i) * h;
            // The previous stage's λ̃ split evenly between its own λ_k and λ_{k+1} estimates
            // the force per unit time; λ̃ of this stage is that force times (1 + h_prev/h_i).
            let w = &mut self.w;
            core::mem::swap(&mut w.y, &mut w.prev);
            w.y_valid = false;
            let grow = one + h_prev / hi;
            // Off the critical path (it depends on the step sizes only).
            let inv_grow = one / grow;
            let (z, force) = (w.z.as_mut_slice(), w.r.as_mut_slice());
            for (v, f) in z[..m].iter_mut().zip(force.iter_mut()) {
                *f = *v;
                *v = *v * grow;
            }
            if K == 0 {
                self.solve(Mode::LambdaK, hi, Base::Prev, stage)?;
            } else {
                self.solve_small::<K>(false, hi, Base::Prev)?;
            }
            // λ̃ = λ_k + (h_prev/h_i) λ_{k+1} ≈ (1 + h_prev/h_i) λ: the force estimate (the
            // previous one when the stages nearly cancel, h_prev ≈ −h_i).
            let (z, force) = (self.w.z.as_mut_slice(), self.w.r.as_slice());
            if grow.abs() >= V::Real::lit(1e-3) {
                z[..m].iter_mut().for_each(|v| *v = *v * inv_grow);
            } else {
                z[..m].copy_from_slice(&force[..m]);
            }
            self.stats.projected_steps += 1;
            h_prev = hi;
        }
        // The last stage's λ_{k+1}, predicted as the force estimate.
        {
            let z = self.w.z.as_mut_slice();
            let (a, b) = z.split_at_mut(m);
            b[..m].copy_from_slice(a);
        }
        let stage1 = "lambda_{k+1} from phi(x_{k+1}) = 0";
        if K == 0 {
            self.solve(Mode::LambdaK1, h_prev, Base::Given(x), stage1)?;
        } else {
            self.solve_small::<K>(true, h_prev, Base::Given(x))?;
        }
        self.decoupling_guard::<K>(m)?;
        Ok(h_prev)
    }

    /// One step from `w.start`; the result is left in `w.xe`.
    fn step_impl(&mut self, h: V::Real, x: &V) -> Result<(), StepError> {
        self.w.y_valid = false;
        match self.scheme {
            Scheme::Decoupled => match (self.small.is_some(), self.m) {
                (false, _) => self.step_decoupled::<0>(h, x),
                (true, 1) => self.step_decoupled::<1>(h, x),
                (true, 2) => self.step_decoupled::<2>(h, x),
                (true, 3) => self.step_decoupled::<3>(h, x),
                (true, _) => self.step_decoupled::<SMALL_MAX>(h, x),
            },
            Scheme::Coupled => self.solve(
                Mode::Coupled,
                h,
                Base::Given(x),
                "(lambda_k, lambda_{k+1}) from g = 0, phi = 0",
            ),
            Scheme::Symmetric => self.solve(
                Mode::Symmetric,
                h,
                Base::Given(x),
                "lambda from g(x_{k+1}) = 0",
            ),
        }
    }
}

impl<V, F, Ms, H, C, L> Flow<V> for Projected<V, F, Ms, H, C, L>
where
    V: Vector,
    F: Flow<V>,
    Ms: StructureMatrix<V>,
    H: Hamiltonian<V>,
    C: HolonomicConstraint<V>,
    L: LinearSolver<V::Real>,
{
    fn step(&mut self, h: V::Real, x: &mut V) -> Result<(), StepError> {
        if x.len() != self.w.xe.len() {
            return Err(StepError::StateLength {
                flow: "Projected",
                expected: self.w.xe.len(),
                got: x.len(),
            });
        }
        if !super::check_step(h, x)? {
            return Ok(());
        }
        if self.scheme != Scheme::Decoupled {
            self.w.warm.start_from_last(&mut self.w.z);
        }
        let result =
            self.step_impl(h, x)
                .and_then(|()| match ops::first_non_finite(self.w.xe.as_slice()) {
                    Some(component) => Err(StepError::NonFinite { component }),
                    None => Ok(()),
                });
        if let Err(e) = result {
            // A failed iterate must not become the next warm start (nothing was committed) or
            // kept Jacobian.
            self.newton.invalidate_jacobian();
            if let Some(n) = self.newton_k1.as_mut() {
                n.invalidate_jacobian();
            }
            return Err(e);
        }
        // The new state is in the workspace: swap it in (O(1) for heap vectors; the old state
        // left in `xe` is overwritten by the next step).
        core::mem::swap(x, &mut self.w.xe);
        let decoupled = self.scheme == Scheme::Decoupled;
        self.w.warm.commit(&mut self.w.z, h, decoupled);
        self.stats.projected_steps += 1;
        Ok(())
    }
    /// The decoupled scheme fuses the stages (see `step_fused`): one multiplier solve per
    /// stage instead of two. The other schemes take the stages one step at a time.
    fn step_table(
        &mut self,
        h: V::Real,
        table: &CompositionTable,
        x: &mut V,
    ) -> Result<(), StepError> {
        if self.scheme != Scheme::Decoupled || table.stages < 2 {
            for i in 0..table.stages {
                self.step(table.gamma_in::<V::Real>(i) * h, x)?;
            }
            return Ok(());
        }
        if x.len() != self.w.xe.len() {
            return Err(StepError::StateLength {
                flow: "Projected",
                expected: self.w.xe.len(),
                got: x.len(),
            });
        }
        if !super::check_step(h, x)? {
            return Ok(());
        }
        let steps_before = self.stats.projected_steps;
        self.w.y_valid = false;
        let result = match (self.small.is_some(), self.m) {
            (false, _) => self.step_fused::<0>(h, table, x),
            (true, 1) => self.step_fused::<1>(h, table, x),
            (true, 2) => self.step_fused::<2>(h, table, x),
            (true, 3) => self.step_fused::<3>(h, table, x),
            (true, _) => self.step_fused::<SMALL_MAX>(h, table, x),
        }
        .and_then(|h_last| match ops::first_non_finite(self.w.xe.as_slice()) {
            Some(component) => Err(StepError::NonFinite { component }),
            None => Ok(h_last),
        });
        let h_last = match result {
            Ok(h_last) => h_last,
            Err(e) => {
                self.stats.projected_steps = steps_before;
                self.newton.invalidate_jacobian();
                if let Some(n) = self.newton_k1.as_mut() {
                    n.invalidate_jacobian();
                }
                return Err(e);
            }
        };
        core::mem::swap(x, &mut self.w.xe);
        self.w.warm.commit_fused(&mut self.w.z, h_last);
        self.stats.projected_steps += 1;
        Ok(())
    }
    fn order(&self) -> u32 {
        self.inner.order().min(2)
    }
    fn is_symmetric(&self) -> bool {
        self.inner.is_symmetric()
    }
    fn stats(&self) -> FlowStats {
        self.stats + self.inner.stats()
    }
    /// The inner flow dissipates, or the half-steps do: `M Gᵀλ` has a dissipative part when `M` has.
    fn dissipates(&self) -> bool {
        self.inner.dissipates() || self.system.structure.is_dissipative()
    }
}

/// Probes at `x0` whether a second half-step `x ↦ x + s M(x) G(x)ᵀ μ` leaves both `g` and the
/// direction `M Gᵀ μ` unchanged (position constraints with `M Gᵀ` acting on momenta).
/// Every decoupled step re-checks that `g(x_{k+1})` equals `g(y)`, which catches a second
/// half-step that moves `g`; a direction `M Gᵀ` that changes along it is only probed here.
fn probe_decoupled<V, Ms, H, C>(system: &System<Ms, H, C>, x0: &V) -> bool
where
    V: Vector,
    Ms: StructureMatrix<V>,
    C: HolonomicConstraint<V>,
{
    let m = system.constraint.dim();
    let mu: Vec<V::Real> = (0..m)
        .map(|j| V::Real::one() + V::Real::lit(j as f64 / (m as f64 + 1.0)))
        .collect();
    let (mut tmp, mut d0, mut d1, mut xp) = (
        x0.zeros_like(),
        x0.zeros_like(),
        x0.zeros_like(),
        x0.zeros_like(),
    );
    system.constraint_force(x0, &mu, &mut tmp, &mut d0);
    let dn = ops::norm_inf(d0.as_slice());
    if dn == V::Real::zero() {
        return true;
    }
    let s = V::Real::lit(1e-3) * (V::Real::one() + ops::norm_inf(x0.as_slice())) / dn;
    ops::add_scaled(xp.as_mut_slice(), x0.as_slice(), s, d0.as_slice());
    let (mut g0, mut g1) = (vec![V::Real::zero(); m], vec![V::Real::zero(); m]);
    system.constraint.residual(x0, &mut g0);
    system.constraint.residual(&xp, &mut g1);
    system.constraint_force(&xp, &mu, &mut tmp, &mut d1);
    let tol = V::Real::lit(64.0) * V::Real::epsilon();
    let gscale = V::Real::one() + ops::norm_inf(&g0);
    ops::dist_inf(&g0, &g1) <= tol * gscale
        && ops::dist_inf(d0.as_slice(), d1.as_slice()) <= tol * dn
}

/// The base point of a first half-step: the state passed to the step, or the previous
/// stage's `y` (workspace `prev`) in a fused composition.
#[derive(Clone, Copy)]
enum Base<'a, V> {
    Given(&'a V),
    Prev,
}

impl<'a, V> Base<'a, V> {
    #[inline(always)]
    fn resolve(self, prev: &'a V) -> &'a V {
        match self {
            Base::Given(x) => x,
            Base::Prev => prev,
        }
    }
}

/// The decoupled scheme for a few constraints (`m ≤` [`SMALL_MAX`], dense `G`) and a
/// Hamiltonian with a Hessian ([`Hamiltonian::hessian_apply`]): each multiplier system is
/// solved by full Newton on stack arrays ([`SmallNewton`]) with closed-form Jacobians, and the
/// half-step directions `M Gᵀ e_j` are formed once per solve, so that a residual evaluation
/// is an axpy per multiplier plus the model's own arithmetic.
#[derive(Debug, Clone)]
struct SmallPath<V: Vector> {
    newton_k: SmallNewton<V::Real>,
    newton_k1: SmallNewton<V::Real>,
    /// `d_j = M Gᵀ e_j` at the half-step's base point (`x_k`, then `y`).
    d: Vec<V>,
    /// `w_j = (h/2)(d_j + h M ∇²H d_j)` at `x_k`.
    w: Vec<V>,
    /// `g(y)` at the solution of the `λ_k` system (for the decoupling guard).
    g_y: [V::Real; SMALL_MAX],
    /// `φ(y + (h/2) Σ λ_j e_j)` is affine in `λ_{k+1}`: quadratic `H`, constant `M`, and `G`
    /// unchanged along the second half-step (probed at `x0`). Solved by one linear solve.
    affine_k1: bool,
}

impl<V: Vector> SmallPath<V> {
    /// `Some` when the model qualifies at `x0`: at most [`SMALL_MAX`] constraints and a
    /// Hamiltonian that answers [`Hamiltonian::hessian_apply`].
    fn try_new<Ms, H, C>(
        system: &System<Ms, H, C>,
        x0: &V,
        options: NewtonOptions<V::Real>,
    ) -> Option<Self>
    where
        Ms: StructureMatrix<V>,
        H: Hamiltonian<V>,
        C: HolonomicConstraint<V>,
    {
        let m = system.constraint.dim();
        let newton_k = SmallNewton::new(m, options)?;
        let newton_k1 = SmallNewton::new(m, options)?;
        let mut out = x0.zeros_like();
        if !system.hamiltonian.hessian_apply(x0, x0, &mut out) {
            return None;
        }
        let affine_k1 = system.hamiltonian.is_quadratic()
            && system.structure.is_constant()
            && jacobian_constant_along_half_step(system, x0);
        Some(Self {
            newton_k,
            newton_k1,
            d: vec![x0.zeros_like(); m],
            w: vec![x0.zeros_like(); m],
            g_y: [V::Real::zero(); SMALL_MAX],
            affine_k1,
        })
    }
}

/// Probes at `x0` whether `G` is unchanged along a second half-step `x0 + s M Gᵀ μ` (for
/// position constraints and a momentum-only direction it is, exactly): `G v` for a fixed `v`
/// at both points.
fn jacobian_constant_along_half_step<V, Ms, H, C>(system: &System<Ms, H, C>, x0: &V) -> bool
where
    V: Vector,
    Ms: StructureMatrix<V>,
    C: HolonomicConstraint<V>,
{
    let (m, n) = (system.constraint.dim(), x0.len());
    let mu: Vec<V::Real> = (0..m)
        .map(|j| V::Real::one() + V::Real::lit(j as f64 / (m as f64 + 1.0)))
        .collect();
    let (mut tmp, mut d, mut xp, mut v) = (
        x0.zeros_like(),
        x0.zeros_like(),
        x0.zeros_like(),
        x0.zeros_like(),
    );
    system.constraint_force(x0, &mu, &mut tmp, &mut d);
    let dn = ops::norm_inf(d.as_slice());
    if dn == V::Real::zero() {
        return true;
    }
    let s = V::Real::lit(1e-3) * (V::Real::one() + ops::norm_inf(x0.as_slice())) / dn;
    ops::add_scaled(xp.as_mut_slice(), x0.as_slice(), s, d.as_slice());
    for (i, vi) in v.as_mut_slice().iter_mut().enumerate() {
        *vi = V::Real::one() + V::Real::lit(i as f64 / (n as f64 + 1.0));
    }
    let (mut a, mut b) = (vec![V::Real::zero(); m], vec![V::Real::zero(); m]);
    system.constraint.jacobian_apply(x0, &v, &mut a);
    system.constraint.jacobian_apply(&xp, &v, &mut b);
    let scale = V::Real::one() + ops::norm_inf(&a);
    ops::dist_inf(&a, &b) <= V::Real::lit(64.0) * V::Real::epsilon() * scale
}

/// `&mut v[..K]` as an array; `v` has at least `K` entries (the small path sizes its vectors
/// to `m` and dispatches on `K = m`).
#[inline(always)]
fn fixed_mut<T, const K: usize>(v: &mut [T]) -> &mut [T; K] {
    match <&mut [T; K]>::try_from(&mut v[..K]) {
        Ok(a) => a,
        Err(_) => unreachable!("a slice of length K converts to [T; K]"),
    }
}

/// `out = x + (h/2) Σ_j z_j d_j`.
#[inline(always)]
fn half_step<V: Vector, const K: usize>(
    out: &mut V,
    x: &V,
    half: V::Real,
    z: &[V::Real],
    d: &[V; K],
) {
    ops::add_scaled(
        out.as_mut_slice(),
        x.as_slice(),
        half * z[0],
        d[0].as_slice(),
    );
    for j in 1..K {
        ops::axpy(out.as_mut_slice(), half * z[j], d[j].as_slice());
    }
}

/// `λ_k ↦ g(Φ_h(x + (h/2) Σ λ_j d_j))` with the columns `G(y) w_j` (small path).
struct FirstHalf<'a, V: Vector, F, C, const K: usize> {
    h: V::Real,
    half: V::Real,
    x: &'a V,
    inner: &'a mut F,
    constraint: &'a C,
    d: &'a [V; K],
    w: Option<&'a [V; K]>,
    y: &'a mut V,
    /// `g(y)` of the last evaluation.
    g: &'a mut [V::Real; K],
}

impl<V, F, C, const K: usize> NonlinearProblem<V::Real> for FirstHalf<'_, V, F, C, K>
where
    V: Vector,
    F: Flow<V>,
    C: HolonomicConstraint<V>,
{
    fn dim(&self) -> usize {
        K
    }
    fn jacobian_scale(&self) -> V::Real {
        self.h * self.h
    }
    #[inline(always)]
    fn residual(&mut self, z: &[V::Real], f: &mut [V::Real]) -> Result<(), StepError> {
        half_step(self.y, self.x, self.half, z, self.d);
        self.inner.step(self.h, self.y)?;
        self.constraint.residual(&*self.y, f);
        for (g, &v) in self.g.iter_mut().zip(&*f) {
            *g = v;
        }
        Ok(())
    }
    /// `∂g(y)/∂λ_j = G(y) DΦ_h (h/2) d_j` with `DΦ_h ≈ I + h M ∇²H` at `x`: exact when the
    /// inner flow's tangent map is that (a drift, or a kick–drift–kick with a potential linear
    /// in the constrained coordinates), `O(h²)` relative otherwise.
    #[inline(always)]
    fn jacobian_column(&mut self, _z: &[V::Real], j: usize, out: &mut [V::Real]) -> bool {
        match self.w {
            Some(w) => {
                self.constraint.jacobian_apply(&*self.y, &w[j], out);
                true
            }
            None => false,
        }
    }
}

/// `λ_{k+1} ↦ φ(y + (h/2) Σ λ_j e_j)` with exact columns (small path).
struct SecondHalf<'a, V: Vector, Ms, H, C, const K: usize> {
    h: V::Real,
    half: V::Real,
    y: &'a V,
    system: &'a System<Ms, H, C>,
    e: &'a [V; K],
    xe: &'a mut V,
    t1: &'a mut V,
    t2: &'a mut V,
}

impl<V, Ms, H, C, const K: usize> NonlinearProblem<V::Real> for SecondHalf<'_, V, Ms, H, C, K>
where
    V: Vector,
    Ms: StructureMatrix<V>,
    H: Hamiltonian<V>,
    C: HolonomicConstraint<V>,
{
    fn dim(&self) -> usize {
        K
    }
    fn jacobian_scale(&self) -> V::Real {
        self.h
    }
    #[inline(always)]
    fn residual(&mut self, z: &[V::Real], f: &mut [V::Real]) -> Result<(), StepError> {
        half_step(self.xe, self.y, self.half, z, self.e);
        self.system
            .hidden_constraint(&*self.xe, self.t1, self.t2, f);
        Ok(())
    }
    /// `∂φ(x')/∂λ_j = (h/2) G(x') M(x') ∇²H(x') e_j`: exact in the decoupled case, where `G`
    /// and `M Gᵀ` do not change along the second half-step.
    #[inline(always)]
    fn jacobian_column(&mut self, _z: &[V::Real], j: usize, out: &mut [V::Real]) -> bool {
        let sys = self.system;
        if !sys
            .hamiltonian
            .hessian_apply(&*self.xe, &self.e[j], self.t1)
        {
            return false;
        }
        sys.structure.apply(&*self.xe, &*self.t1, self.t2);
        sys.constraint.jacobian_apply(&*self.xe, &*self.t2, out);
        out.iter_mut().for_each(|v| *v = *v * self.half);
        true
    }
}

/// Which multiplier system a [`Stage`] residual evaluates.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Mode {
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
struct Stage<'a, V: Vector, F, Ms, H, C> {
    mode: Mode,
    h: V::Real,
    m: usize,
    x: &'a V,
    inner: &'a mut F,
    system: &'a System<Ms, H, C>,
    y: &'a mut V,
    xe: &'a mut V,
    t1: &'a mut V,
    t2: &'a mut V,
    a_cached: &'a mut V,
    y_valid: &'a mut bool,
    u1: &'a mut V,
    u2: &'a mut V,
    ec: &'a mut V,
    g_y: &'a mut V,
    fixed_point_max_iterations: usize,
    fixed_point_tol: V::Real,
}

impl<V, F, Ms, H, C> Stage<'_, V, F, Ms, H, C>
where
    V: Vector,
    F: Flow<V>,
    Ms: StructureMatrix<V>,
    H: Hamiltonian<V>,
    C: HolonomicConstraint<V>,
{
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
        let half = self.h * V::Real::lit(0.5);
        self.system.constraint_force(self.x, a, self.t1, self.t2);
        // x̂ = x + h/2 M Gᵀ a, written straight into y (the inner flow then steps it in place).
        ops::add_scaled(
            self.y.as_mut_slice(),
            self.x.as_slice(),
            half,
            self.t2.as_slice(),
        );
        self.inner.step(self.h, self.y)?;
        // An element loop: `copy_from_slice` of a run-time length is a `memcpy` call, which
        // costs more than the copy for a handful of multipliers.
        for (c, &v) in self.a_cached.as_mut_slice()[..m].iter_mut().zip(a) {
            *c = v;
        }
        *self.y_valid = true;
        Ok(())
    }

    /// `x' = y + h/2 M(y) G(y)ᵀ b` (decoupled: `M Gᵀ` at `y` equals `M Gᵀ` at `x'`).
    fn end_point_explicit(&mut self, b: &[V::Real]) {
        let half = self.h * V::Real::lit(0.5);
        self.system.constraint_force(&*self.y, b, self.t1, self.t2);
        ops::add_scaled(
            self.xe.as_mut_slice(),
            self.y.as_slice(),
            half,
            self.t2.as_slice(),
        );
    }

    /// `x' = y + h/2 M(x') G(x')ᵀ b` by fixed-point iteration from the explicit guess.
    /// The map contracts with factor `O(h |b|)`; iterate until the change is at round-off.
    fn end_point_implicit(&mut self, b: &[V::Real]) -> Result<(), StepError> {
        let half = self.h * V::Real::lit(0.5);
        self.end_point_explicit(b);
        let tol = self.fixed_point_tol;
        let mut change = V::Real::infinity();
        for _ in 0..self.fixed_point_max_iterations {
            self.system.constraint_force(&*self.xe, b, self.t1, self.t2);
            change = V::Real::zero();
            for ((xe, &y), &d) in self
                .xe
                .as_mut_slice()
                .iter_mut()
                .zip(self.y.as_slice())
                .zip(self.t2.as_slice())
            {
                let new = y + half * d;
                change = change.max((new - *xe).abs());
                *xe = new;
            }
            if change <= tol * (V::Real::one() + ops::norm_inf(self.xe.as_slice())) {
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
            .hidden_constraint(&*self.xe, self.t1, self.t2, out);
    }
}

impl<V, F, Ms, H, C> NonlinearProblem<V::Real> for Stage<'_, V, F, Ms, H, C>
where
    V: Vector,
    F: Flow<V>,
    Ms: StructureMatrix<V>,
    H: Hamiltonian<V>,
    C: HolonomicConstraint<V>,
{
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
        if self.u1.len() < self.x.len() || self.ec.len() < m {
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
            Mode::LambdaK1 => self.end_point_explicit(z),
            Mode::Coupled | Mode::Symmetric => return false,
        }
        let e = &mut self.ec.as_mut_slice()[..m];
        ops::fill_zero(e);
        for &j in cols {
            e[j] = V::Real::one();
        }
        let e = &self.ec.as_slice()[..m];
        let (sys, x) = (self.system, self.x);
        if mode == Mode::LambdaK {
            sys.constraint_force(x, e, self.t1, self.t2);
            if !sys.hamiltonian.hessian_apply(self.x, &*self.t2, self.u1) {
                return false;
            }
            sys.structure.apply(self.x, &*self.u1, self.u2);
            ops::add_scaled(
                self.u1.as_mut_slice(),
                self.t2.as_slice(),
                h,
                self.u2.as_slice(),
            );
            sys.constraint.jacobian_apply(&*self.y, &*self.u1, out);
        } else {
            sys.constraint_force(&*self.y, e, self.t1, self.t2);
            if !sys.hamiltonian.hessian_apply(&*self.xe, &*self.t2, self.u1) {
                return false;
            }
            sys.structure.apply(&*self.xe, &*self.u1, self.u2);
            sys.constraint.jacobian_apply(&*self.xe, &*self.u2, out);
        }
        out.iter_mut().for_each(|v| *v = *v * half);
        true
    }

    fn residual(&mut self, z: &[V::Real], f: &mut [V::Real]) -> Result<(), StepError> {
        let m = self.m;
        match self.mode {
            Mode::LambdaK => {
                self.compute_y(z)?;
                self.system.constraint.residual(&*self.y, f);
                for (g, &v) in self.g_y.as_mut_slice().iter_mut().zip(&*f) {
                    *g = v;
                }
            }
            Mode::LambdaK1 => {
                self.end_point_explicit(z);
                self.hidden(f);
            }
            Mode::Coupled => {
                self.compute_y(&z[..m])?;
                self.end_point_implicit(&z[m..])?;
                let (fg, fp) = f.split_at_mut(m);
                self.system.constraint.residual(&*self.xe, fg);
                // g-rows of the Jacobian scale like h², φ-rows like h: g/h puts every row on the
                // scale h that `jacobian_scale` reports (and asks |g| ≤ |h| ftol).
                let inv_h = V::Real::one() / self.h;
                fg.iter_mut().for_each(|v| *v = *v * inv_h);
                self.hidden(fp);
            }
            Mode::Symmetric => {
                self.compute_y(z)?;
                self.end_point_implicit(z)?;
                self.system.constraint.residual(&*self.xe, f);
            }
        }
        Ok(())
    }
}

/// The checks every constrained flow makes at construction: `x0` finite, `m ≤ n`, independent
/// constraint gradients when the constraint provides its sparse Jacobian ([`constraint_gram`],
/// with the solver `L`), the case (from `options.case` or the brackets at `x0`), and
/// `‖g(x0)‖∞ ≤ options.manifold_tol` — with `check_phi`, also `‖φ(x0)‖∞` in the degenerate
/// case. Returns the case and the multiplier pattern (`None` for a dense `G`).
#[allow(clippy::type_complexity)]
pub(crate) fn check_initial_state<V, Ms, H, C, L>(
    system: &System<Ms, H, C>,
    x0: &V,
    options: &ProjectionOptions<V::Real>,
    check_phi: bool,
) -> Result<(Case, Option<Vec<(usize, usize)>>), SetupError>
where
    V: Vector,
    Ms: StructureMatrix<V>,
    H: Hamiltonian<V>,
    C: HolonomicConstraint<V>,
    L: LinearSolver<V::Real>,
{
    if let Some(component) = ops::first_non_finite(x0.as_slice()) {
        return Err(SetupError::NonFiniteState { component });
    }
    let n = x0.len();
    let m = system.constraint.dim();
    if m > n {
        return Err(SetupError::Dimension {
            what: format!("{m} constraints on a state of dimension {n}"),
        });
    }
    // Redundant constraints first: the bracket matrices would only report them as singular.
    let pattern = constraint_gram::<V, Ms, H, C, L>(system, x0, options.newton.solver)?;
    let brackets = Brackets::new(system);
    let case = match options.case {
        Some(c) => c,
        None if m > MAX_BRACKET_CONSTRAINTS => {
            return Err(SetupError::Dimension {
                what: format!(
                    "{m} constraints: deciding the case from the dense bracket matrices costs O(m^2 n); \
                     set it with ProjectionOptions::with_case (and with_coupling)"
                ),
            });
        }
        None => brackets.case(x0, options.degeneracy_tol, options.rcond)?,
    };
    if let Some(tol) = options.manifold_tol {
        let mut gv = vec![V::Real::zero(); m];
        system.constraint.residual(x0, &mut gv);
        let g = ops::norm_inf(&gv);
        if g.is_nan() || g > tol {
            return Err(SetupError::OffManifold {
                what: "g",
                residual: g.to_f64_lossy(),
            });
        }
        if check_phi && case == Case::Degenerate {
            let phi = ops::norm_inf(&brackets.g_h(x0));
            if phi.is_nan() || phi > tol {
                return Err(SetupError::OffManifold {
                    what: "phi",
                    residual: phi.to_f64_lossy(),
                });
            }
        }
    }
    Ok((case, pattern))
}

/// Above this many constraints the case is not decided from the (dense, `O(m² n)`) bracket
/// matrices: the options must name it.
pub const MAX_BRACKET_CONSTRAINTS: usize = 1024;

/// When the constraint provides its sparse Jacobian ([`HolonomicConstraint::jacobian_entries`]):
/// checks at `x0` that the constraint gradients are independent (`G Gᵀ` non-singular, factored
/// by the backend `choice` picks) and returns the pattern of `G Gᵀ` — the pairs of constraints
/// whose gradients share a state variable, which is the sparsity of the multiplier systems when
/// the inner flow moves each variable along its own gradient components. `None` when `G` is
/// not provided. Errors: [`SetupError::RankDeficient`] naming a redundant constraint.
pub(crate) fn constraint_gram<V, Ms, H, C, L>(
    system: &System<Ms, H, C>,
    x0: &V,
    choice: SolverChoice,
) -> Result<Option<Vec<(usize, usize)>>, SetupError>
where
    V: Vector,
    C: HolonomicConstraint<V>,
    L: LinearSolver<V::Real>,
{
    let (m, n) = (system.constraint.dim(), x0.len());
    let mut g = Triplets::default();
    if !system.constraint.jacobian_entries(x0, &mut g) {
        return Ok(None);
    }
    if let Some(&(row, col, _)) = g.entries.iter().find(|&&(r, c, _)| r >= m || c >= n) {
        return Err(SetupError::Dimension {
            what: format!(
                "constraint Jacobian entry ({row}, {col}) outside {m} constraints x {n} state components"
            ),
        });
    }
    // Rows of G by state variable: (G Gᵀ)_ij = Σ_c G_ic G_jc.
    let mut by_col: Vec<(usize, usize, V::Real)> =
        g.entries.iter().map(|&(r, c, v)| (c, r, v)).collect();
    by_col.sort_unstable_by_key(|&(c, r, _)| (c, r));
    let mut gram: Vec<(usize, usize, V::Real)> = Vec::new();
    let mut start = 0;
    while start < by_col.len() {
        let c = by_col[start].0;
        let end = start + by_col[start..].iter().take_while(|e| e.0 == c).count();
        for &(_, i, a) in &by_col[start..end] {
            for &(_, j, b) in &by_col[start..end] {
                gram.push((i, j, a * b));
            }
        }
        start = end;
    }
    gram.sort_unstable_by_key(|&(i, j, _)| (j, i));
    let pattern: Vec<(usize, usize)> = gram.iter().map(|&(i, j, _)| (i, j)).collect();
    // Every constraint needs a diagonal entry: a constraint with a zero gradient row is
    // redundant (it constrains nothing to first order).
    let structure = match Structure::of_pattern(&pattern) {
        Structure::Banded { lower, upper, .. } => Structure::Banded {
            lower,
            upper,
            nnz: gram.len() + m,
        },
        other => other,
    };
    let mut lin = L::with_structure(m, structure, choice)?;
    lin.clear();
    for &(i, j, v) in &gram {
        lin.add(i, j, v);
    }
    for i in 0..m {
        lin.add(i, i, V::Real::zero());
    }
    match lin.factor() {
        Ok(()) => Ok(Some(pattern)),
        Err(crate::LinearSolveError::Singular { pivot, ratio, .. }) => {
            Err(SetupError::RankDeficient {
                constraint: pivot,
                ratio,
            })
        }
        Err(crate::LinearSolveError::StructurallySingular { column }) => {
            Err(SetupError::RankDeficient {
                constraint: column,
                ratio: 0.0,
            })
        }
        Err(e) => Err(e.into()),
    }
}
