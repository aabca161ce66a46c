//! What one assembled term of a scene cost in a run.

use serde::Serialize;

/// One assembled term and what it cost in a run.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EffectReport {
    /// The label (the effect's `name`, or its type).
    pub name: String,
    /// The kind (`gravity`, `spring`, …).
    pub kind: &'static str,
    /// Evaluations of the term (energy, gradient, Hessian products, flows, `M` products).
    pub evaluations: u64,
    /// Share of the run's time (stepping and the diagnostics after each step) spent in the
    /// term (with the `profile` diagnostic).
    pub time_share: Option<f64>,
}
