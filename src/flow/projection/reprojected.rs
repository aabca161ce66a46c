//! A projection after every step of a flow onto `g = 0` and, in the degenerate case, the hidden
//! constraint `φ = 0`: the wrapper that keeps a non-symmetric scheme (an extrapolation) on the
//! manifold.

use super::{HiddenSolver, ProjectionOptions, SmallFits};
use crate::error::{NewtonError, SetupError, StepError};
use crate::flow::{Flow, FlowStats, Ledger, Multipliers};
use crate::nonlinear::{Newton, NonlinearProblem, NonlinearSolver, SMALL_MAX};
use crate::system::{Case, HolonomicConstraint, Model, check_initial_state};
use crate::vector::{Vector, ops};
use num_traits::One as _;

/// `inner`, then the standard projection onto the constraint manifold (Hairer, Lubich &
/// Wanner, *Geometric Numerical Integration*, §IV.4 and §VII.1.3):
///
/// 1. `x ← x + G(x̃)ᵀ μ` with `g(x) = 0` (`x̃` the inner flow's result): the nearest point
///    to first order in the Euclidean metric. For a mechanical model `G = [G_q 0]`, so only
///    the positions move.
/// 2. In the degenerate case (a hidden constraint exists), `x ← x + M(x) G(x)ᵀ ν` with
///    `φ(x) = G M ∇H = 0`. For `H = ½ pᵀW⁻¹p + V(q)` and canonical `M` this is
///    `p ← p − G_qᵀ ν`, `(G_q W⁻¹ G_qᵀ) ν = G_q W⁻¹ p`: orthogonal in the kinetic metric
///    `⟨a, b⟩ = aᵀ W⁻¹ b`, so it only removes kinetic energy, `½ |Δp|²_{W⁻¹} ≥ 0` — the
///    projection cannot feed energy into the system.
///
/// When `inner` has order `r` and keeps `g`, `φ` to `O(h^{r+1})` per step, the projected map
/// has order `r` too (GNI Theorem IV.4.1): the projection moves the state by the defect only.
/// Each part is skipped when its residual is already within the Newton tolerance, so on a
/// flow that stays on the manifold the wrapper costs two residual evaluations a step.
///
/// The projection's energy change is not booked in the [`Ledger`]: it is of the size of the
/// inner flow's local error, so the balance keeps the inner flow's order.
pub struct Reprojected<V: Vector, F, Sys> {
    inner: F,
    /// Everything but the inner flow: compiled once per model and storage, not per flow.
    projector: ManifoldProjection<V, Sys>,
}

/// The two projections of [`Reprojected`] and their workspace: onto `g = 0` and, in the
/// degenerate case, `φ = 0` (see [`Reprojected`]). Also what an adaptive flow runs after each
/// accepted step ([`AcceptStep`](crate::flow::AcceptStep)).
pub struct ManifoldProjection<V: Vector, Sys> {
    system: Sys,
    /// Newton for `μ` (positions).
    positions: Newton<V>,
    /// The hidden-constraint projection (degenerate case only).
    hidden: Option<HiddenSolver<V>>,
    /// The state the step started from (restored on failure).
    start: V,
    /// `x̃`: the inner flow's result, the base of both projections.
    base: V,
    t1: V,
    t2: V,
    mu: Vec<V::Real>,
    nu: Vec<V::Real>,
    r: Vec<V::Real>,
    ftol: V::Real,
    stats: FlowStats,
    projections: u64,
}

impl<V: Vector, F: core::fmt::Debug, Sys> core::fmt::Debug for Reprojected<V, F, Sys> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Reprojected")
            .field("inner", &self.inner)
            .field("hidden_projection", &self.projector.hidden.is_some())
            .field("projections", &self.projector.projections)
            .finish_non_exhaustive()
    }
}

impl<V: Vector, F: Flow<V>, Sys: Model<V>> Reprojected<V, F, Sys> {
    /// `inner` followed by the projection for `system`, built for states shaped like `x0`,
    /// which must lie on the manifold to `options.manifold_tol` (as for
    /// [`Projected`](super::Projected)). `options.case` names the case or it is decided from
    /// the brackets at `x0`; `options.newton` drives both solves (its `ftol` is the accepted
    /// residual).
    ///
    /// # Errors
    /// The initial-state checks of a projection ([`SetupError`]).
    pub fn try_new(
        inner: F,
        system: Sys,
        x0: &V,
        options: ProjectionOptions<V::Real>,
    ) -> Result<Self, SetupError> {
        let projector = ManifoldProjection::try_new(system, x0, options)?;
        Ok(Self { inner, projector })
    }

    /// The wrapped flow.
    pub fn inner(&self) -> &F {
        &self.inner
    }

    /// Steps after which the state had to be moved (a residual above the tolerance).
    pub fn projections(&self) -> u64 {
        self.projector.projections
    }
}

