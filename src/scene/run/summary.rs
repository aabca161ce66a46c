//! What a run is asked to compute, what it passes its observer after each step, and the
//! summary it returns.

use crate::error::StepError;
use crate::scene::simulation::EffectReport;
use serde::Serialize;

/// What to compute during a run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunPlan {
    /// Steps of `dt` to take.
    pub steps: usize,
    /// The length of one last, shorter step that lands on `t_end` when `dt` does not divide
    /// it, taken after the `steps` full ones (`None` when the full steps end there).
    pub last_step: Option<f64>,
    /// The final time the run ends at.
    pub t_end: f64,
    /// Evaluate `H` after every step.
    pub energy: bool,
    /// Evaluate `|g|` and `|φ|` after every step.
    pub residuals: bool,
    /// Take the scheme's own steps to `t_end` — an adaptive scheme's accepted steps — with
    /// the observer called after each, instead of the steps of `dt` (for a scene with a
    /// tolerance, `dt` is the interval its states are reported at, each report time a step
    /// lands on). A scheme without steps of its own takes the steps of `dt`.
    pub own_steps: bool,
    /// Report at every `dt` from the dense output of the scheme's own steps (a scene with
    /// `dense = true`): the observer sees the state at each report time, read from the
    /// polynomial of the accepted step that holds it, while the steps go on from their own
    /// ends ([`advance_dense_until`](crate::scene::advance_dense_until)).
    pub dense: bool,
    /// Pass the step's multipliers `(λ_k + λ_{k+1})/2` to the observer (a copy per step: for
    /// writing them out, off by default).
    pub multipliers: bool,
}

impl RunPlan {
    /// Every step the plan takes: the full ones and the shortened last one.
    pub fn total_steps(&self) -> usize {
        self.steps + usize::from(self.last_step.is_some())
    }
}

/// The state after a step, with the diagnostics the plan asked for; passed to the run's observer.
#[derive(Debug, Clone, Copy)]
pub struct Sample<'a> {
    /// Step index (0 for the initial state).
    pub step: usize,
    /// Time.
    pub t: f64,
    /// The state.
    pub x: &'a [f64],
    /// `H(x)`, if asked for.
    pub energy: Option<f64>,
    /// `max |g(x)|`, if asked for and there are constraints.
    pub g: Option<f64>,
    /// `max |φ(x)|`, likewise.
    pub phi: Option<f64>,
    /// The declared outputs (see [`Simulation::output_names`](crate::scene::Simulation::output_names)).
    pub outputs: &'a [f64],
    /// The energy dissipated so far, when the run books it (with the energy diagnostic).
    pub dissipated: Option<f64>,
    /// The energy supplied through the inputs so far, likewise.
    pub supplied: Option<f64>,
    /// The multipliers of the step that reached this state, when the plan asks for them and
    /// the scheme is a projection (empty otherwise; see [`Simulation::multipliers`](crate::scene::Simulation::multipliers)).
    pub multipliers: &'a [f64],
}

/// Why a run stopped early.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RunFailure {
    /// The step that failed (the state is the one before it).
    pub step: usize,
    /// Its time.
    pub t: f64,
    /// The error's kind, e.g. `Newton`, `NonFinite`.
    pub kind: String,
    /// The error's message.
    pub message: String,
    /// What to try instead, when the error says (a smaller `dt`, another scheme).
    pub advice: Option<String>,
}

