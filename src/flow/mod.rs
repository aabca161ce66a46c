//! One-step maps `x ↦ Φ_h(x)` and how to build them: closed-form sub-flows, composition
//! (sequence, Strang, Yoshida and other symmetric tables) and the projection half-steps of
//! Zhang & Deng (2004, §3).
//!
//! Flows are values; composition and projection are wrappers, chained like iterator adapters:
//!
//! ```text
//! kick.strang(drift).projected(system, &x0, options)?.triple_jump()
//! ```

mod adaptive;
pub mod coefficients;
mod compose;
mod constrained_dg;
mod contraction;
mod entry_pairs;
mod exact;
mod extrapolated;
mod flow_enum;
mod forcing;
mod implicit;
mod ledger;
mod linear;
mod linear_drift;
pub(crate) use linear_drift::fall_series;
mod petrov_galerkin;
mod predictor;
mod projection;
mod reduced;
mod schur;
mod stage_blocks;
mod step_end;

pub use adaptive::{
    AcceptStep, AdaptiveExtrapolation, AdaptiveOptions, AdaptiveStats, DensityFn, ReversibleSteps,
    StepDensity, StepDoubling, Tolerances, step_density,
};
pub use coefficients::CompositionTable;
pub use compose::{Composition, Strang, Then};
pub use constrained_dg::{ConstrainedDiscreteGradient, EnergyBalance};
pub use exact::{FnFlow, FnLedgerFlow, from_fn, from_fn_at, from_fn_with_order};
pub use extrapolated::{Extrapolated, MAX_ROWS};
#[cfg_attr(not(feature = "scene"), allow(unused_imports))]
pub(crate) use flow_enum::flow_enum;
pub use implicit::{
    DiscreteGradient, GonzalezRule, GradientRule, ImplicitMidpoint, IncrementFlow, MidpointRule,
};
pub use ledger::Ledger;
pub use linear::{LINEAR_FLOW_CACHE, LinearFlow};
pub use petrov_galerkin::{DiscreteDissipation, MAX_STAGES, PetrovGalerkin, exact_quadrature};
pub use projection::{
    Coupling, ManifoldProjection, Projected, ProjectedMidpoint, ProjectionOptions, Reprojected,
    Scheme,
};

use crate::error::{SetupError, StepError};
use crate::linalg::LinearSolver;
use crate::system::Model;
use crate::vector::Vector;

/// The order reported by a flow that is exact (a closed-form flow of a sub-Hamiltonian).
pub const EXACT: u32 = u32::MAX;

/// Counters a flow keeps about its work (cumulative since construction).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct FlowStats {
    /// Projected steps taken.
    pub projected_steps: u64,
    /// Newton solves for multipliers.
    pub newton_solves: u64,
    /// Newton iterations (updates), summed over solves.
    pub newton_iterations: u64,
    /// Residual evaluations inside Newton (each runs the inner flow or a constraint).
    pub residual_evaluations: u64,
    /// Newton-matrix factorizations.
    pub factorizations: u64,
}

impl FlowStats {
    /// Counts one Newton solve and its work.
    #[inline]
    pub fn record<T>(&mut self, report: &crate::nonlinear::SolveReport<T>) {
        self.newton_solves += 1;
        self.newton_iterations += report.iterations as u64;
        self.residual_evaluations += report.residual_evaluations as u64;
        self.factorizations += report.factorizations as u64;
    }
}

impl core::ops::Add for FlowStats {
    type Output = Self;
    fn add(self, o: Self) -> Self {
        Self {
            projected_steps: self.projected_steps + o.projected_steps,
            newton_solves: self.newton_solves + o.newton_solves,
            newton_iterations: self.newton_iterations + o.newton_iterations,
            residual_evaluations: self.residual_evaluations + o.residual_evaluations,
            factorizations: self.factorizations + o.factorizations,
        }
    }
}

/// The multipliers `(λ_k, λ_{k+1})` of a projected step (see [`Flow::multipliers`]).
pub type Multipliers<'a, T> = (&'a [T], &'a [T]);

