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

mod decoupled;
mod entry;
mod fused;
mod gram;
mod hidden;
mod midpoint;
mod options;
mod reprojected;
mod small;
mod stage;
mod warm;

use super::{CompositionTable, Flow, FlowStats, Ledger, Multipliers};
use crate::error::{SetupError, StepError};
use crate::linalg::LinearSolver;
use crate::nonlinear::{DiagonalNewton, Newton};
use crate::system::Model;
use crate::system::{
    Case, HolonomicConstraint, MechanicalForm, StructureMatrix, check_initial_state,
    half_step_keeps_jacobian, probe_decoupled,
};
use crate::vector::{Vector, ops, take};
use entry::EntryCheck;
use fused::StageSizes;
use gram::Gram;
pub(crate) use hidden::{Hidden, HiddenSolver};
use num_traits::{One, Zero};
use small::SmallPath;
use stage::Mode;
use warm::WarmStart;

pub use midpoint::ProjectedMidpoint;
pub use options::{Coupling, ProjectionOptions, Scheme};
pub use reprojected::{ManifoldProjection, Reprojected};

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
    /// The time and energies at the start of the inner flow's sub-step (see [`Ledger`]).
    ledger_in: Ledger<V::Real>,
    /// The ledger after the inner evaluation that produced `y`.
    ledger_y: Ledger<V::Real>,
}

/// Multiplier Jacobians of a model of mechanical form are summed from `G`'s entries
/// ([`gram`]) when their pattern needs more colour groups than this.
const GROUPS_SUMMED_ABOVE: usize = 3;

/// The projected flow of Zhang & Deng (2004, §3) around an inner flow `F` (see the module docs).
///
/// Built with [`FlowExt::projected`](super::FlowExt::projected). Order `min(2, order(F))`,
/// symmetric when `F` is. The multiplier systems are solved by [`Newton`] with the linear solver
/// `L` (default: the state storage's dense solver); workspace is allocated at construction,
/// so a step allocates nothing.
pub struct Projected<V: Vector, F, Sys, L = <V as Vector>::Solver> {
    inner: F,
    system: Sys,
    scheme: Scheme,
    m: usize,
    /// Newton for `λ_k` (decoupled), `(λ_k, λ_{k+1})` (coupled) or `λ` (symmetric).
    newton: Newton<V, L>,
    /// Newton for `λ_{k+1}` (decoupled only): a separate solver keeps its own Jacobian.
    newton_k1: Option<Newton<V, L>>,
    /// The small decoupled path (see [`SmallPath`]), when it applies.
    small: Option<SmallPath<V>>,
    /// The decoupled systems of independent constraints (no two read a common coordinate:
    /// the pattern of `G Gᵀ` is diagonal), solved by [`DiagonalNewton`] instead of `newton`
    /// and `newton_k1`.
    diagonal: Option<DiagonalNewton<V::Real>>,
    /// With `diagonal`, the inverse masses of a model of mechanical form
    /// ([`MechanicalForm`]): the `λ_{k+1}` system is affine and solved by one division.
    inverse_mass: Option<Vec<V::Real>>,
    /// The multiplier Jacobians summed from `G`'s entries (see [`gram`]), for a model of
    /// mechanical form whose multipliers couple.
    gram: Option<Gram<V::Real>>,
    /// `diagonal` is in use: until a solve had to difference its diagonal (then `newton`'s
    /// kept Jacobians cost less).
    diagonal_active: bool,
    /// The last `λ_k` solve took its quadratic model's root: the next starts from zero.
    quadratic_k: bool,
    fixed_point_max_iterations: usize,
    /// Bound on `|g(x_{k+1}) − g(y)|` in the decoupled variant (exactly 0 when it applies).
    guard_tol: V::Real,
    /// Relative tolerance of the fixed point for the implicit end point.
    fixed_point_tol: V::Real,
    w: Work<V>,
    entry: EntryCheck<V>,
    stats: FlowStats,
}

impl<V, F, Sys, L> core::fmt::Debug for Projected<V, F, Sys, L>
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