/// The summary of a run (printed as the command's final JSON line).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RunSummary {
    /// Final time reached.
    pub t: f64,
    /// Steps taken.
    pub steps: usize,
    /// Steps planned; in a run of the scheme's own steps ([`own_steps`](Self::own_steps)),
    /// whose number is not known before, the steps taken.
    pub steps_planned: usize,
    /// The steps were the scheme's own (an adaptive scheme's accepted steps,
    /// [`RunPlan::own_steps`]), not steps to every `dt`.
    pub own_steps: bool,
    /// Step size.
    pub dt: f64,
    /// The length of the last step when it was shortened to end at `t_end` (`dt` does not
    /// divide `t_end`); `None` when every step was `dt`.
    pub last_step: Option<f64>,
    /// The final state.
    pub x: Vec<f64>,
    /// `max |g|` over the run (`None` without constraints or with the diagnostic off).
    pub max_abs_g: Option<f64>,
    /// `max |φ|` over the run, likewise.
    pub max_abs_phi: Option<f64>,
    /// `H` at the start (`None` with the energy diagnostic off).
    pub energy_initial: Option<f64>,
    /// `H` at the end.
    pub energy_final: Option<f64>,
    /// `max |H − H₀|` over the run.
    pub max_abs_energy_error: Option<f64>,
    /// `max (H_{k+1} − H_k)` over the steps. With damping, ≤ 0 when the dissipation per step
    /// dominates the splitting's `O(h³)` energy error, and ≤ 0 by construction with the
    /// discrete gradient and the Petrov–Galerkin scheme.
    pub max_energy_increase: Option<f64>,
    /// Energy dissipated, `∫ ∇Hᵀ R ∇H dt` (with damping): the damping sub-flow's exact
    /// account in a splitting, the trapezoidal rule over the steps otherwise (see
    /// [`EnergyBudget`](crate::scene::observe::EnergyBudget)).
    pub dissipated: Option<f64>,
    /// Energy supplied through the inputs, `∫ yᵀu dt` (with inputs).
    pub supplied: Option<f64>,
    /// The events that happened, in order.
    pub events: Vec<crate::scene::EventRecord>,
    /// The event that stopped the run, if one did.
    pub stopped_by: Option<String>,
    /// `max |H − H₀ + dissipated − supplied|` over the run: the energy budget's error (with
    /// damping or inputs).
    pub max_energy_balance_error: Option<f64>,
    /// Set when the energy budget's error exceeds [`BUDGET_WARNING_FRACTION`] of the energy
    /// exchanged (`dissipated + |supplied|`): the account is then dominated by the scheme's
    /// energy error at this step size (stiff damping, `c dt/m ≫ 1`), and says why and what to do.
    pub energy_balance_warning: Option<String>,
    /// Per-term evaluation counts.
    pub effects: Vec<EffectReport>,
    /// Residual evaluations of the multiplier solves.
    pub residual_evaluations: u64,
    /// Newton iterations of the multiplier solves.
    pub newton_iterations: u64,
    /// Wall time per step, stepping only (diagnostics excluded).
    pub ns_per_step: f64,
    /// Why the run stopped early, if it did.
    pub error: Option<RunFailure>,
    /// The run was interrupted (Ctrl-C) before its last step: the summary covers the steps
    /// taken.
    pub interrupted: bool,
    /// What the step controller did (a scene with a tolerance; `None` otherwise).
    pub adaptive: Option<AdaptiveSummary>,
}

/// What the step controller of a scene with a tolerance did: its accepted, rejected and
/// failed steps, the orders it chose, its smallest and largest steps, and its last error
/// estimate (in the weighted norm of the tolerance: ≤ 1).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AdaptiveSummary {
    /// Accepted steps.
    pub accepted: u64,
    /// Steps rejected by the error estimate.
    pub rejected: u64,
    /// Steps halved because a sub-step failed (a Newton failure).
    pub failed: u64,
    /// Base (Strang) steps taken, rejected ones included.
    pub base_steps: u64,
    /// `[order, accepted steps at it]`, for the orders used.
    pub orders: Vec<[u64; 2]>,
    /// The smallest accepted step.
    pub smallest_step: Option<f64>,
    /// The largest accepted step.
    pub largest_step: Option<f64>,
    /// The last accepted step's error estimate, in the tolerance's weighted norm.
    pub error_estimate: f64,
}

impl From<crate::flow::AdaptiveStats> for AdaptiveSummary {
    fn from(s: crate::flow::AdaptiveStats) -> Self {
        Self {
            accepted: s.accepted,
            rejected: s.rejected,
            failed: s.failed,
            base_steps: s.base_steps,
            orders: s
                .orders
                .iter()
                .enumerate()
                .filter(|(_, n)| **n > 0)
                .map(|(k, &n)| [2 * k as u64, n])
                .collect(),
            smallest_step: (s.accepted > 0).then_some(s.smallest),
            largest_step: (s.accepted > 0).then_some(s.largest),
            error_estimate: s.last_error,
        }
    }
}

