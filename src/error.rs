//! Typed errors, layered: [`LinearSolveError`] ⊂ [`NewtonError`] ⊂ [`StepError`] ⊂ [`IntegrateError`],
//! and [`SetupError`] for what is detected when a scheme is built.
//!
//! Values in errors are `f64` (converted from the scalar type) so that every error is
//! `Send + Sync + 'static` and independent of the scalar type.

use thiserror::Error;

/// A dense or sparse linear solve failed.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum LinearSolveError {
    /// The matrix is singular to working precision: pivot `pivot` has magnitude `magnitude`,
    /// `ratio` times the largest pivot.
    #[error(
        "singular matrix: pivot {pivot} has magnitude {magnitude:e} ({ratio:e} of the largest pivot)"
    )]
    Singular {
        /// The column (unknown) of the original matrix whose elimination found no pivot
        /// (0-based; row pivoting does not change it, and the sparse solver maps its column
        /// ordering back).
        pivot: usize,
        /// Its magnitude.
        magnitude: f64,
        /// Its magnitude relative to the largest pivot.
        ratio: f64,
    },
    /// The matrix contains NaN or infinity.
    #[error("matrix entry ({row}, {col}) is not finite")]
    NonFinite {
        /// Row of the first non-finite entry.
        row: usize,
        /// Column of the first non-finite entry.
        col: usize,
    },
    /// The solver cannot hold a system of this size (e.g. a stack solver with a fixed capacity).
    #[error("system of dimension {requested} exceeds the solver capacity {capacity}")]
    TooLarge {
        /// Requested dimension.
        requested: usize,
        /// Largest dimension the solver supports.
        capacity: usize,
    },
    /// An entry lies outside the `dim × dim` matrix.
    #[error("matrix entry ({row}, {col}) is outside a {dim} x {dim} matrix")]
    OutOfBounds {
        /// Row of the entry.
        row: usize,
        /// Column of the entry.
        col: usize,
        /// The dimension.
        dim: usize,
    },
    /// A sparse assembly did not repeat the recorded pattern: entry number `entry` was expected
    /// at `expected` (`None`: past the end of the pattern) but came at `got` (`None`: the
    /// assembly stopped early). The pattern is recorded once, by the first assembly.
    #[error(
        "sparse assembly changed its pattern at entry {entry}: expected {expected:?}, got {got:?}"
    )]
    PatternChanged {
        /// Position in the assembly sequence.
        entry: usize,
        /// The recorded position.
        expected: Option<(usize, usize)>,
        /// The position added.
        got: Option<(usize, usize)>,
    },
    /// A Jacobian computed in closed form has a non-zero outside the sparsity pattern it was
    /// declared with, in a row its column group does not cover: grouped columns would add it
    /// to another entry, so the matrix would be wrong, not merely incomplete. (A non-zero in a
    /// covered row cannot be told apart from the group sum; it shows as slow convergence.)
    /// Declare a wider pattern (or none).
    #[error(
        "the Jacobian has a non-zero in row {row} outside the declared sparsity pattern (the column group of column {column})"
    )]
    PatternIncomplete {
        /// The row of the non-zero.
        row: usize,
        /// A column of the group it appeared in.
        column: usize,
    },
    /// A solve was asked of a solver with no (successful) factorization since its last
    /// assembly.
    #[error("solve before a successful factorization of the current matrix")]
    NotFactored,
    /// The sparsity pattern itself is singular: no choice of values makes the matrix invertible
    /// (a column or row without entries, or more constraints than a set of unknowns can carry).
    #[error("structurally singular sparse matrix (column {column} has no available pivot)")]
    StructurallySingular {
        /// The column (of the original matrix) without a pivot.
        column: usize,
    },
    /// The backend ran out of memory or index range.
    #[error("sparse backend failed: {what}")]
    Backend {
        /// What failed.
        what: &'static str,
    },
}