impl<V, F, Sys, L> Projected<V, F, Sys, L>
where
    V: Vector,
    F: Flow<V>,
    Sys: Model<V>,
    L: LinearSolver<V::Real>,
{
    /// Builds the projected flow, deciding case and coupling at `x0` unless `options` fix them.
    ///
    /// Errors: non-finite `x0`; `⟨g,g⟩` and `⟨φ,g⟩` both singular (redundant constraints, a
    /// Casimir of `M`); `⟨g,g⟩` neither zero nor invertible; a linear solver too small.
    pub fn try_new(
        mut inner: F,
        system: Sys,
        x0: &V,
        options: ProjectionOptions<V::Real>,
    ) -> Result<Self, SetupError> {
        let (case, pattern) =
            check_initial_state::<V, Sys, L>(&system, x0, &options.initial_checks(), true)?;
        let (n, m) = (x0.len(), system.constraint().dim());
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
        let diagonal = pattern_m
            .filter(|p| p.iter().all(|&(r, c)| r == c))
            .map(|_| DiagonalNewton::new(m, options.newton));
        // φ(y + (h/2) M Gᵀλ) = φ(y) − (h/2) G W⁻¹ Gᵀ λ for a model of mechanical form whose
        // half-steps keep G (a declaration its evaluations contradict leaves the general
        // solve).
        // Sums pay where the grouped products are many: at three colour groups or fewer (a
        // chain's tridiagonal pattern) the grouped products cost as little, and their kept
        // Jacobians less (`cargo bench --bench rigid_rattle`; `lieflow run scenes/chain1000.toml`).
        let summable = newton.evaluations_per_jacobian() > GROUPS_SUMMED_ABOVE;
        let inverse_mass = pattern_m
            .filter(|_| diagonal.is_some() || summable)
            .filter(|_| half_step_keeps_jacobian(&system, x0))
            .and_then(|_| {
                MechanicalForm::of(&system, system.hamiltonian(), x0)
                    .ok()
                    .flatten()
            })
            .map(|form| form.inverse_mass);
        // Jacobians summed from G's entries where the pattern couples multipliers (a diagonal
        // one solves each alone).
        let gram = inverse_mass
            .as_ref()
            .filter(|_| diagonal.is_none())
            .and_then(|w| Gram::new(system.constraint(), x0, w.len()));
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
            ledger_in: Ledger::default(),
            ledger_y: Ledger::default(),
        };
        Ok(Self {
            inner,
            system,
            scheme,
            m,
            newton,
            newton_k1,
            small,
            diagonal,
            inverse_mass,
            gram,
            diagonal_active: true,
            quadratic_k: false,
            fixed_point_max_iterations: options.fixed_point_max_iterations,
            guard_tol: options.newton.ftol,
            fixed_point_tol: options.newton.xtol,
            w,
            // The initial state was checked above.
            entry: EntryCheck::new(options.manifold_tol, x0),
            stats: FlowStats::default(),
        })
    }

    /// The variant in use.
    pub fn scheme(&self) -> Scheme {
        self.scheme
    }

    /// The model.
    pub fn system(&self) -> &Sys {
        &self.system
    }

    /// `true` when the flow runs the small decoupled path: the decoupled scheme with a dense
    /// `G` of at most [`SMALL_MAX`](crate::nonlinear::SMALL_MAX) constraints and a Hamiltonian with a Hessian — full Newton
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
        let from_last = self.entry.is_last(x);
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
            Scheme::Decoupled => self.fused_stages(1, StageSizes::Single(h), x).map(drop),
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

