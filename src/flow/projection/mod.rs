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

mod midpoint;
mod small;
mod stage;
mod warm;

use super::{CompositionTable, Flow, FlowStats, Multipliers};
use crate::error::{NewtonError, SetupError, StepError};
use crate::linalg::LinearSolver;
use crate::nonlinear::{Newton, NewtonOptions, NonlinearSolver, SMALL_MAX, SolveReport};
use crate::real::Real;
use crate::system::{
    Case, Hamiltonian, HolonomicConstraint, InitialChecks, StructureMatrix, System,
    check_initial_state, probe_decoupled,
};
use crate::vector::{Vector, ops, take};
use num_traits::Float as _;
use num_traits::{One, Zero};
use small::{FirstHalf, SmallPath};
pub(crate) use small::{SecondHalf, fixed_mut, solve_second_half};
use stage::{Mode, Stage};
use warm::WarmStart;

pub use midpoint::ProjectedMidpoint;

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
    /// scheme's symmetry and invariants hold on the manifold. So must every state a step starts
    /// from that is not the flow's own last result (a state changed between steps by the
    /// caller), or the step fails with [`StepError::OffManifold`](crate::StepError::OffManifold)
    /// instead of silently projecting it back. `None` skips both checks (a step then projects
    /// onto `g = 0`, `φ = 0`: an explicit opt-in). Default `√ε`.
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
    /// The initial-state checks these options ask for.
    pub(crate) fn initial_checks(&self) -> InitialChecks<T> {
        InitialChecks {
            case: self.case,
            degeneracy_tol: self.degeneracy_tol,
            rcond: self.rcond,
            manifold_tol: self.manifold_tol,
            solver: self.newton.solver,
        }
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
    /// `y = Φ_h(x + (h/2) M Gᵀ λ_k)`, the state between the two half-steps.
    y: V,
    /// The previous stage's `y`: the base point of a fused stage (see `step_fused`).
    prev: V,
    /// `x_{k+1}`, the step's result until it is swapped into the caller's state.
    x_next: V,
    /// Scratch states for `Gᵀλ` / `∇H` and `M Gᵀλ` / `M ∇H`.
    t1: V,
    t2: V,
    /// `(λ_k, λ_{k+1})` being solved for (the last successful ones are in `warm`).
    z: V,
    /// Warm starts, double-buffered (see [`warm`]).
    warm: WarmStart<V>,
    /// `λ_k` for which `y` was last computed.
    a_cached: V,
    y_valid: bool,
    /// Scratch for `m` entries: `g(x_{k+1})` for the decoupling guard, the force estimate of a
    /// fused stage.
    r: V,
    /// `g(y)` of the last `λ_k` residual evaluation (general path), for the decoupling guard.
    g_y: V,
    /// Scratch for closed-form Jacobian groups: `∇²H v`, `M ∇²H v`, and the indicator vector
    /// of a column group (`m` entries).
    hess_v: V,
    m_hess_v: V,
    indicator: V,
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
    entry: EntryCheck<V>,
    stats: FlowStats,
}

/// The check of a step's starting state (see [`ProjectionOptions::manifold_tol`]): skipped when
/// the state equals the flow's own last result (as floats).
struct EntryCheck<V: Vector> {
    tol: Option<V::Real>,
    /// A copy of the last result (`valid`), or nothing yet.
    last: V,
    valid: bool,
}

impl<V: Vector> EntryCheck<V> {
    /// A step must start on the manifold (`‖g‖∞`, and with `check_phi` `‖φ‖∞`, within the
    /// tolerance). Called only when the step does not start from the flow's own last result:
    /// one residual evaluation (two with `φ`) when the caller changed the state between
    /// steps. `r` has the constraint's length; `t1`, `t2` are workspace of the state's length.
    fn check<Ms, H, C>(
        &self,
        system: &System<Ms, H, C>,
        x: &V,
        check_phi: bool,
        r: &mut [V::Real],
        t1: &mut V,
        t2: &mut V,
    ) -> Result<(), StepError>
    where
        Ms: StructureMatrix<V>,
        H: Hamiltonian<V>,
        C: HolonomicConstraint<V>,
    {
        let Some(tol) = self.tol else {
            return Ok(());
        };
        let off = |what, r: V::Real| StepError::OffManifold {
            what,
            residual: r.to_f64_lossy(),
            tol: tol.to_f64_lossy(),
        };
        system.constraint.residual(x, r);
        let g = ops::norm_inf(r);
        if g.is_nan() || g > tol {
            return Err(off("g", g));
        }
        if check_phi {
            // φ = G M ∇H, the hidden constraint of the degenerate case.
            system.hidden_constraint(x, t1, t2, r);
            let phi = ops::norm_inf(r);
            if phi.is_nan() || phi > tol {
                return Err(off("phi", phi));
            }
        }
        Ok(())
    }