/// A one-step map `x ↦ Φ_h(x)`, applied in place.
///
/// Contract: on `Err`, `x` is left exactly as it was passed in (never partially updated, never
/// NaN). `h` may be negative (symmetric flows satisfy `Φ_{−h} ∘ Φ_h = id`).
pub trait Flow<V: Vector> {
    /// Advances `x` by one step of size `h`. A flow with a time-dependent part (an input) steps
    /// here as from `t = 0`: drive such a flow through [`step_at`](Self::step_at) or a
    /// [`Stepper`](crate::Stepper), which pass the time.
    fn step(&mut self, h: V::Real, x: &mut V) -> Result<(), StepError>;
    /// The order of accuracy ([`EXACT`] for an exact flow).
    fn order(&self) -> u32;
    /// `true` if `Φ_{−h} = Φ_h⁻¹` (time-symmetric).
    fn is_symmetric(&self) -> bool;
    /// Allocates any workspace for states like `x`. Called by the drivers before the first step;
    /// a flow that is not prepared prepares itself on its first step.
    fn prepare(&mut self, _x: &V) {}
    /// Work counters.
    fn stats(&self) -> FlowStats {
        FlowStats::default()
    }
    /// The constraint multipliers `(λ_k, λ_{k+1})` of the last step, when the flow (or the
    /// flow it wraps) is a projection; `None` otherwise. In `x' = M (∇H + Gᵀλ)` the continuous
    /// multiplier at the step is `≈ (λ_k + λ_{k+1})/2`. See [`Projected::multipliers`].
    fn multipliers(&self) -> Option<Multipliers<'_, V::Real>> {
        None
    }
    /// `false` if `step` never returns an error (closed-form flows); compositions then skip
    /// saving the state for a restore.
    fn is_fallible(&self) -> bool {
        true
    }
    /// `true` if the flow contains dissipation (energy decays forward in time), so that a
    /// negative step runs it backwards and adds energy — unstable when the damping is stiff.
    /// Compositions with negative coefficients refuse such flows (see [`Composition`]).
    fn dissipates(&self) -> bool {
        false
    }
    /// `true` when [`step_table`](Self::step_table) itself leaves the state unchanged on
    /// failure, so that a [`Composition`] needs no saved copy of it. Default `false` (the default
    /// `step_table` takes the stages one step at a time).
    fn step_table_is_atomic(&self) -> bool {
        false
    }
    /// `out = DΦ_h v`, the tangent map of the last successful step at its starting point, and
    /// `true`, when the flow can apply it cheaply (an implicit method from its factored Newton
    /// matrix); `false` (the default) otherwise. A projection around this flow uses it for the
    /// Jacobian of its `λ_k` system, which then converges quadratically whatever the flow.
    fn tangent_apply(&mut self, v: &V, out: &mut V) -> bool {
        let _ = (v, out);
        false
    }
    /// `true` when the flow is a *kick*: it moves no coordinate a holonomic constraint reads
    /// (a mechanical model's positions), only the others (the momenta: a potential's force, an
    /// input force, a dashpot), so `g(Φ_h(x)) = g(x)` exactly. Default `false`. A [`Strang`]
    /// splitting whose outer flow is a kick offers its trailing half-kick as a tail (see
    /// [`step_lead`](Self::step_lead)).
    fn is_kick(&self) -> bool {
        false
    }
    /// The step split as `Φ_h = T_h ∘ L_h` with a tail `T_h` that is a [kick](Self::is_kick):
    /// `step_lead` applies `L_h`, [`step_tail`](Self::step_tail) then `T_h`; together they are
    /// [`step_at`](Self::step_at). A projection solves for `λ_k` from `g(L_h(x̂)) = 0` alone —
    /// the tail cannot change `g` — and applies the tail once, after the solve: for
    /// `kick ∘ drift ∘ kick` the trailing kick's force is evaluated once per step instead of
    /// once per Newton iteration. The default has no tail (`L_h = Φ_h`, `T_h = id`). Same
    /// contract as `step_at`.
    fn step_lead(
        &mut self,
        ledger: &mut Ledger<V::Real>,
        h: V::Real,
        x: &mut V,
    ) -> Result<(), StepError> {
        self.step_at(ledger, h, x)
    }
    /// The tail `T_h` of the last [`step_lead`](Self::step_lead), from the state and ledger it
    /// left. Default: the identity.
    fn step_tail(
        &mut self,
        ledger: &mut Ledger<V::Real>,
        h: V::Real,
        x: &mut V,
    ) -> Result<(), StepError> {
        let _ = (ledger, h, x);
        Ok(())
    }
    /// `out = DL_h v`, the tangent map of the last [`step_lead`](Self::step_lead) at its
    /// starting point, as [`tangent_apply`](Self::tangent_apply) is for the whole step.
    /// Default: the whole step's (the default lead is the whole step).
    fn lead_tangent_apply(&mut self, v: &V, out: &mut V) -> bool {
        self.tangent_apply(v, out)
    }
    /// `true` when the lead ([`step_lead`](Self::step_lead)) is affine in the state,
    /// `L_h(x + v) = L_h(x) + DL_h v` for every `x` and `v` — a linear flow with forcing, a
    /// scene's free flight — so that its tangent map is the same at every point. A projection
    /// around it with quadratic constraints then has a `λ_k` system that is exactly quadratic
    /// in `λ_k`. Default `false`.
    fn lead_is_affine(&self) -> bool {
        false
    }
    /// `true` when the lead ([`step_lead`](Self::step_lead)) leaves the [`Ledger`]'s energies
    /// as they are, whatever the state (it books nothing: a linear flow). With
    /// [`lead_is_affine`](Self::lead_is_affine), a projection then forms the lead at a new
    /// multiplier from the last one along the tangent map instead of running it again.
    /// Default `false`.
    fn lead_ledger_is_constant(&self) -> bool {
        false
    }
    /// `true` when the whole step is affine along the directions a [kick](Self::is_kick)
    /// moves — the coordinates no holonomic constraint reads, a mechanical model's momenta:
    /// `Φ_h(x + v) = Φ_h(x) + DΦ_h v` for every `x` and every such `v`. A potential's kick
    /// (its increment depends on the positions alone) and a scene's free flight (affine in
    /// everything) are. Default `false`.
    fn is_affine_in_momenta(&self) -> bool {
        false
    }
    /// `true` when the lead ([`step_lead`](Self::step_lead)) is affine along the directions a
    /// kick moves, as [`is_affine_in_momenta`](Self::is_affine_in_momenta) is for the whole
    /// step. The decoupled projection's half-steps move along them (`M Gᵀλ` acts on momenta
    /// only), so with quadratic constraints its `λ_k` system is then exactly quadratic in
    /// `λ_k` — for a [`Strang`] splitting of a potential's kick and a free flight, whose lead is
    /// not affine in the positions. Default: [`lead_is_affine`](Self::lead_is_affine).
    fn lead_is_affine_in_momenta(&self) -> bool {
        self.lead_is_affine()
    }
    /// Advances `x` by one step of size `h` that starts at time `ledger.t`, advancing the
    /// extended coordinates the flow owns (see [`Ledger`]): a flow of a time-dependent part
    /// (an input) reads `ledger.t`, advances it by `h` and adds the energy it supplied; an
    /// exact damping flow adds the energy it dissipated. The default, for autonomous flows,
    /// is [`step`](Self::step), leaving the ledger as it is. Wrappers (compositions, the
    /// projection) pass the ledger through their sub-flows in order, so that each sub-step
    /// sees its own time. Same contract as `step`; on `Err` the ledger is left as passed in.
    fn step_at(
        &mut self,
        ledger: &mut Ledger<V::Real>,
        h: V::Real,
        x: &mut V,
    ) -> Result<(), StepError> {
        let _ = ledger;
        self.step(h, x)
    }
    /// Advances `x` through the stages of a composition: steps of `γ_i h` for the table's
    /// coefficients in order, each from the time the previous one reached — the map
    /// [`Composition`] applies. The default takes them one [`step_at`](Self::step_at) at a
    /// time. A flow whose consecutive steps can share work overrides it with the same map:
    /// the projection fuses the `λ_{k+1}` half-step of one stage with the `λ_k` half-step of
    /// the next (see [`Projected`]). Same contract as `step`: on `Err`, `x` is left as it was
    /// passed in.
    fn step_table(
        &mut self,
        ledger: &mut Ledger<V::Real>,
        h: V::Real,
        table: &CompositionTable,
        x: &mut V,
    ) -> Result<(), StepError> {
        for i in 0..table.stages {
            self.step_at(ledger, table.gamma_in::<V::Real>(i) * h, x)?;
        }
        Ok(())
    }
    /// Advances `x` by `n` consecutive steps of size `h`: the map of `n` calls of
    /// [`step_at`](Self::step_at), each from the time the previous one reached (an
    /// [`Extrapolated`] row). The default takes them one at a time; the projection fuses the
    /// `λ_{k+1}` half-step of each step with the `λ_k` half-step of the next, as in
    /// [`step_table`](Self::step_table): one multiplier solve a step, the same map up to the
    /// Newton tolerance. On `Err`, `x` may hold the steps taken before the failing one
    /// (an extrapolation restarts its row from its own copy).
    fn step_repeated(
        &mut self,
        ledger: &mut Ledger<V::Real>,
        h: V::Real,
        n: u32,
        x: &mut V,
    ) -> Result<(), StepError> {
        step_each(self, ledger, h, n, x)
    }
    /// Appends to `out` what the flow remembers between steps and what its next step depends
    /// on (warm starts of multipliers, held input values), so that [`restore_memory`] of it
    /// makes the continuation equal, bit for bit, to the run that continued from here. A flow
    /// forgets what it cannot save (a kept, factored Newton matrix): its next step rebuilds it,
    /// in the run that saved and in every run restored from the save alike. Default: nothing.
    ///
    /// [`restore_memory`]: Self::restore_memory
    fn save_memory(&mut self, out: &mut Vec<V::Real>) {
        let _ = out;
    }
    /// Reads back what [`save_memory`](Self::save_memory) appended, from the front of `from`,
    /// and advances `from` past it. Default: nothing.
    fn restore_memory(&mut self, from: &mut &[V::Real]) {
        let _ = from;
    }
    /// An adaptive flow's own step ([`AdaptiveExtrapolation`]): advances `x` by a step the
    /// flow chooses to meet its tolerance, of at most `|max|` in the direction of `max`, and
    /// returns it (`max` itself when it reached it). `None` for a flow without steps of its
    /// own: every fixed-step flow (the default).
    fn step_own(
        &mut self,
        ledger: &mut Ledger<V::Real>,
        max: V::Real,
        x: &mut V,
    ) -> Option<Result<V::Real, StepError>> {
        let _ = (ledger, max, x);
        None
    }
    /// What an adaptive flow's controller did (`None` for a fixed-step flow).
    fn adaptive_stats(&self) -> Option<AdaptiveStats> {
        None
    }
    /// Dense output from an interpolant of the flow's last accepted step (the adaptive
    /// extrapolation with [`AdaptiveOptions::dense_output`]): the state at `ledger.t` into
    /// `out`, projected as the step's end is, and `ledger`'s energies there. `None` when the
    /// flow keeps no interpolant or its last step does not cover `ledger.t` (the default):
    /// the caller takes a partial step instead ([`Stepper::dense`](crate::Stepper::dense)).
    fn interpolate(
        &mut self,
        ledger: &mut Ledger<V::Real>,
        out: &mut V,
    ) -> Option<Result<(), StepError>> {
        let _ = (ledger, out);
        None
    }
}