impl<V, F, Sys, L> Flow<V> for Projected<V, F, Sys, L>
where
    V: Vector,
    F: Flow<V>,
    Sys: Model<V>,
    L: LinearSolver<V::Real>,
{
    fn step(&mut self, h: V::Real, x: &mut V) -> Result<(), StepError> {
        self.step_at(&mut Ledger::default(), h, x)
    }
    /// The half-steps own no extended coordinate: the ledger is the inner flow's, from the
    /// evaluation that produced the accepted `y`.
    fn step_at(
        &mut self,
        ledger: &mut Ledger<V::Real>,
        h: V::Real,
        x: &mut V,
    ) -> Result<(), StepError> {
        self.w.ledger_in = *ledger;
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
            *ledger = self.w.ledger_y;
        }
        Ok(())
    }
    /// The warm starts, the multipliers, and the two choices the next solves depend on (the
    /// diagonal solver in use, `λ_k` from zero), then the inner flow's memory.
    fn save_memory(&mut self, out: &mut Vec<V::Real>) {
        self.w.warm.save(out);
        out.extend_from_slice(self.w.z.as_slice());
        let flag = |b: bool| if b { V::Real::one() } else { V::Real::zero() };
        out.extend([flag(self.diagonal_active), flag(self.quadratic_k)]);
        self.newton.invalidate_jacobian();
        if let Some(n) = self.newton_k1.as_mut() {
            n.invalidate_jacobian();
        }
        self.inner.save_memory(out);
    }
    fn restore_memory(&mut self, from: &mut &[V::Real]) {
        self.w.warm.restore(from);
        let z = self.w.z.as_mut_slice();
        let saved = super::take_memory(from, z.len());
        z[..saved.len()].copy_from_slice(saved);
        if let [active, quadratic] = *super::take_memory(from, 2) {
            self.diagonal_active = !active.is_zero();
            self.quadratic_k = !quadratic.is_zero();
        }
        self.newton.invalidate_jacobian();
        if let Some(n) = self.newton_k1.as_mut() {
            n.invalidate_jacobian();
        }
        self.inner.restore_memory(from);
    }
    /// The decoupled scheme fuses the stages (see `step_fused`): one multiplier solve per
    /// stage instead of two. The other schemes take the stages one step at a time.
    fn step_table(
        &mut self,
        ledger: &mut Ledger<V::Real>,
        h: V::Real,
        table: &CompositionTable,
        x: &mut V,
    ) -> Result<(), StepError> {
        if self.scheme != Scheme::Decoupled || table.stages < 2 {
            let start = *ledger;
            for i in 0..table.stages {
                self.step_at(ledger, table.gamma_in::<V::Real>(i) * h, x)
                    .inspect_err(|_| *ledger = start)?;
            }
            return Ok(());
        }
        self.run_fused(ledger, h, x, table.stages, StageSizes::Table(table, h))
    }
    /// `n` equal steps fused as a composition's stages are (decoupled scheme, `n ≥ 2`): one
    /// multiplier solve a step plus the last step's `λ_{k+1}`.
    fn step_repeated(
        &mut self,
        ledger: &mut Ledger<V::Real>,
        h: V::Real,
        n: u32,
        x: &mut V,
    ) -> Result<(), StepError> {
        if self.scheme != Scheme::Decoupled || n < 2 {
            return super::step_each(self, ledger, h, n, x);
        }
        self.run_fused(ledger, h, x, n as usize, StageSizes::Equal(h))
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
    /// The inner flow's workspace (and what it keeps of a state) for states like `x`.
    fn prepare(&mut self, x: &V) {
        self.inner.prepare(x);
    }

    fn stats(&self) -> FlowStats {
        self.stats + self.inner.stats()
    }
    fn multipliers(&self) -> Option<Multipliers<'_, V::Real>> {
        Some(Projected::multipliers(self))
    }
    /// The inner flow dissipates, or the half-steps do: `M Gᵀλ` has a dissipative part when `M` has.
    fn dissipates(&self) -> bool {
        self.inner.dissipates() || self.system.structure().is_dissipative()
    }
}

/// Whether `K` multipliers fit a degenerate projection of states of type `V` (`2K ≤ n`, which
/// [`Projected::try_new`] requires): the small path's dispatch is compiled only for the counts a
/// state can hold (a stack state of 4 entries takes at most 2), the others fall to the general
/// path they can never reach. A constant per type, so the unreachable steps are not generated.
pub(crate) struct SmallFits<V, const K: usize>(core::marker::PhantomData<V>);

impl<V: Vector, const K: usize> SmallFits<V, K> {
    pub(crate) const OK: bool = 2 * K <= V::MAX_LEN;
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
