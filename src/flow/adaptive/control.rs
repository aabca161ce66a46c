//! What every error-controlled adaptive flow shares: the controller's state ([`Control`]), a
//! macro step's verdict ([`Outcome`]), and the stepping built on one macro step
//! ([`MacroStep`]): a call's bookkeeping (what a failure restores), the macro steps until one
//! is accepted, `step(h)` landing on `t + h` ([`step_at`]) and one step of the flow's own size
//! ([`step_own`]).

use super::{AdaptiveOptions, AdaptiveStats};
use crate::error::StepError;
use crate::flow::Ledger;
use crate::real::Real;
use crate::vector::Vector;
use num_traits::{Float as _, One as _, Zero as _};

/// How a macro step went.
pub(crate) enum Outcome<T> {
    Accepted,
    /// Rejected, with the step to try next.
    Rejected(T),
}

/// The state an error controller keeps between macro steps, and what a call restores.
#[derive(Debug)]
pub(crate) struct Control<V: Vector> {
    pub(crate) options: AdaptiveOptions<V::Real>,
    /// The next macro step to try (`None`: none taken yet).
    pub(crate) h_next: Option<V::Real>,
    /// Whether the last macro step was rejected (no increase of the step after one).
    pub(crate) rejected_last: bool,
    /// The error estimate of the last rejected step (for the message when the step fails).
    pub(crate) rejected_error: f64,
    pub(crate) stats: AdaptiveStats,
    /// The call's start: the state and the memory a failure restores.
    whole: V,
    whole_memory: Vec<V::Real>,
}

impl<V: Vector> Control<V> {
    pub(crate) fn new(mut options: AdaptiveOptions<V::Real>) -> Self {
        options
            .breakpoints
            .sort_by(|a, b| a.partial_cmp(b).unwrap_or(core::cmp::Ordering::Equal));
        Self {
            options,
            h_next: None,
            rejected_last: false,
            rejected_error: 0.0,
            stats: AdaptiveStats {
                smallest: f64::INFINITY,
                ..AdaptiveStats::default()
            },
            whole: V::zeros(0),
            whole_memory: Vec::new(),
        }
    }

    /// Appends the proposal and the last verdict (two values).
    pub(crate) fn save(&self, out: &mut Vec<V::Real>) {
        let one = V::Real::one();
        out.push(self.h_next.unwrap_or(-one));
        out.push(if self.rejected_last {
            one
        } else {
            V::Real::zero()
        });
    }

    /// Reads back what [`save`](Self::save) appended.
    pub(crate) fn restore(&mut self, head: &[V::Real]) {
        self.h_next = (head[0] >= V::Real::zero()).then_some(head[0]);
        self.rejected_last = head[1] != V::Real::zero();
    }

    /// Books an accepted step of length `h` at order `2 rows` with estimate `err`.
    pub(crate) fn book_accepted(&mut self, h: f64, rows: usize, err: f64) {
        let s = &mut self.stats;
        s.accepted += 1;
        s.orders[rows.min(s.orders.len() - 1)] += 1;
        s.smallest = s.smallest.min(h);
        s.largest = s.largest.max(h);
        s.last_error = err;
    }

    /// `left` clipped to end on the first breakpoint ahead of `t` in the direction `sign`
    /// (one within rounding of `t` is passed).
    fn to_breakpoint(&self, t: V::Real, sign: V::Real, left: V::Real) -> V::Real {
        let b = &self.options.breakpoints;
        if b.is_empty() {
            return left;
        }
        let near = |p: V::Real| {
            (p - t).abs() <= V::Real::lit(8.0) * V::Real::epsilon() * (t.abs() + p.abs())
        };
        let ahead = if sign > V::Real::zero() {
            let i = b.partition_point(|&p| p <= t);
            b[i..].iter().copied().find(|&p| !near(p))
        } else {
            let i = b.partition_point(|&p| p < t);
            b[..i].iter().rev().copied().find(|&p| !near(p))
        };
        ahead.map_or(left, |p| left.min((p - t).abs()))
    }

    /// Books a rejected step with estimate `err`.
    pub(crate) fn book_rejected(&mut self, err: f64) {
        self.rejected_last = true;
        self.rejected_error = err;
        self.stats.rejected += 1;
    }
}