impl LinearSolveError {
    /// The error of a matrix whose columns (and rows) a solver renumbered, in the caller's
    /// numbering: `old(new)` maps a singular pivot's column and a non-finite entry's row and
    /// column back.
    pub(crate) fn renumbered(self, old: impl Fn(usize) -> usize) -> Self {
        match self {
            LinearSolveError::Singular {
                pivot,
                magnitude,
                ratio,
            } => LinearSolveError::Singular {
                pivot: old(pivot),
                magnitude,
                ratio,
            },
            LinearSolveError::NonFinite { row, col } => LinearSolveError::NonFinite {
                row: old(row),
                col: old(col),
            },
            other => other,
        }
    }
}

/// Newton's method failed to solve a nonlinear system. `E` is the error of the problem's
/// residual evaluation ([`NonlinearProblem::Error`](crate::nonlinear::NonlinearProblem::Error));
/// the default, [`Infallible`](core::convert::Infallible), is Newton's own failures only (as
/// [`StepError::Newton`] carries them: a failed residual evaluation of a step is reported as
/// that step's own error, not wrapped).
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum NewtonError<E = core::convert::Infallible> {
    /// The iteration limit was reached before the residual met the tolerance.
    #[error("Newton did not converge in {iterations} iterations (residual {residual:.3e})")]
    NotConverged {
        /// Iterations performed.
        iterations: usize,
        /// Max-norm of the last residual.
        residual: f64,
    },
    /// The Newton matrix could not be factored or solved.
    #[error("Newton matrix: {0}")]
    Linear(#[from] LinearSolveError),
    /// The residual became NaN or infinite.
    #[error("Newton residual is not finite at iteration {iteration}")]
    NonFinite {
        /// Iteration at which it happened.
        iteration: usize,
    },
    /// Evaluating the residual failed (for instance an inner flow or fixed point failed).
    #[error("residual evaluation failed: {0}")]
    Residual(E),
    /// The residual is exactly quadratic in its one unknown and has no real root: no iterate
    /// meets the tolerance (a projection's constraint cannot be reached along its direction
    /// at this step size; a smaller step can).
    #[error(
        "the residual (quadratic in its unknown) has no real root: its least value exceeds the tolerance (residual {residual:.3e}, discriminant {discriminant:.3e} of J^2)"
    )]
    NoRoot {
        /// Max-norm of the residual at the iterate where it was found.
        residual: f64,
        /// The discriminant `J² − 2 c F` relative to `J²` (negative).
        discriminant: f64,
    },
}

impl<E> NewtonError<E> {
    /// Separates the problem's own failure (`Err`) from Newton's (`Ok`, without a residual
    /// variant).
    pub fn split(self) -> Result<NewtonError, E> {
        match self {
            NewtonError::NotConverged {
                iterations,
                residual,
            } => Ok(NewtonError::NotConverged {
                iterations,
                residual,
            }),
            NewtonError::Linear(e) => Ok(NewtonError::Linear(e)),
            NewtonError::NonFinite { iteration } => Ok(NewtonError::NonFinite { iteration }),
            NewtonError::NoRoot {
                residual,
                discriminant,
            } => Ok(NewtonError::NoRoot {
                residual,
                discriminant,
            }),
            NewtonError::Residual(e) => Err(e),
        }
    }
}

