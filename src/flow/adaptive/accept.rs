//! What an adaptive flow runs after each accepted step.

use crate::error::StepError;
use crate::flow::FlowStats;
use crate::vector::{Vector, ops};

/// A map applied to each accepted step's result: the projection onto the constraint manifold
/// ([`ManifoldProjection`](crate::flow::ManifoldProjection): `g = 0` and, in the degenerate
/// case, `φ = 0`, to the Newton tolerance), or nothing (`()`). An extrapolated step is an affine
/// combination of states on the manifold, so it lies off it by its local error; projecting
/// keeps the order (Hairer, Lubich & Wanner, *Geometric Numerical Integration*, Theorem IV.4.1)
/// and the residuals at round-off after every accepted step.
pub trait AcceptStep<V: Vector> {
    /// Maps the accepted result `x` in place. On error `x` may hold anything: the caller
    /// restores it.
    ///
    /// # Errors
    /// The projection's [`StepError`] (its Newton failure).
    fn accept(&mut self, x: &mut V) -> Result<(), StepError>;
    /// The map's work counters.
    fn stats(&self) -> FlowStats {
        FlowStats::default()
    }
    /// Forgets kept Jacobians (after a restore of the flow's memory).
    fn forget(&mut self) {}
}

impl<V: Vector> AcceptStep<V> for () {
    fn accept(&mut self, _x: &mut V) -> Result<(), StepError> {
        Ok(())
    }
}

/// `finish` applied to an accepted result, which must come out finite.
///
/// # Errors
/// The map's [`StepError`], or [`StepError::NonFinite`] naming the first non-finite component.
pub(crate) fn finish_accepted<V: Vector, P: AcceptStep<V>>(
    finish: &mut P,
    x: &mut V,
) -> Result<(), StepError> {
    finish.accept(x)?;
    match ops::first_non_finite(x.as_slice()) {
        Some(component) => Err(StepError::NonFinite { component }),
        None => Ok(()),
    }
}