/// One macro step of an error-controlled flow, and the state it keeps.
pub(crate) trait MacroStep<V: Vector> {
    /// The flow's name, for messages.
    const NAME: &'static str;
    fn control(&mut self) -> &mut Control<V>;
    /// One macro step of size `big` from `x`: on acceptance `x` and `ledger` advance and the
    /// next step is proposed (`control().h_next`); on rejection or failure both and the base
    /// flow's memory are as they were.
    fn attempt(
        &mut self,
        ledger: &mut Ledger<V::Real>,
        big: V::Real,
        x: &mut V,
    ) -> Result<Outcome<V::Real>, StepError>;
    /// Appends the controller's state and the base flow's memory.
    fn save_all(&mut self, out: &mut Vec<V::Real>);
    /// Reads back what [`save_all`](Self::save_all) appended.
    fn restore_all(&mut self, from: &mut &[V::Real]);
    /// Allocates the workspace for states like `x`.
    fn prepare_all(&mut self, x: &V);
    /// The first step to try from `x`, at most `span` long in the direction `sign`, when none
    /// was given ([`first_step::estimate`](super::first_step::estimate)), and the base steps
    /// it took; `None`: the span.
    fn first_step(
        &mut self,
        ledger: &Ledger<V::Real>,
        sign: V::Real,
        span: V::Real,
        x: &V,
    ) -> (Option<V::Real>, u64);
    /// The longest macro step the flow takes now, beside `h_max` (unbounded by default).
    fn longest(&self) -> V::Real {
        V::Real::infinity()
    }
    /// Dense output from the flow's interpolant of its last accepted step at `ledger.t`
    /// ([`Flow::interpolate`](crate::flow::Flow::interpolate)); `None`: no interpolant covers it.
    fn interpolate(
        &mut self,
        ledger: &mut Ledger<V::Real>,
        out: &mut V,
    ) -> Option<Result<(), StepError>> {
        let _ = (ledger, out);
        None
    }
}

/// The [`Flow`](crate::flow::Flow) of an error-controlled flow `$ty<V, F, P>` with fields `base:
/// F`, `finish: P` and `control: Control<V>`, implementing [`MacroStep`]: `step(h)` lands on
/// `t + h` ([`step_at`]), `step_own` takes one step of the controller's size ([`step_own`]), the
/// work counters, multipliers and dissipation are the base flow's, the memory is the
/// controller's and the base flow's. `$order` is the flow's order as an expression of `self`.
macro_rules! controlled_flow {
    ($ty:ident, |$s:ident| $order:expr) => {
        impl<V: Vector, F: Flow<V>, P: AcceptStep<V>> Flow<V> for $ty<V, F, P> {
            fn step(&mut self, h: V::Real, x: &mut V) -> Result<(), StepError> {
                self.step_at(&mut Ledger::default(), h, x)
            }
            /// Advances by exactly `h`: steps of the controller's choosing, the last fitted to
            /// land on `t + h`.
            fn step_at(
                &mut self,
                ledger: &mut Ledger<V::Real>,
                h: V::Real,
                x: &mut V,
            ) -> Result<(), StepError> {
                $crate::flow::adaptive::control::step_at(self, ledger, h, x)
            }
            /// One step of the controller's own size, at most `|max|`, in the direction of
            /// `max`.
            fn step_own(
                &mut self,
                ledger: &mut Ledger<V::Real>,
                max: V::Real,
                x: &mut V,
            ) -> Option<Result<V::Real, StepError>> {
                Some($crate::flow::adaptive::control::step_own(
                    self, ledger, max, x,
                ))
            }
            fn order(&self) -> u32 {
                let $s = self;
                $order
            }
            fn is_symmetric(&self) -> bool {
                false
            }
            fn prepare(&mut self, x: &V) {
                MacroStep::prepare_all(self, x);
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
                MacroStep::save_all(self, out);
            }
            fn restore_memory(&mut self, from: &mut &[V::Real]) {
                MacroStep::restore_all(self, from);
            }
            fn adaptive_stats(&self) -> Option<AdaptiveStats> {
                Some(self.control.stats)
            }
            fn interpolate(
                &mut self,
                ledger: &mut Ledger<V::Real>,
                out: &mut V,
            ) -> Option<Result<(), StepError>> {
                MacroStep::interpolate(self, ledger, out)
            }
        }
    };
}
pub(crate) use controlled_flow;

/// Checks a call's step and state and keeps what a failure restores: `false` for a zero step.
fn begin<V: Vector, M: MacroStep<V>>(m: &mut M, h: V::Real, x: &V) -> Result<bool, StepError> {
    if !crate::flow::check_step(h, x)? {
        return Ok(false);
    }
    let tolerances = &m.control().options.tolerances;
    if !tolerances.fits(x.len()) {
        return Err(StepError::StateLength {
            flow: M::NAME,
            expected: tolerances.components(),
            got: x.len(),
        });
    }
    m.prepare_all(x);
    let c = m.control();
    if c.whole.len() != x.len() {
        c.whole = x.zeros_like();
    }
    c.whole.copy_from(x);
    let mut memory = core::mem::take(&mut c.whole_memory);
    memory.clear();
    m.save_all(&mut memory);
    m.control().whole_memory = memory;
    Ok(true)
}

/// Ends a call: on success the ledger's time is exactly `t + h`; on failure the state, the
/// ledger and the memory are those of the call's start.
fn end<V: Vector, M: MacroStep<V>>(
    m: &mut M,
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
            let c = m.control();
            x.copy_from(&c.whole);
            *ledger = l_whole;
            let memory = core::mem::take(&mut c.whole_memory);
            let mut from = memory.as_slice();
            m.restore_all(&mut from);
            m.control().whole_memory = memory;
            Err(e)
        }
    }
}

