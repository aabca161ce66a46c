//! How [`AdaptiveExtrapolation`] steps: a call's bookkeeping (what a failure restores), the
//! macro steps until one is accepted, and the [`Flow`] it is — `step(h)` lands on `t + h`,
//! `step_own` takes one step of its own size.

use super::{AcceptStep, AdaptiveExtrapolation, AdaptiveStats, Outcome};
use crate::error::StepError;
use crate::flow::{Flow, FlowStats, Ledger, Multipliers};
use crate::real::Real;
use crate::vector::Vector;
use num_traits::{Float as _, Zero as _};

impl<V: Vector, F: Flow<V>, P: AcceptStep<V>> AdaptiveExtrapolation<V, F, P> {
    /// Checks a call's step and state and keeps what a failure restores: `false` for a zero
    /// step (nothing to do).
    fn begin(&mut self, h: V::Real, x: &V) -> Result<bool, StepError> {
        if !crate::flow::check_step(h, x)? {
            return Ok(false);
        }
        if !self.options.tolerances.fits(x.len()) {
            return Err(StepError::StateLength {
                flow: "adaptive extrapolation (per-component tolerances)",
                expected: self.options.tolerances.components(),
                got: x.len(),
            });
        }
        self.prepare(x);
        self.whole.copy_from(x);
        let mut memory = core::mem::take(&mut self.whole_memory);
        memory.clear();
        self.save_all(&mut memory);
        self.whole_memory = memory;
        Ok(true)
    }

    /// Ends a call: on success the ledger's time is exactly `t + h`; on failure the state, the
    /// ledger and the memory are those of the call's start.
    fn end(
        &mut self,
        result: Result<(), StepError>,
        ledger: &mut Ledger<V::Real>,
        l_whole: Ledger<V::Real>,
        h: V::Real,
        x: &mut V,
    ) -> Result<(), StepError> {
        match result {
            Ok(()) => {
                ledger.t = l_whole.t + h;
                Ok(())
            }
            Err(e) => {
                x.copy_from(&self.whole);
                *ledger = l_whole;
                let memory = core::mem::take(&mut self.whole_memory);
                let mut from = memory.as_slice();
                self.restore_all(&mut from);
                self.whole_memory = memory;
                Err(e)
            }
        }
    }

    /// Macro steps in the direction `sign` until one is accepted, none longer than `left`;
    /// returns its length. Rejected and failed attempts shrink the step; below `h_min` (or
    /// where the step no longer moves time) the error names the time and the cause.
    fn until_accepted(
        &mut self,
        ledger: &mut Ledger<V::Real>,
        sign: V::Real,
        left: V::Real,
        x: &mut V,
    ) -> Result<V::Real, StepError> {
        let h_max = self
            .options
            .h_max
            .map_or_else(V::Real::infinity, |v| v.abs());
        loop {
            // The controller's proposal taken down to the ladder 2^{k/4}: successive steps then
            // often share a size, and so do their rows' sub-steps, whose per-size work a base
            // flow keeps (an exact linear flow's exponentials, a kept Newton matrix).
            let proposal = self
                .h_next
                .map(ladder)
                .or(self.options.first_step)
                .map_or(left, |v| v.abs())
                .min(h_max);
            // Up to the end of the interval: in one step when the proposal reaches it, in two
            // equal ones when it falls short by less than itself (not a step and a sliver).
            let big = if proposal >= left {
                left
            } else if proposal + proposal > left {
                left * V::Real::lit(0.5)
            } else {
                proposal
            };
            let t = ledger.t;
            let cause = match self.attempt(ledger, sign * big, x) {
                Ok(Outcome::Accepted) => {
                    // A step shortened to fit the interval says nothing against the longer one
                    // proposed before it.
                    if big < proposal
                        && let Some(next) = self.h_next
                    {
                        self.h_next = Some(next.max(proposal));
                    }
                    return Ok(big);
                }
                Ok(Outcome::Rejected(next)) => {
                    self.h_next = Some(next.abs());
                    format!(
                        "the error estimate stayed above the tolerance ({:.3e} of it, in the weighted norm)",
                        self.rejected_error
                    )
                }
                Err(e) => {
                    self.stats.failed += 1;
                    self.rejected_last = true;
                    self.h_next = Some(big * V::Real::lit(0.5));
                    e.to_string()
                }
            };
            let next = self.h_next.unwrap_or(big);
            if next <= self.options.h_min || t + sign * next == t {
                return Err(self.too_small(t, next, cause));
            }
        }
    }

