//! Fixed-step integration with observers that record only what is asked for: a run of the
//! [`Stepper`] over a state the caller keeps.

use crate::error::IntegrateError;
use crate::flow::Flow;
pub use crate::observe::{InvariantError, MaxResidual, Observer, Trajectory};
pub use crate::stepper::IntegrateReport;
use crate::stepper::Stepper;
use crate::vector::Vector;

/// Takes `steps` steps of size `h` from `(t0, x)`, calling `observer` on the initial state and
/// after every step. On error `x` holds the state at the start of the failing step, and the
/// error says which step and when.
pub fn integrate<V, F, O>(
    flow: &mut F,
    x: &mut V,
    t0: V::Real,
    h: V::Real,
    steps: usize,
    observer: &mut O,
) -> Result<IntegrateReport<V::Real>, IntegrateError>
where
    V: Vector,
    F: Flow<V>,
    O: Observer<V>,
{
    let mut stepper = Stepper::new(flow, x, t0, h)?;
    observer.observe(0, t0, stepper.state());
    stepper.advance(steps, observer)
}
