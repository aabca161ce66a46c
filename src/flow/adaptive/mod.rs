//! Tolerance-driven integration: flows that choose their own steps (and orders) to meet a
//! requested accuracy, and keep the structure of the fixed-step schemes — every sub-step
//! forward in time, the constraints projected to round-off after every accepted step, a
//! rejected step restoring the state and the flow's memory exactly (`../shared/docs/METHOD.md`
//! §9; docs/method.md §12d).
//!
//! An adaptive flow is a [`Flow`](crate::flow::Flow) like any other: `step(h, x)` advances by
//! exactly `h` — the communication interval of an embedder, an FMU or a CSV row — taking as many
//! internal steps as the tolerance needs and landing on `t + h` with a last, shorter one. So
//! the one [`Stepper`](crate::Stepper) runs it unchanged: `advance_to`, events on dense output,
//! checkpoints (the controller's state is part of the flow's memory, so a continuation is
//! bit-identical).
//!
//! Files: `tolerances.rs` ([`Tolerances`]: the weighted norm), `options.rs`
//! ([`AdaptiveOptions`], [`AdaptiveStats`]), `extrapolation.rs`
//! ([`AdaptiveExtrapolation`]: order- and step-size-controlled extrapolation of a symmetric
//! base step, ODEX's controller), `step_doubling.rs` ([`StepDoubling`]: step-size control of a
//! fixed-order scheme by step doubling and a PI controller), `control.rs` (the state and the
//! stepping every error-controlled flow shares), `first_step.rs` (the first step when none is
//! given, estimated from the base step), `interpolant.rs` (the dense output of an accepted
//! extrapolation step), `reversible.rs` ([`ReversibleSteps`]: time-reversible
//! variable steps along a [`StepDensity`] (`step_density.rs`), for conservative symmetric
//! schemes), `accept.rs` ([`AcceptStep`]: what runs after each accepted
//! step — the projection onto the manifold, or nothing).

mod accept;
mod control;
mod extrapolation;
mod first_step;
mod interpolant;
mod options;
mod reversible;
mod step_density;
mod step_doubling;
mod tolerances;

pub use accept::AcceptStep;
pub use extrapolation::AdaptiveExtrapolation;
pub use options::{AdaptiveOptions, AdaptiveStats};
pub use reversible::ReversibleSteps;
pub use step_density::{DensityFn, StepDensity, step_density};
pub use step_doubling::StepDoubling;
pub use tolerances::Tolerances;