    /// One macro step of its own size, at most `|max|` (see [`Flow::step_own`]).
    fn own_step(
        &mut self,
        ledger: &mut Ledger<V::Real>,
        max: V::Real,
        x: &mut V,
    ) -> Result<V::Real, StepError> {
        if !self.begin(max, x)? {
            return Ok(V::Real::zero());
        }
        let l_whole = *ledger;
        let taken = self.until_accepted(ledger, max.signum(), max.abs(), x);
        let h = match taken {
            Ok(t) if t < max.abs() => max.signum() * t,
            _ => max,
        };
        self.end(taken.map(|_| ()), ledger, l_whole, h, x)?;
        Ok(h)
    }

    fn too_small(&self, t: V::Real, h: V::Real, cause: String) -> StepError {
        StepError::StepSizeTooSmall {
            t: t.to_f64_lossy(),
            h: h.to_f64_lossy(),
            h_min: self.options.h_min.to_f64_lossy(),
            cause,
        }
    }
}

impl<V: Vector, F: Flow<V>, P: AcceptStep<V>> Flow<V> for AdaptiveExtrapolation<V, F, P> {
    fn step(&mut self, h: V::Real, x: &mut V) -> Result<(), StepError> {
        self.step_at(&mut Ledger::default(), h, x)
    }

    /// Advances by exactly `h`: macro steps of the controller's choosing, the last clipped to
    /// land on `t + h`.
    fn step_at(
        &mut self,
        ledger: &mut Ledger<V::Real>,
        h: V::Real,
        x: &mut V,
    ) -> Result<(), StepError> {
        if !self.begin(h, x)? {
            return Ok(());
        }
        let l_whole = *ledger;
        let span = h.abs();
        let mut done = V::Real::zero();
        let mut result = Ok(());
        while done < span {
            let left = span - done;
            match self.until_accepted(ledger, h.signum(), left, x) {
                Ok(taken) => done = if taken >= left { span } else { done + taken },
                Err(e) => {
                    result = Err(e);
                    break;
                }
            }
        }
        self.end(result, ledger, l_whole, h, x)
    }

    /// One macro step of the controller's own size, at most `|max|`, in the direction of `max`.
    fn step_own(
        &mut self,
        ledger: &mut Ledger<V::Real>,
        max: V::Real,
        x: &mut V,
    ) -> Option<Result<V::Real, StepError>> {
        Some(self.own_step(ledger, max, x))
    }

    fn order(&self) -> u32 {
        2 * self.kmax as u32
    }

    fn is_symmetric(&self) -> bool {
        false
    }

    fn prepare(&mut self, x: &V) {
        if self.prev.len() != self.kmax || self.start.len() != x.len() {
            self.start = x.zeros_like();
            self.whole = x.zeros_like();
            self.prev = (0..self.kmax).map(|_| x.zeros_like()).collect();
            self.cur = (0..self.kmax).map(|_| x.zeros_like()).collect();
        }
        self.base.prepare(x);
    }

    fn stats(&self) -> FlowStats {
        self.base.stats() + self.finish.stats()
    }

    fn multipliers(&self) -> Option<Multipliers<'_, V::Real>> {
        self.base.multipliers()
    }

    fn dissipates(&self) -> bool {
        self.base.dissipates()
    }

    fn save_memory(&mut self, out: &mut Vec<V::Real>) {
        self.save_all(out);
    }

    fn adaptive_stats(&self) -> Option<AdaptiveStats> {
        Some(self.stats)
    }

    fn restore_memory(&mut self, from: &mut &[V::Real]) {
        self.restore_all(from);
    }
}

/// The largest `2^{k/4}` (k an integer) not above `|h|`.
fn ladder<T: Real>(h: T) -> T {
    let h = h.abs();
    let k = (h.to_f64_lossy().log2() * 4.0).floor();
    let rung = T::lit((k / 4.0).exp2());
    if rung > T::zero() && rung <= h && rung.is_finite() {
        rung
    } else {
        h
    }
}