/// The fraction of the energy exchanged (`dissipated + |supplied|`) above which the budget's
/// error is flagged in the summary ([`RunSummary::energy_balance_warning`]).
pub const BUDGET_WARNING_FRACTION: f64 = 0.01;

/// The warning of a budget error `error` against the energy exchanged, when above
/// [`BUDGET_WARNING_FRACTION`] of it and above the rounding of the energies (`scale`: the
/// largest `|H|` of the run), so that a run that exchanges nothing is not flagged for its
/// round-off. Its advice is a smaller `dt`, or with a tolerance (`adaptive`, where `dt` is
/// the report interval) a tighter one.
pub(crate) fn budget_warning(
    error: f64,
    dissipated: f64,
    supplied: f64,
    scale: f64,
    adaptive: bool,
) -> Option<String> {
    let exchanged = dissipated.abs() + supplied.abs();
    if exchanged == 0.0 && scale == 0.0 {
        // Nothing exchanged and no energy to measure it against (a body at rest at H = 0).
        return None;
    }
    let rounding = 1e3 * f64::EPSILON * scale.max(exchanged);
    let shrink = if adaptive {
        "a tighter tol shrinks it"
    } else {
        "a smaller dt shrinks it as dt²"
    };
    (error > BUDGET_WARNING_FRACTION * exchanged && error > rounding).then(|| {
        format!(
            "the energy budget's error {error:.3e} exceeds 1% of the energy exchanged ({exchanged:.3e}): {shrink}, scheme = \"petrov-galerkin\" closes it"
        )
    })
}

/// What to try after a failed step, by the error's cause.
pub(crate) fn step_error_advice(e: &StepError, dt: f64) -> Option<String> {
    let smaller = format!(
        "a smaller step (dt = {:e} or less: the multiplier system is nearer linear, its Newton start nearer the solution, the smaller the step)",
        dt / 4.0
    );
    match e {
        StepError::Newton { .. } | StepError::FixedPointNotConverged { .. } => Some(format!(
            "the multiplier solve failed at this step size; try {smaller}. A step must resolve the scene's fastest oscillation (ω dt < 2): a stiff spring (ω² = k/m), or a light body held between heavy ones, which swings across its rods at ω² = T (1/ℓ₁ + 1/ℓ₂)/m under the tension T; for stiff springs or damping, an implicit scheme (`scheme = \"midpoint\"`, `\"discrete-gradient\"` or `\"petrov-galerkin\"`) keeps larger steps stable"
        )),
        StepError::NonFinite { .. } => Some(format!(
            "the state grew without bound: the step is past the explicit splitting's stability limit (ω dt < 2 for a spring of angular frequency ω); try {smaller}, or an implicit scheme (`scheme = \"midpoint\"`)"
        )),
        StepError::NonFiniteInput { .. } => Some(
            "a smaller step does not help: the input's signal must be finite wherever the run samples it (every step reads it inside the step as well as at its ends); define it there, e.g. `max(t - 1, 1e-9)` inside a logarithm".to_owned(),
        ),
        _ => None,
    }
}

/// The variant name of a step error, for summaries.
pub(crate) fn step_error_kind(e: &StepError) -> &'static str {
    match e {
        StepError::Newton { .. } => "Newton",
        StepError::FixedPointNotConverged { .. } => "FixedPointNotConverged",
        StepError::NonFinite { .. } => "NonFinite",
        StepError::NonFiniteInput { .. } => "NonFiniteInput",
        StepError::BadStepSize { .. } => "BadStepSize",
        StepError::BackwardDissipation { .. } => "BackwardDissipation",
        StepError::CouplingViolated { .. } => "CouplingViolated",
        StepError::StateLength { .. } => "StateLength",
        StepError::OffManifold { .. } => "OffManifold",
        StepError::StepSizeTooSmall { .. } => "StepSizeTooSmall",
    }
}