/// `n` calls of [`Flow::step_at`] with step `h`: the default [`Flow::step_repeated`], and the
/// path of a flow that overrides it for the cases it does not fuse.
pub(crate) fn step_each<V: Vector, F: Flow<V> + ?Sized>(
    flow: &mut F,
    ledger: &mut Ledger<V::Real>,
    h: V::Real,
    n: u32,
    x: &mut V,
) -> Result<(), StepError> {
    for _ in 0..n {
        flow.step_at(ledger, h, x)?;
    }
    Ok(())
}

/// Takes the first `n` values off the front of a checkpoint's memory (fewer if it has fewer).
pub(crate) fn take_memory<'a, T>(from: &mut &'a [T], n: usize) -> &'a [T] {
    let (head, tail) = from.split_at(n.min(from.len()));
    *from = tail;
    head
}

/// Forwards every [`Flow`] method through a pointer type (`&mut F`, `Box<F>`).
macro_rules! forward_flow {
    ($($ptr:ty),*) => {$(
        impl<V: Vector, F: Flow<V> + ?Sized> Flow<V> for $ptr {
            fn step(&mut self, h: V::Real, x: &mut V) -> Result<(), StepError> {
                (**self).step(h, x)
            }
            fn order(&self) -> u32 {
                (**self).order()
            }
            fn is_symmetric(&self) -> bool {
                (**self).is_symmetric()
            }
            fn prepare(&mut self, x: &V) {
                (**self).prepare(x)
            }
            fn stats(&self) -> FlowStats {
                (**self).stats()
            }
            fn multipliers(&self) -> Option<Multipliers<'_, V::Real>> {
                (**self).multipliers()
            }
            fn is_fallible(&self) -> bool {
                (**self).is_fallible()
            }
            fn dissipates(&self) -> bool {
                (**self).dissipates()
            }
            fn step_at(
                &mut self,
                ledger: &mut Ledger<V::Real>,
                h: V::Real,
                x: &mut V,
            ) -> Result<(), StepError> {
                (**self).step_at(ledger, h, x)
            }
            fn step_table(
                &mut self,
                ledger: &mut Ledger<V::Real>,
                h: V::Real,
                table: &CompositionTable,
                x: &mut V,
            ) -> Result<(), StepError> {
                (**self).step_table(ledger, h, table, x)
            }
            fn step_repeated(
                &mut self,
                ledger: &mut Ledger<V::Real>,
                h: V::Real,
                n: u32,
                x: &mut V,
            ) -> Result<(), StepError> {
                (**self).step_repeated(ledger, h, n, x)
            }
            fn save_memory(&mut self, out: &mut Vec<V::Real>) {
                (**self).save_memory(out)
            }
            fn restore_memory(&mut self, from: &mut &[V::Real]) {
                (**self).restore_memory(from)
            }
            fn step_own(
                &mut self,
                ledger: &mut Ledger<V::Real>,
                max: V::Real,
                x: &mut V,
            ) -> Option<Result<V::Real, StepError>> {
                (**self).step_own(ledger, max, x)
            }
            fn adaptive_stats(&self) -> Option<AdaptiveStats> {
                (**self).adaptive_stats()
            }
            fn interpolate(
                &mut self,
                ledger: &mut Ledger<V::Real>,
                out: &mut V,
            ) -> Option<Result<(), StepError>> {
                (**self).interpolate(ledger, out)
            }
            fn tangent_apply(&mut self, v: &V, out: &mut V) -> bool {
                (**self).tangent_apply(v, out)
            }
            fn step_table_is_atomic(&self) -> bool {
                (**self).step_table_is_atomic()
            }
            fn is_kick(&self) -> bool {
                (**self).is_kick()
            }
            fn step_lead(
                &mut self,
                ledger: &mut Ledger<V::Real>,
                h: V::Real,
                x: &mut V,
            ) -> Result<(), StepError> {
                (**self).step_lead(ledger, h, x)
            }
            fn step_tail(
                &mut self,
                ledger: &mut Ledger<V::Real>,
                h: V::Real,
                x: &mut V,
            ) -> Result<(), StepError> {
                (**self).step_tail(ledger, h, x)
            }
            fn lead_tangent_apply(&mut self, v: &V, out: &mut V) -> bool {
                (**self).lead_tangent_apply(v, out)
            }
            fn lead_is_affine(&self) -> bool {
                (**self).lead_is_affine()
            }
            fn lead_ledger_is_constant(&self) -> bool {
                (**self).lead_ledger_is_constant()
            }
            fn is_affine_in_momenta(&self) -> bool {
                (**self).is_affine_in_momenta()
            }
            fn lead_is_affine_in_momenta(&self) -> bool {
                (**self).lead_is_affine_in_momenta()
            }
        }
    )*};
}