/// One step of a flow failed. On error the state passed to `step` is left unchanged.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum StepError {
    /// A multiplier system was not solved.
    #[error("{stage}: {source}")]
    Newton {
        /// Which multiplier system (e.g. `"lambda_k from g = 0"`).
        stage: &'static str,
        /// The Newton failure.
        source: NewtonError,
    },
    /// The implicit end point of a projection half-step did not converge.
    #[error(
        "implicit projection end point did not converge in {iterations} iterations (change {change:.3e})"
    )]
    FixedPointNotConverged {
        /// Iterations performed.
        iterations: usize,
        /// Max-norm of the last change.
        change: f64,
    },
    /// The state became NaN or infinite.
    #[error("state component {component} is not finite")]
    NonFinite {
        /// First non-finite component.
        component: usize,
    },
    /// An input's value is not finite (a division by zero, a logarithm outside its domain,
    /// an overflow of a held value): the state would be, and nothing a smaller step does helps.
    #[error("input {input} is {value} at t = {t}: its signal is not finite there")]
    NonFiniteInput {
        /// The input's index, in the order the inputs were declared.
        input: usize,
        /// The time at which it was evaluated.
        t: f64,
        /// Its value there (or its integral over the sub-step divided by its length).
        value: f64,
    },
    /// The step size is not finite.
    #[error("step size {h} is not finite")]
    BadStepSize {
        /// The offending step size.
        h: f64,
    },
    /// A composition with a negative coefficient was asked to step a dissipative flow
    /// (see [`Composition`](crate::flow::Composition)).
    #[error(
        "composition '{table}' takes a backward sub-step (stage {stage}, gamma = {gamma}) on a dissipative flow: damping would run backwards; use Strang or allow it explicitly"
    )]
    BackwardDissipation {
        /// The composition table.
        table: &'static str,
        /// The first stage with a negative coefficient.
        stage: usize,
        /// Its coefficient.
        gamma: f64,
    },
    /// A step assumed by the decoupled projection path was violated (the second half-step changed g).
    #[error(
        "decoupled projection assumption violated: |g| = {residual:e} after the second half-step; use Coupling::Coupled"
    )]
    CouplingViolated {
        /// Max-norm of g after the step.
        residual: f64,
    },
    /// A projected step was asked to start from a state off the constraint manifold (changed
    /// by the caller since the flow's last step): projecting it back would hide a jump. See
    /// [`ProjectionOptions::manifold_tol`](crate::flow::ProjectionOptions::manifold_tol).
    #[error(
        "the step starts off the constraint manifold: |{what}| = {residual:e} > {tol:e}: the state was changed since the last step (a scene's set_state(x, reproject = true) projects it back; in code, ProjectionOptions::manifold_tol = None lets the step project it)"
    )]
    OffManifold {
        /// `"g"` or `"phi"`.
        what: &'static str,
        /// Max-norm of the violation.
        residual: f64,
        /// The tolerance.
        tol: f64,
    },
    /// An adaptive flow could not meet its tolerance: the step it needed fell below its
    /// smallest step `h_min`.
    #[error("at t = {t}: the step needed fell to {h:e}, below h_min = {h_min:e} ({cause})")]
    StepSizeTooSmall {
        /// The time the failing step started from.
        t: f64,
        /// The step the controller asked for last.
        h: f64,
        /// The smallest step allowed.
        h_min: f64,
        /// Why the step shrank: the error estimate above the tolerance, or the failure of a
        /// sub-step (a Newton failure, a non-finite state).
        cause: String,
    },
    /// The state passed to a flow has a different length than the flow was built for.
    #[error("{flow}: state of length {got}, built for length {expected}")]
    StateLength {
        /// The flow.
        flow: &'static str,
        /// The length the flow was built for.
        expected: usize,
        /// The length passed.
        got: usize,
    },
}

impl StepError {
    /// A multiplier solve of `stage` failed: the residual's own error (an inner flow's, say) is
    /// the step's error; Newton's failures are wrapped in [`StepError::Newton`].
    pub(crate) fn from_newton(stage: &'static str, e: NewtonError<StepError>) -> Self {
        match e.split() {
            Ok(source) => StepError::Newton { stage, source },
            Err(step) => step,
        }
    }
}