impl<V: Vector, Sys: Model<V>> ManifoldProjection<V, Sys> {
    /// The projections for `system`, built for states shaped like `x0`, which must lie on the
    /// manifold to `options.manifold_tol`; `options.case` names the case or it is decided from
    /// the brackets at `x0`; `options.newton` drives both solves (its `ftol` is the accepted
    /// residual).
    ///
    /// # Errors
    /// The initial-state checks of a projection ([`SetupError`]).
    pub fn try_new(
        system: Sys,
        x0: &V,
        options: ProjectionOptions<V::Real>,
    ) -> Result<Self, SetupError> {
        let (case, pattern) =
            check_initial_state::<V, Sys, V::Solver>(&system, x0, &options.initial_checks(), true)?;
        let m = system.constraint().dim();
        let pattern = pattern.filter(|_| m > SMALL_MAX);
        let positions = Newton::with_pattern(m, options.newton, pattern.as_deref())?;
        let hidden = match case {
            // The small solver only for the counts the dispatch in `project` compiles (a
            // stack state holds at most half its length in multipliers there).
            Case::Degenerate if m > SMALL_MAX || 2 * m > V::MAX_LEN => Some(HiddenSolver::General(
                Newton::with_pattern(m, options.newton, pattern.as_deref())?,
            )),
            Case::Degenerate => Some(HiddenSolver::new(&system, x0, options.newton, None)?),
            Case::NonDegenerate => None,
        };
        let zero = <V::Real as num_traits::Zero>::zero();
        Ok(Self {
            system,
            positions,
            hidden,
            start: x0.zeros_like(),
            base: x0.zeros_like(),
            t1: x0.zeros_like(),
            t2: x0.zeros_like(),
            mu: vec![zero; m],
            nu: vec![zero; m],
            r: vec![zero; m],
            ftol: options.newton.ftol,
            stats: FlowStats::default(),
            projections: 0,
        })
    }

    /// How many times a projection moved the state.
    pub fn projections(&self) -> u64 {
        self.projections
    }
}

impl<V: Vector, Sys> core::fmt::Debug for ManifoldProjection<V, Sys> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("ManifoldProjection")
            .field("hidden_projection", &self.hidden.is_some())
            .field("projections", &self.projections)
            .finish_non_exhaustive()
    }
}

impl<V: Vector, Sys: Model<V>> crate::flow::AcceptStep<V> for ManifoldProjection<V, Sys> {
    fn accept(&mut self, x: &mut V) -> Result<(), StepError> {
        self.project(x)
    }
    fn stats(&self) -> FlowStats {
        self.stats
    }
    fn forget(&mut self) {
        self.invalidate();
    }
}

impl<V: Vector, Sys: Model<V>> ManifoldProjection<V, Sys> {
    /// The hidden-constraint projection from `base` into `x` (`K = m` on the small path).
    #[inline(always)]
    fn project_hidden<const K: usize>(
        &mut self,
        x: &mut V,
    ) -> Result<crate::nonlinear::SolveReport<V::Real>, NewtonError<StepError>> {
        let Some(hidden) = self.hidden.as_mut() else {
            unreachable!("project_hidden without a hidden projection");
        };
        hidden.project::<K, _>(
            &self.system,
            &self.base,
            x,
            &mut self.t1,
            &mut self.t2,
            &mut self.nu,
        )
    }

    /// Both projections of `x` in place. On error `x` is whatever the solves left.
    fn project(&mut self, x: &mut V) -> Result<(), StepError> {
        let tol = self.ftol;
        let mut moved = false;
        self.system.constraint().residual(x, &mut self.r);
        if ops::norm_inf(&self.r) > tol {
            moved = true;
            self.base.copy_from(x);
            ops::fill_zero(&mut self.mu);
            let mut problem = Onto {
                base: &self.base,
                x: &mut *x,
                t1: &mut self.t1,
                system: &self.system,
            };
            let report = self
                .positions
                .solve(&mut problem, &mut self.mu)
                .map_err(|e| StepError::from_newton("re-projection onto g = 0", e))?;
            problem.place(&self.mu);
            self.stats.record(&report);
        }
        if self.hidden.is_some() {
            self.system
                .hidden_constraint(x, &mut self.t1, &mut self.t2, &mut self.r);
            if ops::norm_inf(&self.r) > tol {
                moved = true;
                self.base.copy_from(x);
                ops::fill_zero(&mut self.nu);
                // Only the counts the storage can hold on the small path (the general path,
                // which any count can take, otherwise).
                let solved = match self.r.len() {
                    1 => self.project_hidden::<1>(x),
                    2 if SmallFits::<V, 2>::OK => self.project_hidden::<2>(x),
                    3 if SmallFits::<V, 3>::OK => self.project_hidden::<3>(x),
                    4 if SmallFits::<V, SMALL_MAX>::OK => self.project_hidden::<SMALL_MAX>(x),
                    _ => self.project_hidden::<0>(x),
                };
                let report = solved.map_err(|e| {
                    if let Some(HiddenSolver::General(n)) = self.hidden.as_mut() {
                        n.invalidate_jacobian();
                    }
                    StepError::from_newton("re-projection onto phi = 0", e)
                })?;
                self.stats.record(&report);
            }
        }
        if moved {
            self.projections += 1;
        }
        Ok(())
    }
}