forward_flow!(&mut F, Box<F>);

/// Validates the input of a step: `h` and `x` finite. `Ok(false)` when `h = 0` (the step is the
/// identity and nothing needs to be computed).
pub(crate) fn check_step<V: Vector>(h: V::Real, x: &V) -> Result<bool, StepError> {
    let nonzero = check_step_size(h)?;
    if let Some(component) = crate::ops::first_non_finite(x.as_slice()) {
        return Err(StepError::NonFinite { component });
    }
    Ok(nonzero)
}

/// Validates a step size: finite. `Ok(false)` when `h = 0`.
#[inline(always)]
pub(crate) fn check_step_size<T: crate::Real>(h: T) -> Result<bool, StepError> {
    if !h.is_finite() {
        return Err(StepError::BadStepSize {
            h: h.to_f64_lossy(),
        });
    }
    Ok(h != T::zero())
}

/// Adapters that build schemes from flows.
pub trait FlowExt<V: Vector>: Flow<V> + Sized {
    /// `self` for `h`, then `next` for `h` (Lie–Trotter; order 1, not symmetric).
    fn then<B: Flow<V>>(self, next: B) -> Then<V, Self, B> {
        Then::new(self, next)
    }

    /// Strang splitting `self(h/2) ∘ inner(h) ∘ self(h/2)`: order 2, symmetric when both are.
    fn strang<B: Flow<V>>(self, inner: B) -> Strang<V, Self, B> {
        Strang::new(self, inner)
    }