/// A scheme could not be built for the given model and initial state.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum SetupError {
    /// The initial state contains NaN or infinity.
    #[error("initial state component {component} is not finite")]
    NonFiniteState {
        /// First non-finite component.
        component: usize,
    },
    /// Neither ⟨g,g⟩ = G M Gᵀ nor ⟨φ,g⟩ is invertible: redundant constraints, or a constraint
    /// that is a Casimir of M (already invariant). The multipliers are not determined.
    #[error(
        "multiplier matrix {bracket} is singular at the initial state (pivot {pivot}, ratio {ratio:e}): redundant constraints or a Casimir of M"
    )]
    SingularMultiplierMatrix {
        /// Which bracket matrix (`"<g,g>"` or `"<phi,g>"`).
        bracket: &'static str,
        /// Index of the failing pivot.
        pivot: usize,
        /// Its magnitude relative to the largest pivot.
        ratio: f64,
    },
    /// ⟨g,g⟩ is neither zero nor invertible: a mix of degenerate and non-degenerate constraints.
    #[error(
        "<g,g> is neither zero (|<g,g>| = {norm:e}) nor invertible: mixed degenerate/non-degenerate constraints are not supported"
    )]
    MixedCase {
        /// Max-norm of ⟨g,g⟩.
        norm: f64,
    },
    /// The constraint gradients are linearly dependent at the initial state (`G Gᵀ` singular to
    /// working precision): a constraint listed twice, or a closed loop that constrains more
    /// than it can (a redundant, over-constrained set). No multiplier is unique there.
    #[error(
        "redundant constraints at the initial state: the gradient of constraint {constraint} is a linear combination of the others (pivot ratio {ratio:e}); remove duplicated links or over-constraining loop closures"
    )]
    RankDeficient {
        /// A constraint whose gradient depends on the others.
        constraint: usize,
        /// Its pivot relative to the largest pivot of `G Gᵀ`.
        ratio: f64,
    },
    /// A constraint whose gradient depends on the others is violated at the initial state:
    /// it contradicts them (a second rod of another length), so it cannot be dropped as
    /// redundant (see [`DropDependent`](crate::system::DropDependent)).
    #[error(
        "constraint {constraint} depends on the others but is violated at the initial state (residual {residual:e}): it contradicts them and is not dropped"
    )]
    InconsistentConstraint {
        /// The row of the wrapped constraint.
        constraint: usize,
        /// Its residual at the initial state.
        residual: f64,
    },
    /// A constraint row dropped as dependent is not a combination of the kept rows at this
    /// state: the state is off the motion along which the redundancy holds (see
    /// [`DropDependent::minimum_norm_multipliers`](crate::system::DropDependent::minimum_norm_multipliers)).
    #[error(
        "constraint {constraint} was dropped as dependent but is independent of the kept rows here (relative residual {residual:e}): the state is off the mechanism's motion"
    )]
    NotDependent {
        /// The row of the wrapped constraint.
        constraint: usize,
        /// `‖g_d − G_Kᵀ c‖ / ‖g_d‖` of its best combination of the kept rows.
        residual: f64,
    },
    /// The initial state violates the constraint manifold by more than the tolerance.
    #[error("initial state is off the constraint manifold: {what} = {residual:e}")]
    OffManifold {
        /// `"g"` or `"phi"`.
        what: &'static str,
        /// Max-norm of the violation.
        residual: f64,
    },
    /// A linear solver could not be created for the multiplier system.
    #[error("linear solver: {0}")]
    Linear(#[from] LinearSolveError),
    /// A model parameter is out of its domain (a non-positive mass, a NaN length, a negative
    /// damping coefficient).
    #[error("parameter {name} = {value} is invalid: it must be {requirement}")]
    InvalidParameter {
        /// The parameter, with its index when it is one of many (`"mass 3"`).
        name: String,
        /// The value given.
        value: f64,
        /// What it must be (`"positive and finite"`).
        requirement: &'static str,
    },
    /// Dimensions of the model pieces do not match.
    #[error("dimension mismatch: {what}")]
    Dimension {
        /// What did not match.
        what: String,
    },
    /// An adapter cannot be built on the flow it wraps (an extrapolation of a step that is not
    /// symmetric, an order its step sequence cannot reach).
    #[error("cannot build the scheme: {what}")]
    Scheme {
        /// What the adapter needs and the flow lacks.
        what: String,
    },
    /// A structure the model declares (its mechanical form: inverse masses, momentum block,
    /// position constraints) contradicts its own evaluations at the initial state.
    #[error("the model's declaration does not hold: {what}")]
    Declaration {
        /// What was declared and what the evaluation gave.
        what: String,
    },
}

/// The fixed-step driver stopped at a failing step.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum IntegrateError {
    /// The initial state contains NaN or infinity.
    #[error("initial state component {component} is not finite")]
    NonFiniteInitialState {
        /// First non-finite component.
        component: usize,
    },
    /// Step `step` (0-based), starting at time `t`, failed; the state is the one at `t`.
    #[error("step {step} at t = {t}: {source}")]
    Step {
        /// Index of the failing step.
        step: usize,
        /// Time at the start of the failing step.
        t: f64,
        /// What failed.
        source: StepError,
    },
}