    /// `x` is the flow's newest result (checked when it was made).
    #[inline(always)]
    fn record(&mut self, x: &V) {
        if self.tol.is_some() {
            self.last.copy_from(x);
            self.valid = true;
        }
    }
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
        let (case, pattern) =
            check_initial_state::<V, Ms, H, C, L>(&system, x0, &options.initial_checks(), true)?;
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
        let k1_exact = small.as_ref().is_some_and(|s| s.affine_k1);
        let zeros = x0.zeros_like();
        let w = Work {
            y: zeros.clone(),
            prev: zeros.clone(),
            x_next: zeros.clone(),
            t1: zeros.clone(),
            t2: zeros,
            z: V::zeros(k_z),
            warm: WarmStart::new(m, k_z, k1_exact),
            a_cached: V::zeros(m),
            y_valid: false,
            r: V::zeros(m),
            g_y: V::zeros(m),
            // Only grouped (sparse) Jacobians use these: no memory for them otherwise.
            hess_v: V::zeros(if grouped { n } else { 0 }),
            m_hess_v: V::zeros(if grouped { n } else { 0 }),
            indicator: V::zeros(if grouped { m } else { 0 }),
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
            entry: EntryCheck {
                tol: options.manifold_tol,
                last: x0.clone(),
                // The initial state was checked above.
                valid: options.manifold_tol.is_some(),
            },
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
    /// on stack arrays with closed-form Jacobians ([`SmallNewton`](crate::nonlinear::SmallNewton)), and one linear solve for
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
    /// projection). After a fused composition step ([`Flow::step_table`]) the pair belongs to
    /// its last stage, whose `λ_k` is not solved for on its own (it is combined with the previous
    /// stage's `λ_{k+1}`): the first entry is then the force estimate `λ̃/(1 + h_{i−1}/h_i)`.
    pub fn multipliers(&self) -> (&[V::Real], &[V::Real]) {
        let z = self.w.warm.last().as_slice();
        match self.scheme {
            Scheme::Symmetric => (&z[..self.m], &z[..self.m]),
            _ => (&z[..self.m], &z[self.m..2 * self.m]),
        }
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
            x_next,
            t1,
            t2,
            z,
            a_cached,
            y_valid,
            hess_v,
            m_hess_v,
            indicator,
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
            x_next,
            t1,
            t2,
            a_cached,
            y_valid,
            hess_v,
            m_hess_v,
            indicator,
            g_y,
            fixed_point_max_iterations: self.fixed_point_max_iterations,
            fixed_point_tol: self.fixed_point_tol,
        };
        let newton = match (mode, self.newton_k1.as_mut()) {
            (Mode::LambdaK1, Some(n)) => n,
            _ => &mut self.newton,
        };
        let result = newton.solve(&mut problem, &mut z.as_mut_slice()[range]);
        Self::finish_solve(&mut self.stats, result, stage)
    }

