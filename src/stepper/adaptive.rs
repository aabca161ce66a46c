//! The stepper's steps of an adaptive flow's own size: one accepted step at a time, the time
//! advancing by the step the flow chose ([`Flow::step_own`]).

use super::Stepper;
use crate::error::{IntegrateError, StepError};
use crate::flow::Flow;
use crate::observe::Observer;
use crate::real::Real;
use crate::vector::{Vector, ops};
use num_traits::Float as _;
use std::borrow::BorrowMut;

impl<V, F, S> Stepper<V, F, S>
where
    V: Vector,
    F: Flow<V>,
    S: BorrowMut<V>,
{
    /// One step of the flow's own size toward `t_end`, at most there (an adaptive flow,
    /// [`Flow::step_own`]): the step count grows by one and the time by the step taken, and
    /// a step that reaches `t_end` ends on it exactly. Returns the step taken; `None` when the
    /// time is `t_end` already (to rounding) or the flow has no steps of its own — then nothing
    /// changes.
    ///
    /// # Errors
    /// The flow's [`StepError`] (for an adaptive flow, [`StepError::StepSizeTooSmall`] when it
    /// cannot meet its tolerance), or [`StepError::NonFinite`]; the state, time and ledger are
    /// those before the step.
    pub fn step_own(&mut self, t_end: V::Real) -> Result<Option<V::Real>, StepError> {
        let t = self.time();
        let remaining = t_end - t;
        let slack = V::Real::lit(8.0) * V::Real::epsilon() * (t_end.abs() + t.abs());
        if !remaining.is_finite() || remaining.abs() <= slack {
            return Ok(None);
        }
        let x = self.x.borrow_mut();
        self.last.copy_from(x);
        self.last_ledger = self.ledger;
        self.last_ledger.t = t;
        let mut ledger = self.last_ledger;
        let taken = match self.flow.step_own(&mut ledger, remaining, x) {
            None => return Ok(None),
            Some(Err(e)) => {
                x.copy_from(&self.last);
                return Err(e);
            }
            Some(Ok(h)) => h,
        };
        if let Some(component) = ops::first_non_finite(x.as_slice()) {
            x.copy_from(&self.last);
            return Err(StepError::NonFinite { component });
        }
        self.ledger = ledger;
        self.k += 1;
        self.t_base = if taken == remaining { t_end } else { t + taken };
        self.k_base = self.k;
        Ok(Some(taken))
    }

    /// Steps of the flow's own size until the time is `t_end` (an adaptive flow; a fixed-step
    /// flow takes the steps of [`advance_to`](Self::advance_to)), calling `observer` after each.
    /// Returns the number of steps taken.
    ///
    /// # Errors
    /// [`IntegrateError::Step`] naming the failing step and the time it started at; the state
    /// is the one at that time.
    pub fn advance_own_to<O: Observer<V>>(
        &mut self,
        t_end: V::Real,
        observer: &mut O,
    ) -> Result<usize, IntegrateError> {
        let start = self.k;
        loop {
            let k = self.k;
            let t = self.time();
            match self.step_own(t_end) {
                Ok(Some(_)) => observer.observe(self.k, self.time(), self.x.borrow()),
                Ok(None) if self.k == start && self.flow.adaptive_stats().is_none() => {
                    return self.advance_to(t_end, observer);
                }
                Ok(None) => return Ok(self.k - start),
                Err(source) => {
                    return Err(IntegrateError::Step {
                        step: k,
                        t: t.to_f64_lossy(),
                        source,
                    });
                }
            }
        }
    }
}
