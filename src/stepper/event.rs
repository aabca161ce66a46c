//! Events `e(t, x) = 0`: detected by a sign change over a step, located on the dense output,
//! and stepped to.

use super::Stepper;
use crate::error::StepError;
use crate::flow::Flow;
use crate::real::Real;
use crate::vector::Vector;
use num_traits::Float as _;
use num_traits::{One, Zero};
use std::borrow::BorrowMut;

/// The step a watched step takes: one of the grid, one of `h` off it, or one of the flow's
/// own size toward a time.
#[derive(Clone, Copy)]
enum Take<R> {
    Grid,
    OffGrid(R),
    Own(R),
}

/// A watched step of the flow's own size: its length and the earliest event in it.
pub type WatchedStep<R> = (R, Option<EventHit<R>>);

/// Which crossings of zero count.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Direction {
    /// From `e < 0` to `e ≥ 0`.
    Rising,
    /// From `e > 0` to `e ≤ 0`.
    Falling,
    /// Either way.
    Either,
}

/// The event function type: `e(t, x)`.
type EventFn<V> = Box<dyn FnMut(<V as Vector>::Real, &V) -> <V as Vector>::Real + Send>;

/// An event function `e(t, x)` with the direction of the crossings it reports and whether
/// the run should stop there.
pub struct Event<V: Vector> {
    function: EventFn<V>,
    direction: Direction,
    terminal: bool,
}

impl<V: Vector> core::fmt::Debug for Event<V> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Event")
            .field("direction", &self.direction)
            .field("terminal", &self.terminal)
            .finish_non_exhaustive()
    }
}

impl<V: Vector> Event<V> {
    /// A non-terminal event (recorded, the run goes on).
    pub fn new(
        function: impl FnMut(V::Real, &V) -> V::Real + Send + 'static,
        direction: Direction,
    ) -> Self {
        Self {
            function: Box::new(function),
            direction,
            terminal: false,
        }
    }
    /// Makes the event terminal: the run should stop at it.
    pub fn terminal(mut self) -> Self {
        self.terminal = true;
        self
    }
    fn crosses(&self, before: V::Real, after: V::Real) -> bool {
        let zero = V::Real::zero();
        let rising = before < zero && after >= zero;
        let falling = before > zero && after <= zero;
        match self.direction {
            Direction::Rising => rising,
            Direction::Falling => falling,
            Direction::Either => rising || falling,
        }
    }
}

/// An event that occurred: which one, when, and whether it is terminal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EventHit<T> {
    /// Its index in the [`Events`].
    pub index: usize,
    /// The located time.
    pub t: T,
    /// `e(t, x)` at the located state (zero to the location's accuracy).
    pub value: T,
    /// The event asked the run to stop.
    pub terminal: bool,
    /// Dense evaluations (steps) spent locating it.
    pub evaluations: usize,
}

/// The events watched during a run, with their values at the last step point.
#[derive(Debug)]
pub struct Events<V: Vector> {
    events: Vec<Event<V>>,
    /// Every event the last watched step found, in time order.
    hits: Vec<EventHit<V::Real>>,
    previous: Vec<V::Real>,
    started: bool,
    scratch: Option<V>,
    located_valid: bool,
    /// The time tolerance of the location (absolute, scaled by `max(1, |t|)`).
    pub tolerance: V::Real,
}

impl<V: Vector> Events<V> {
    /// Watches `events`; locates their times to `1e-13 · max(1, |t|)`.
    pub fn new(events: Vec<Event<V>>) -> Self {
        let n = events.len();
        Self {
            events,
            // A fixed-step flow's step records at most one: no allocation per step (and none at
            // all without events).
            hits: Vec::with_capacity(2 * n),
            previous: vec![V::Real::zero(); n],
            started: false,
            scratch: None,
            located_valid: false,
            tolerance: V::Real::lit(1e-13),
        }
    }
    /// The state at the event the last watched step returned (`None` if it returned none).
    pub fn located(&self) -> Option<&V> {
        self.scratch.as_ref().filter(|_| self.located_valid)
    }
    /// Every event the last watched step found, in time order (the call returned the first):
    /// an adaptive flow's step to a report time may hold several.
    pub fn hits(&self) -> &[EventHit<V::Real>] {
        &self.hits
    }
    /// The number of events.
    pub fn len(&self) -> usize {
        self.events.len()
    }
    /// `true` when no event is watched.
    pub fn is_empty(&self) -> bool {
        self.events.is_empty()
    }
    /// The events' values at the last step point (what a crossing is detected against), for
    /// a checkpoint; empty before the first watched step.
    pub fn values(&self) -> &[V::Real] {
        if self.started { &self.previous } else { &[] }
    }
    /// Restores the values of [`values`](Self::values) (an empty slice: not started).
    pub fn set_values(&mut self, values: &[V::Real]) {
        self.started = values.len() == self.previous.len() && !values.is_empty();
        if self.started {
            self.previous.copy_from_slice(values);
        }
    }
    fn evaluate_all(&mut self, t: V::Real, x: &V) {
        for (e, p) in self.events.iter_mut().zip(self.previous.iter_mut()) {
            *p = (e.function)(t, x);
        }
    }
}