    /// Counts a successful multiplier solve in `stats`; turns a failed one into the step's error.
    #[inline(always)]
    fn finish_solve(
        stats: &mut FlowStats,
        result: Result<SolveReport<V::Real>, NewtonError<StepError>>,
        stage: &'static str,
    ) -> Result<(), StepError> {
        match result {
            Ok(report) => {
                stats.record(&report);
                Ok(())
            }
            Err(e) => Err(StepError::from_newton(stage, e)),
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
        tally: &mut FlowStats,
    ) -> Result<(), StepError> {
        let Some(small) = self.small.as_mut() else {
            unreachable!("solve_small without a small path");
        };
        let w = &mut self.w;
        let x = base.resolve(&w.prev);
        let half = h * V::Real::lit(0.5);
        // Directions and Jacobian columns: local arrays for stack states (kept in registers
        // across the solve), the preallocated workspace otherwise.
        let (mut d_local, mut w_local, mut t_local): ([V; K], [V; K], [V; 2]);
        let (d, cols, t): (&mut [V; K], &mut [V; K], [&mut V; 2]) = if V::CLONE_IS_COPY {
            d_local = core::array::from_fn(|_| x.clone());
            w_local = core::array::from_fn(|_| x.clone());
            t_local = core::array::from_fn(|_| x.clone());
            let [t1, t2] = &mut t_local;
            (&mut d_local, &mut w_local, [t1, t2])
        } else {
            (
                fixed_mut(&mut small.d),
                fixed_mut(&mut small.w),
                [&mut w.t1, &mut w.t2],
            )
        };
        let [t1, t2] = t;
        // The directions of this half-step, fixed for the whole solve: `(h/2) M Gᵀ e_j` at
        // `x` for the first half-step, at `y` for the second, so that Newton forms
        // `x + Σ λ_j d_j` without scaling `λ` first (one multiplication less on the latency
        // chain of every evaluation).
        let base = if second { &w.y } else { x };
        let mut unit = [V::Real::zero(); K];
        for (j, dj) in d.iter_mut().enumerate() {
            unit[j] = half;
            self.system.constraint_force(base, &unit, t1, dj);
            unit[j] = V::Real::zero();
        }
        let d: &[V; K] = d;
        let (result, stage) = if second {
            let mut problem = SecondHalf {
                h,
                y: &w.y,
                system: &self.system,
                d,
                x_next: &mut w.x_next,
                t1: &mut w.t1,
                t2: &mut w.t2,
            };
            let z: &mut [V::Real; K] = fixed_mut(&mut w.z.as_mut_slice()[K..]);
            let result = solve_second_half(&small.newton_k1, small.affine_k1, &mut problem, z);
            (result, STAGE_LAMBDA_K1)
        } else {
            // w_j = d_j + h M(x) ∇²H(x) d_j, so that G(y) w_j is column j of ∂g/∂λ_k.
            let mut exact = true;
            for (dj, wj) in d.iter().zip(cols.iter_mut()) {
                if !self.system.hamiltonian.hessian_apply(x, dj, t1) {
                    exact = false;
                    break;
                }
                self.system.structure.apply(x, t1, t2);
                let (wj, dj, t2) = (wj.as_mut_slice(), dj.as_slice(), t2.as_slice());
                for ((o, &dv), &tv) in wj.iter_mut().zip(dj).zip(t2) {
                    *o = dv + h * tv;
                }
            }
            let mut problem = FirstHalf {
                h,
                x,
                inner: &mut self.inner,
                constraint: &self.system.constraint,
                d,
                w: exact.then_some(&*cols),
                y: &mut w.y,
                g: fixed_mut(&mut small.g_y),
                scratch: t1,
            };
            let z: &mut [V::Real; K] = fixed_mut(w.z.as_mut_slice());
            (small.newton_k.solve_fixed(&mut problem, z), STAGE_LAMBDA_K)
        };
        Self::finish_solve(tally, result, stage)
    }

    /// The `λ_k` system from `base`: on the small path for `K = m`, the general one for `K = 0`.
    /// The small path counts its work in `tally` (a local of the step, kept in registers), the
    /// general one in the flow's statistics.
    #[inline(always)]
    fn solve_lambda_k<const K: usize>(
        &mut self,
        h: V::Real,
        base: Base<'_, V>,
        tally: &mut FlowStats,
    ) -> Result<(), StepError> {
        if K == 0 {
            self.solve(Mode::LambdaK, h, base, STAGE_LAMBDA_K)
        } else {
            self.solve_small::<K>(false, h, base, tally)
        }
    }

    /// The `λ_{k+1}` system from `y`: on the small path for `K = m`, the general one for `K = 0`
    /// (`tally` as for [`Self::solve_lambda_k`]).
    #[inline(always)]
    fn solve_lambda_k1<const K: usize>(
        &mut self,
        h: V::Real,
        x: &V,
        tally: &mut FlowStats,
    ) -> Result<(), StepError> {
        if K == 0 {
            self.solve(Mode::LambdaK1, h, Base::Given(x), STAGE_LAMBDA_K1)
        } else {
            self.solve_small::<K>(true, h, Base::Given(x), tally)
        }
    }

    /// The decoupled step (RATTLE-like): `λ_k` from `g(x_{k+1}) = 0`, then `λ_{k+1}` from
    /// `φ(x_{k+1}) = 0`. `K = m` on the small path (every loop over the multipliers unrolls),
    /// `K = 0` on the general one.
    ///
    /// The small path's work is counted in `tally` (see [`Self::tallied`]).
    #[inline(always)]
    fn step_decoupled<const K: usize>(
        &mut self,
        h: V::Real,
        x: &V,
        tally: &mut FlowStats,
    ) -> Result<(), StepError> {
        let m = if K == 0 { self.m } else { K };
        self.w.warm.predict_lambda_k(m, h, self.w.z.as_mut_slice());
        self.solve_lambda_k::<K>(h, Base::Given(x), tally)?;
        self.w.warm.record_lambda_k(m, h, self.w.z.as_slice());
        self.w.warm.predict_lambda_k1(m, h, self.w.z.as_mut_slice());
        self.solve_lambda_k1::<K>(h, x, tally)?;
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
        self.system.constraint.residual(&w.x_next, gx);
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
    ///
    /// The small path's work and the interior stages are counted in `tally` (see
    /// [`Self::tallied`]).
    #[inline(always)]
    fn step_fused<const K: usize>(
        &mut self,
        h: V::Real,
        table: &CompositionTable,
        x: &V,
        tally: &mut FlowStats,
    ) -> Result<V::Real, StepError> {
        let m = if K == 0 { self.m } else { K };
        let one = V::Real::one();
        let mut h_prev = table.gamma_in::<V::Real>(0) * h;
        self.w
            .warm
            .predict_lambda_k(m, h_prev, self.w.z.as_mut_slice());
        self.solve_lambda_k::<K>(h_prev, Base::Given(x), tally)?;
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
            self.solve_lambda_k::<K>(hi, Base::Prev, tally)?;
            // λ̃ = λ_k + (h_prev/h_i) λ_{k+1} ≈ (1 + h_prev/h_i) λ: the force estimate (the
            // previous one when the stages nearly cancel, h_prev ≈ −h_i).
            let (z, force) = (self.w.z.as_mut_slice(), self.w.r.as_slice());
            if grow.abs() >= V::Real::lit(1e-3) {
                z[..m].iter_mut().for_each(|v| *v = *v * inv_grow);
            } else {
                z[..m].copy_from_slice(&force[..m]);
            }
            tally.projected_steps += 1;
            h_prev = hi;
        }
        // The last stage's λ_{k+1}, predicted as the force estimate.
        {
            let z = self.w.z.as_mut_slice();
            let (a, b) = z.split_at_mut(m);
            b[..m].copy_from_slice(a);
        }
        self.solve_lambda_k1::<K>(h_prev, x, tally)?;
        self.decoupling_guard::<K>(m)?;
        Ok(h_prev)
    }

    /// What every step shares: the state's length and finiteness (`None` for `h = 0`, the
    /// identity), the `work` from `x` into `w.x_next`, the result's finiteness, and then either
    /// the result swapped into `x` (O(1) for heap vectors) or, on failure, no trace: `x`, the
    /// warm starts (committed by the caller only on success) and the step count as they were,
    /// and no kept Jacobian from a failed iterate.
    #[inline(always)]
    fn run_atomic<R>(
        &mut self,
        h: V::Real,
        x: &mut V,
        work: impl FnOnce(&mut Self, &V) -> Result<R, StepError>,
    ) -> Result<Option<R>, StepError> {
        if x.len() != self.w.x_next.len() {
            return Err(StepError::StateLength {
                flow: "Projected",
                expected: self.w.x_next.len(),
                got: x.len(),
            });
        }
        // The flow's own last result (equal as floats; ±0 alike, which changes no residual)
        // was checked finite and on the manifold when it was made: no scan, no residual.
        let nonzero = super::check_step_size(h)?;
        let from_last = self.entry.valid && ops::equal(x.as_slice(), self.entry.last.as_slice());
        if !from_last && let Some(component) = ops::first_non_finite(x.as_slice()) {
            return Err(StepError::NonFinite { component });
        }
        if !nonzero {
            return Ok(None);
        }
        if !from_last {
            self.check_entry(x)?;
        }
        let steps_before = self.stats.projected_steps;
        let result =
            work(self, x).and_then(|r| match ops::first_non_finite(self.w.x_next.as_slice()) {
                Some(component) => Err(StepError::NonFinite { component }),
                None => Ok(r),
            });
        match result {
            Ok(r) => {
                take(x, &mut self.w.x_next);
                self.entry.record(x);
                Ok(Some(r))
            }
            Err(e) => {
                self.stats.projected_steps = steps_before;
                self.newton.invalidate_jacobian();
                if let Some(n) = self.newton_k1.as_mut() {
                    n.invalidate_jacobian();
                }
                Err(e)
            }
        }
    }

    /// A step must start on the manifold (see [`EntryCheck::check`]).
    fn check_entry(&mut self, x: &V) -> Result<(), StepError> {
        let check_phi = self.scheme != Scheme::Symmetric;
        let w = &mut self.w;
        let r = &mut w.r.as_mut_slice()[..self.m];
        self.entry
            .check(&self.system, x, check_phi, r, &mut w.t1, &mut w.t2)
    }

    /// The fused composition dispatched on the multiplier count (see `step_fused`).
    fn step_fused_any(
        &mut self,
        h: V::Real,
        table: &CompositionTable,
        x: &V,
    ) -> Result<V::Real, StepError> {
        self.w.y_valid = false;
        self.tallied(|flow, t| match (flow.small.is_some(), flow.m) {
            (false, _) => flow.step_fused::<0>(h, table, x, t),
            (true, 1) => flow.step_fused::<1>(h, table, x, t),
            (true, 2) => flow.step_fused::<2>(h, table, x, t),
            (true, 3) => flow.step_fused::<3>(h, table, x, t),
            (true, _) => flow.step_fused::<SMALL_MAX>(h, table, x, t),
        })
    }

    /// Runs `work` with a local tally of solves and stages, added to the flow's statistics
    /// once afterwards, failed or not: a local stays in registers, where updating the
    /// statistics after every solve was a read-modify-write of memory per counter.
    #[inline(always)]
    fn tallied<R>(&mut self, work: impl FnOnce(&mut Self, &mut FlowStats) -> R) -> R {
        let mut tally = FlowStats::default();
        let result = work(self, &mut tally);
        self.stats = self.stats + tally;
        result
    }

    /// One step from `x`; the result is left in `w.x_next`.
    fn step_impl(&mut self, h: V::Real, x: &V) -> Result<(), StepError> {
        self.w.y_valid = false;
        match self.scheme {
            Scheme::Decoupled => self.tallied(|flow, t| match (flow.small.is_some(), flow.m) {
                (false, _) => flow.step_decoupled::<0>(h, x, t),
                (true, 1) => flow.step_decoupled::<1>(h, x, t),
                (true, 2) => flow.step_decoupled::<2>(h, x, t),
                (true, 3) => flow.step_decoupled::<3>(h, x, t),
                (true, _) => flow.step_decoupled::<SMALL_MAX>(h, x, t),
            }),
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
        if self.scheme != Scheme::Decoupled {
            self.w.warm.start_from_last(&mut self.w.z);
        }
        if self
            .run_atomic(h, x, |flow, x| flow.step_impl(h, x))?
            .is_some()
        {
            let decoupled = self.scheme == Scheme::Decoupled;
            self.w.warm.commit(&mut self.w.z, h, decoupled);
            self.stats.projected_steps += 1;
        }
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
        let fused = self.run_atomic(h, x, |flow, x| flow.step_fused_any(h, table, x))?;
        if let Some(h_last) = fused {
            self.w.warm.commit_fused(&mut self.w.z, h_last);
            self.stats.projected_steps += 1;
        }
        Ok(())
    }
    /// The fused composition works on the workspace and swaps the result in only on success.
    fn step_table_is_atomic(&self) -> bool {
        self.scheme == Scheme::Decoupled
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
    fn multipliers(&self) -> Option<Multipliers<'_, V::Real>> {
        Some(Projected::multipliers(self))
    }
    /// The inner flow dissipates, or the half-steps do: `M Gᵀλ` has a dissipative part when `M` has.
    fn dissipates(&self) -> bool {
        self.inner.dissipates() || self.system.structure.is_dissipative()
    }
}

/// The stage names errors carry.
const STAGE_LAMBDA_K: &str = "lambda_k from g(x_{k+1}) = 0";
const STAGE_LAMBDA_K1: &str = "lambda_{k+1} from phi(x_{k+1}) = 0";

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