impl<V: Vector, Sys: Model<V>> ManifoldProjection<V, Sys> {
    /// Projects the inner flow's result `x`; on failure (or a non-finite result) `x` and
    /// `ledger` go back to the step's start and `ledger_start`.
    fn finish(
        &mut self,
        ledger: &mut Ledger<V::Real>,
        ledger_start: Ledger<V::Real>,
        x: &mut V,
    ) -> Result<(), StepError> {
        let result = self
            .project(x)
            .and_then(|()| match ops::first_non_finite(x.as_slice()) {
                Some(component) => Err(StepError::NonFinite { component }),
                None => Ok(()),
            });
        if result.is_err() {
            x.copy_from(&self.start);
            *ledger = ledger_start;
        }
        result
    }

    /// Forgets the kept Jacobians (the projections start from zero every step).
    fn invalidate(&mut self) {
        self.positions.invalidate_jacobian();
        if let Some(HiddenSolver::General(n)) = self.hidden.as_mut() {
            n.invalidate_jacobian();
        }
    }
}

/// `F(μ) = g(base + G(base)ᵀ μ)`.
struct Onto<'a, V: Vector, Sys> {
    base: &'a V,
    x: &'a mut V,
    t1: &'a mut V,
    system: &'a Sys,
}

impl<V: Vector, Sys: Model<V>> Onto<'_, V, Sys> {
    fn place(&mut self, mu: &[V::Real]) {
        self.x.copy_from(self.base);
        self.system.constraint().jacobian_transpose_apply_add(
            self.base,
            mu,
            V::Real::one(),
            self.x,
        );
    }
}

impl<V: Vector, Sys: Model<V>> NonlinearProblem<V::Real> for Onto<'_, V, Sys> {
    type Error = StepError;

    fn dim(&self) -> usize {
        self.system.constraint().dim()
    }

    fn residual(&mut self, mu: &[V::Real], out: &mut [V::Real]) -> Result<(), StepError> {
        self.place(mu);
        self.system.constraint().residual(self.x, out);
        Ok(())
    }

    /// `G(x(μ)) G(base)ᵀ e_j`.
    fn jacobian_column(&mut self, mu: &[V::Real], j: usize, out: &mut [V::Real]) -> bool {
        self.jacobian_group(mu, &[j], out)
    }

    /// `G(x(μ)) G(base)ᵀ Σ_{j ∈ cols} e_j`.
    fn jacobian_group(&mut self, mu: &[V::Real], cols: &[usize], out: &mut [V::Real]) -> bool {
        self.place(mu);
        ops::fill_zero(out);
        let c = self.system.constraint();
        // t1 = G(base)ᵀ Σ e_j, then out = G(x) t1.
        ops::fill_zero(self.t1.as_mut_slice());
        for &j in cols {
            out[j] = V::Real::one();
        }
        c.jacobian_transpose_apply_add(self.base, out, V::Real::one(), self.t1);
        c.jacobian_apply(self.x, self.t1, out);
        true
    }
}

impl<V: Vector, F: Flow<V>, Sys: Model<V>> Flow<V> for Reprojected<V, F, Sys> {
    fn step(&mut self, h: V::Real, x: &mut V) -> Result<(), StepError> {
        self.step_at(&mut Ledger::default(), h, x)
    }

    fn step_at(
        &mut self,
        ledger: &mut Ledger<V::Real>,
        h: V::Real,
        x: &mut V,
    ) -> Result<(), StepError> {
        let p = &mut self.projector;
        if x.len() != p.start.len() {
            return Err(StepError::StateLength {
                flow: "re-projection",
                expected: p.start.len(),
                got: x.len(),
            });
        }
        p.start.copy_from(x);
        let l0 = *ledger;
        self.inner.step_at(ledger, h, x)?;
        p.finish(ledger, l0, x)
    }

    fn order(&self) -> u32 {
        self.inner.order()
    }

    fn is_symmetric(&self) -> bool {
        false
    }

    fn prepare(&mut self, x: &V) {
        self.inner.prepare(x);
    }

    fn stats(&self) -> FlowStats {
        self.inner.stats() + self.projector.stats
    }

    fn multipliers(&self) -> Option<Multipliers<'_, V::Real>> {
        self.inner.multipliers()
    }

    fn dissipates(&self) -> bool {
        self.inner.dissipates()
    }

    fn save_memory(&mut self, out: &mut Vec<V::Real>) {
        // The projections start from zero every step; their kept Jacobians cannot be saved.
        self.projector.invalidate();
        self.inner.save_memory(out);
    }

    fn restore_memory(&mut self, from: &mut &[V::Real]) {
        self.projector.invalidate();
        self.inner.restore_memory(from);
    }
}