/// Macro steps in the direction `sign` until one is accepted, none longer than `left`; returns
/// its length. Rejected and failed attempts shrink the step; below `h_min` (or where the step
/// no longer moves time) the error names the time and the cause.
fn until_accepted<V: Vector, M: MacroStep<V>>(
    m: &mut M,
    ledger: &mut Ledger<V::Real>,
    sign: V::Real,
    left: V::Real,
    x: &mut V,
) -> Result<V::Real, StepError> {
    // No step across a breakpoint: the interval ends on the next one.
    let left = m.control().to_breakpoint(ledger.t, sign, left);
    loop {
        let longest = m.longest();
        let c = m.control();
        let h_max = c
            .options
            .h_max
            .map_or_else(V::Real::infinity, |v| v.abs())
            .min(longest);
        // No step taken and none given: the first is estimated from the flow's derivatives
        // (not below the smallest step allowed).
        let estimated = if c.h_next.is_none() && c.options.first_step.is_none() {
            let (h, steps) = m.first_step(ledger, sign, left.min(h_max), x);
            let c = m.control();
            c.stats.base_steps += steps;
            h.map(|h| h.max(c.options.h_min))
        } else {
            None
        };
        let c = m.control();
        let raw = c
            .h_next
            .or(c.options.first_step)
            .or(estimated)
            .map_or(left, |v| v.abs());
        // The controller's proposal taken down to the ladder 2^{k/4}: successive steps then
        // often share a size, and so do their sub-steps, whose per-size work a base flow keeps
        // (an exact linear flow's exponentials, a kept Newton matrix). Not below `h_max` or the
        // interval's end when the proposal itself reaches them: steps bounded by `h_max` share
        // its size, and an interval the proposal spans is one step, not two halves of a rung
        // just short of it (a scene's report interval, `h_max` by default, would take two).
        let proposal = if raw >= h_max {
            h_max
        } else if c.h_next.is_some() && raw < left {
            ladder(raw)
        } else {
            raw
        };
        // Up to the end of the interval: in one step when the proposal reaches it, in two equal
        // ones when it falls short by less than itself (not a step and a sliver).
        let big = if proposal >= left {
            left
        } else if proposal + proposal > left {
            left * V::Real::lit(0.5)
        } else {
            proposal
        };
        let t = ledger.t;
        // Why the attempt was not accepted, put into words only if it ends the run (a
        // rejection is routine: no message, no allocation).
        let failure = match m.attempt(ledger, sign * big, x) {
            Ok(Outcome::Accepted) => {
                // A step shortened to fit the interval says nothing against the longer one
                // proposed before it.
                let c = m.control();
                if big < proposal
                    && let Some(next) = c.h_next
                {
                    c.h_next = Some(next.max(proposal));
                }
                return Ok(big);
            }
            Ok(Outcome::Rejected(next)) => {
                m.control().h_next = Some(next.abs());
                None
            }
            Err(e) => {
                let c = m.control();
                c.stats.failed += 1;
                c.rejected_last = true;
                c.h_next = Some(big * V::Real::lit(0.5));
                Some(e)
            }
        };
        let c = m.control();
        let next = c.h_next.unwrap_or(big);
        if next <= c.options.h_min || t + sign * next == t {
            let cause = match failure {
                Some(e) => e.to_string(),
                None => format!(
                    "the error estimate stayed above the tolerance ({:.3e} of it, in the weighted norm)",
                    c.rejected_error
                ),
            };
            return Err(StepError::StepSizeTooSmall {
                t: t.to_f64_lossy(),
                h: next.to_f64_lossy(),
                h_min: c.options.h_min.to_f64_lossy(),
                cause,
            });
        }
    }
}

/// Advances by exactly `h`: macro steps of the controller's choosing, the last clipped to land
/// on `t + h` (see [`Flow::step_at`](crate::flow::Flow::step_at)).
pub(crate) fn step_at<V: Vector, M: MacroStep<V>>(
    m: &mut M,
    ledger: &mut Ledger<V::Real>,
    h: V::Real,
    x: &mut V,
) -> Result<(), StepError> {
    if !begin(m, h, x)? {
        return Ok(());
    }
    let l_whole = *ledger;
    let span = h.abs();
    let mut done = V::Real::zero();
    let mut result = Ok(());
    while done < span {
        let left = span - done;
        match until_accepted(m, ledger, h.signum(), left, x) {
            Ok(taken) => done = if taken >= left { span } else { done + taken },
            Err(e) => {
                result = Err(e);
                break;
            }
        }
    }
    end(m, result, ledger, l_whole, h, x)
}

/// One macro step of the controller's own size, at most `|max|`, in the direction of `max`
/// (see [`Flow::step_own`](crate::flow::Flow::step_own)).
pub(crate) fn step_own<V: Vector, M: MacroStep<V>>(
    m: &mut M,
    ledger: &mut Ledger<V::Real>,
    max: V::Real,
    x: &mut V,
) -> Result<V::Real, StepError> {
    if !begin(m, max, x)? {
        return Ok(V::Real::zero());
    }
    let l_whole = *ledger;
    let taken = until_accepted(m, ledger, max.signum(), max.abs(), x);
    let h = match taken {
        Ok(t) if t < max.abs() => max.signum() * t,
        _ => max,
    };
    end(m, taken.map(|_| ()), ledger, l_whole, h, x)?;
    Ok(h)
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