impl<V, F, S> Stepper<V, F, S>
where
    V: Vector,
    F: Flow<V>,
    S: BorrowMut<V>,
{
    /// One step, watching `events`. When one or more cross zero over the step (in their
    /// direction), the earliest crossing is located on the dense output (Illinois regula
    /// falsi on `θ ↦ e(t_prev + θ h, x(t_prev + θ h))`, each evaluation one step of the
    /// scheme from the previous point, so a projected flow's state there is on the
    /// constraint manifold at round-off) and returned:
    ///
    /// - a terminal event moves the stepper to it (a step to the root); the grid of later
    ///   steps, if the caller goes on, starts there, and the event is not reported again at
    ///   the root it was stepped to;
    /// - a non-terminal event is recorded only: the stepper stays at the end of the step, on
    ///   its grid, so recording events does not change the trajectory; the state at the event
    ///   is [`Events::located`].
    ///
    /// A sign change and back within one step is not seen. An adaptive flow (one with steps
    /// of its own, [`Flow::step_own`]) is watched at each of its accepted steps to the step's
    /// end, not at the step's two ends, which may be a report interval apart: every event it
    /// finds is in [`Events::hits`], the first returned (a terminal one ends the step there).
    ///
    /// # Errors
    /// The step's [`StepError`]: the stepper is then at the start of the step, or, for an
    /// adaptive flow, at the end of its last accepted step before the failure.
    pub fn step_with_events(
        &mut self,
        events: &mut Events<V>,
    ) -> Result<Option<EventHit<V::Real>>, StepError> {
        self.step_watched(None, events, &mut |_| {})
    }

    /// As [`step_with_events`](Self::step_with_events), with a step of size `h` off the grid
    /// (the last, shorter step to a time; the grid restarts from its end).
    pub fn step_by_with_events(
        &mut self,
        h: V::Real,
        events: &mut Events<V>,
    ) -> Result<Option<EventHit<V::Real>>, StepError> {
        self.step_watched(Some(h), events, &mut |_| {})
    }

    /// A step of the grid (`short = None`) or of `short` off it, watching `events` as
    /// [`step_with_events`](Self::step_with_events) does, and passing the state after each
    /// step the flow takes to `each` — one call for a fixed-step flow, one per accepted step
    /// for an adaptive one (what must see every step, such as an angle unwrapped against the
    /// last: less than half a turn a step).
    ///
    /// # Errors
    /// As [`step_with_events`](Self::step_with_events).
    pub fn step_watched(
        &mut self,
        short: Option<V::Real>,
        events: &mut Events<V>,
        each: &mut dyn FnMut(&V),
    ) -> Result<Option<EventHit<V::Real>>, StepError> {
        events.hits.clear();
        let take = short.map_or(Take::Grid, Take::OffGrid);
        if self.flow.adaptive_stats().is_none() {
            let hit = self.watched_step(events, take)?.and_then(|(_, hit)| hit);
            events.hits.extend(hit);
            each(self.x.borrow());
            return Ok(hit);
        }
        // The accepted steps to the step's end, each watched; then one step of the count, the
        // grid where it was (or restarting from the end of an off-grid step, or from a
        // terminal event).
        let (k0, t_base0, k_base0) = (self.k, self.t_base, self.k_base);
        let target = match short {
            None => self.t_base + V::Real::lit((self.k + 1 - self.k_base) as f64) * self.h,
            Some(h) => self.time() + h,
        };
        let mut terminal = false;
        loop {
            match self.watched_step(events, Take::Own(target)) {
                Ok(None) => break,
                Ok(Some((_, hit))) => {
                    each(self.x.borrow());
                    if let Some(hit) = hit {
                        events.hits.push(hit);
                        if hit.terminal {
                            terminal = true;
                            break;
                        }
                    }
                }
                Err(e) => {
                    // At the end of the last accepted step (its time, from step_own).
                    self.k = k0;
                    self.k_base = k0;
                    return Err(e);
                }
            }
        }
        self.k = k0 + 1;
        match (short, terminal) {
            (None, false) => (self.t_base, self.k_base) = (t_base0, k_base0),
            (Some(_), false) => (self.t_base, self.k_base) = (target, self.k),
            (_, true) => self.k_base = self.k,
        }
        Ok(events.hits.first().copied())
    }

    /// As [`step_with_events`](Self::step_with_events), with a step of the flow's own size
    /// toward `t_end` ([`step_own`](Self::step_own): an adaptive flow's next accepted step);
    /// the crossing is located on the dense output of that step. Returns the step taken (to a
    /// terminal event, when one stopped it there) and the event found in it; `None` when no step was taken (the time is `t_end`, or the flow
    /// has no steps of its own).
    ///
    /// # Errors
    /// The step's [`StepError`] (the stepper is then at the start of the step).
    pub fn step_own_with_events(
        &mut self,
        t_end: V::Real,
        events: &mut Events<V>,
    ) -> Result<Option<WatchedStep<V::Real>>, StepError> {
        self.watched_step(events, Take::Own(t_end))
    }

    /// The step `take` watching `events`: the step's length and the earliest event in it,
    /// `None` when no step was taken.
    fn watched_step(
        &mut self,
        events: &mut Events<V>,
        take: Take<V::Real>,
    ) -> Result<Option<WatchedStep<V::Real>>, StepError> {
        if !events.started {
            let (t, x) = (self.time(), self.x.borrow());
            events.evaluate_all(t, x);
            events.started = true;
        }
        let start = self.time();
        match take {
            Take::OffGrid(h) => self.step_off_grid(h)?,
            Take::Grid => self.step()?,
            Take::Own(t_end) => {
                if self.step_own(t_end)?.is_none() {
                    return Ok(None);
                }
            }
        }
        let t1 = self.time();
        let t0 = self.previous_time();
        let mut earliest: Option<EventHit<V::Real>> = None;
        let mut scratch = events
            .scratch
            .take()
            .unwrap_or_else(|| self.x.borrow().clone());
        for i in 0..events.len() {
            let after = (events.events[i].function)(t1, self.x.borrow());
            let before = events.previous[i];
            if !events.events[i].crosses(before, after) {
                continue;
            }
            let end = earliest.map_or(t1, |e| e.t);
            let hit = self.locate(events, i, (t0, before), (t1, after), end, &mut scratch);
            match hit {
                Ok(Some(hit)) if earliest.is_none_or(|e| hit.t < e.t) => earliest = Some(hit),
                Ok(_) => {}
                Err(e) => {
                    events.scratch = Some(scratch);
                    return Err(e);
                }
            }
        }
        let result = match earliest {
            Some(hit) if hit.terminal => {
                if hit.t < t1 {
                    self.step_back_to(hit.t, &mut scratch)?;
                }
                let (t, x) = (self.time(), self.x.borrow());
                events.evaluate_all(t, x);
                // Stepped to its root: the next step starts from zero, not re-reported.
                events.previous[hit.index] = V::Real::zero();
                events.located_valid = true;
                Some(hit)
            }
            Some(hit) => {
                // The state at the event, kept for the caller; the stepper stays put.
                self.dense(hit.t, &mut scratch)?;
                let (t, x) = (self.time(), self.x.borrow());
                events.evaluate_all(t, x);
                events.located_valid = true;
                Some(hit)
            }
            None => {
                let (t, x) = (self.time(), self.x.borrow());
                events.evaluate_all(t, x);
                events.located_valid = false;
                None
            }
        };
        events.scratch = Some(scratch);
        // After a terminal event, the step to it.
        Ok(Some((self.time() - start, result)))
    }

    /// Locates the crossing of event `i` in `[t0, t1]` (values `e0`, `e1` of opposite signs, or
    /// `e1 = 0`); `None` when it lies after `end` (an earlier event was found).
    fn locate(
        &mut self,
        events: &mut Events<V>,
        i: usize,
        (mut a, mut fa): (V::Real, V::Real),
        (mut b, mut fb): (V::Real, V::Real),
        end: V::Real,
        scratch: &mut V,
    ) -> Result<Option<EventHit<V::Real>>, StepError> {
        let tol = events.tolerance * V::Real::one().max(b.abs());
        let zero = V::Real::zero();
        let half = V::Real::lit(0.5);
        let mut evaluations = 0;
        // `b` is always on the crossed side (or at zero); Illinois halves the weight of an
        // end that is kept twice (Dowell & Jarratt, BIT 11, 1971).
        let mut side = 0i8;
        while (b - a).abs() > tol && fb != zero && evaluations < 100 {
            let mut c = b - fb * (b - a) / (fb - fa);
            let lo = a.min(b);
            let hi = a.max(b);
            if !(c > lo && c < hi) || evaluations % 8 == 7 {
                c = (a + b) * half;
            }
            self.dense(c, scratch)?;
            evaluations += 1;
            let fc = (events.events[i].function)(c, scratch);
            if (fc < zero) == (fb < zero) || fc == zero {
                // c is on the crossed side: it replaces b.
                b = c;
                fb = fc;
                if side == 1 {
                    fa = fa * half;
                }
                side = 1;
            } else {
                a = c;
                fa = fc;
                if side == -1 {
                    fb = fb * half;
                }
                side = -1;
            }
            if a > end && b > end {
                return Ok(None);
            }
        }
        if b > end {
            return Ok(None);
        }
        Ok(Some(EventHit {
            index: i,
            t: b,
            value: fb,
            terminal: events.events[i].terminal,
            evaluations,
        }))
    }
}