    /// Symmetric composition with the coefficients of `table`.
    fn composed(self, table: &'static CompositionTable) -> Composition<V, Self> {
        Composition::new(self, table)
    }

    /// Yoshida's triple jump (order 4, 3 stages).
    fn triple_jump(self) -> Composition<V, Self> {
        Composition::new(self, &coefficients::TRIPLE_JUMP)
    }

    /// Aitken–Neville extrapolation of this symmetric step to `order` (4, 6, 8, …) on the
    /// harmonic step sequence, every sub-step forward in time (see [`Extrapolated`]).
    ///
    /// # Errors
    /// [`SetupError::Scheme`] when `self` is not symmetric or `order` is out of reach.
    fn extrapolated(self, order: u32) -> Result<Extrapolated<V, Self>, SetupError> {
        Extrapolated::try_new(self, order)
    }

    /// `self`, then a projection back onto `g = 0` (and `φ = 0` in the degenerate case) after
    /// every step (see [`Reprojected`]); for schemes that leave the manifold by their local
    /// error, such as an [`extrapolated`](Self::extrapolated) projected step.
    ///
    /// # Errors
    /// The initial-state checks of a projection ([`SetupError`]).
    fn reprojected<Sys: Model<V>>(
        self,
        system: Sys,
        x0: &V,
        options: ProjectionOptions<V::Real>,
    ) -> Result<Reprojected<V, Self, Sys>, SetupError> {
        Reprojected::try_new(self, system, x0, options)
    }

    /// The projection half-steps of Zhang & Deng (2004, §3) around `self`, for `system`,
    /// with the case and coupling decided at `x0` (see [`Projected`]).
    #[allow(clippy::type_complexity)]
    fn projected<Sys: Model<V>>(
        self,
        system: Sys,
        x0: &V,
        options: ProjectionOptions<V::Real>,
    ) -> Result<Projected<V, Self, Sys>, SetupError> {
        Projected::try_new(self, system, x0, options)
    }

    /// As [`projected`](Self::projected), with a chosen linear solver `L` for the multiplier systems.
    #[allow(clippy::type_complexity)]
    fn projected_with<Sys: Model<V>, L: LinearSolver<V::Real>>(
        self,
        system: Sys,
        x0: &V,
        options: ProjectionOptions<V::Real>,
    ) -> Result<Projected<V, Self, Sys, L>, SetupError> {
        Projected::try_new(self, system, x0, options)
    }
}

impl<V: Vector, F: Flow<V>> FlowExt<V> for F {}
