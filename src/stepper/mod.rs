//! The one stepping object: a flow, the state it advances and the time, stepped one step at a
//! time by an embedder or run for many steps with an [`Observer`].
//!
//! Every driver of the crate is built on it — [`integrate`](crate::integrate()), the runs of
//! compiled scenes ([`scene::Simulation`](crate::scene::Simulation)), and through them the
//! command, the examples, the hard-case suite and the work–precision sets — so the loop that
//! guards a step lives in one place:
//!
//! - the step's own contract: on `Err` the state is exactly the one the step started from;
//! - closed-form flows cannot report a blow-up, so a step that produces NaN or infinity is
//!   undone here and reported as [`StepError::NonFinite`];
//! - time is `t₀ + k h`, not a running sum, so long runs do not accumulate round-off in `t`.
//!
//! The state is held as anything that borrows a vector (`V` itself, or `&mut V` for a caller
//! that keeps its own), so running costs no copy of it. A step allocates nothing.
//!
//! For an embedder (a control loop, a co-simulation master) it also keeps the step's
//! [`Ledger`] — time, energy supplied through the ports, energy dissipated — and offers:
//! [`advance_to`](Stepper::advance_to) a time (a last, shorter step lands on it exactly),
//! [`save`](Stepper::save) and [`restore`](Stepper::restore) of a [`Checkpoint`] (the
//! continuation equals the saved run bit for bit), [`dense`](Stepper::dense) output between
//! step points, [`step_with_events`](Stepper::step_with_events) (events located on the dense
//! output) and [`state_mut`](Stepper::state_mut) for external changes of the state.

mod adaptive;
mod checkpoint;
mod dense;
mod event;

pub use checkpoint::{Checkpoint, CheckpointError};
pub use event::{Direction, Event, EventHit, Events, WatchedStep};

use crate::error::{IntegrateError, StepError};
use crate::flow::{Flow, FlowStats, Ledger};
use crate::observe::Observer;
use crate::real::Real;
use crate::vector::{Vector, ops};
use num_traits::Float as _;
use num_traits::Zero;
use std::borrow::BorrowMut;
use std::marker::PhantomData;

/// A flow, the state it advances (`S`: `V` or `&mut V`), the step size and the time.
#[derive(Debug)]
pub struct Stepper<V: Vector, F, S = V> {
    flow: F,
    x: S,
    /// The state before the current step: restored when a step yields a non-finite state,
    /// and the start of the dense output.
    last: V,
    /// The ledger before the current step.
    last_ledger: Ledger<V::Real>,
    /// Time is `t_base + (k − k_base) h`: `t₀ + k h` until a shorter step moves the base.
    t_base: V::Real,
    k_base: usize,
    h: V::Real,
    k: usize,
    /// Energy supplied and dissipated so far (the ledger's time is `time()`).
    ledger: Ledger<V::Real>,
    /// Scratch for the flow's memory around a dense evaluation (allocated on first use).
    memory: Vec<V::Real>,
    state: PhantomData<V>,
}

/// What a run of many steps did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IntegrateReport<T> {
    /// Steps taken.
    pub steps: usize,
    /// Final time.
    pub t: T,
    /// The flow's work counters at the end of the run (cumulative over the flow's life).
    pub stats: FlowStats,
}

impl<V, F, S> Stepper<V, F, S>
where
    V: Vector,
    F: Flow<V>,
    S: BorrowMut<V>,
{
    /// A stepper at `(t0, x0)` with steps of size `h`. Prepares the flow's workspace for states
    /// like `x0`.
    ///
    /// # Errors
    /// [`IntegrateError::NonFiniteInitialState`] if `x0` holds NaN or infinity.
    pub fn new(mut flow: F, x0: S, t0: V::Real, h: V::Real) -> Result<Self, IntegrateError> {
        let x: &V = x0.borrow();
        if let Some(component) = ops::first_non_finite(x.as_slice()) {
            return Err(IntegrateError::NonFiniteInitialState { component });
        }
        flow.prepare(x);
        let last = x.clone();
        // The memory's buffer sized once, so that dense output and events allocate nothing.
        let mut memory = Vec::new();
        flow.save_memory(&mut memory);
        memory.clear();
        Ok(Self {
            flow,
            x: x0,
            last,
            last_ledger: Ledger::at(t0),
            t_base: t0,
            k_base: 0,
            h,
            k: 0,
            ledger: Ledger::at(t0),
            memory,
            state: PhantomData,
        })
    }

    /// One step of size `h`: `x ← Φ_h(x)`, `t ← t + h`.
    ///
    /// # Errors
    /// The flow's [`StepError`], or [`StepError::NonFinite`] when the step produced NaN or
    /// infinity; either way the state, time and ledger are those before the step.
    pub fn step(&mut self) -> Result<(), StepError> {
        self.step_by(self.h)?;
        self.k += 1;
        Ok(())
    }

    /// One step of size `h` that is not on the grid `t_base + k h` (a last, shorter step to a
    /// communication point): the grid restarts from its end.
    ///
    /// # Errors
    /// As [`step`](Self::step).
    pub fn step_off_grid(&mut self, h: V::Real) -> Result<(), StepError> {
        let t = self.time() + h;
        self.step_by(h)?;
        self.k += 1;
        self.t_base = t;
        self.k_base = self.k;
        Ok(())
    }

    /// The guarded step of size `h`, without the step count.
    #[inline]
    fn step_by(&mut self, h: V::Real) -> Result<(), StepError> {
        let t = self.time();
        let x = self.x.borrow_mut();
        self.last.copy_from(x);
        self.last_ledger = self.ledger;
        self.last_ledger.t = t;
        let mut ledger = self.last_ledger;
        if let Err(e) = self.flow.step_at(&mut ledger, h, x) {
            // A flow restores its own state, except where a sub-flow that does not fail a
            // step of its own fails (an input signal that is not finite, in a composition
            // that saves no copy): the copy above is the state before the step either way.
            x.copy_from(&self.last);
            return Err(e);
        }
        if let Some(component) = ops::first_non_finite(x.as_slice()) {
            x.copy_from(&self.last);
            return Err(StepError::NonFinite { component });
        }
        self.ledger = ledger;
        Ok(())
    }

    /// Steps until the time is `t_end`: steps of `h` while they fit, then one shorter step
    /// that ends on `t_end` exactly (none when the grid already lands there to within
    /// rounding). Calls `observer` after each step. Returns the number of steps taken.
    ///
    /// # Errors
    /// As [`advance`](Self::advance); a `t_end` behind the current time (for `h > 0`) takes no
    /// step.
    pub fn advance_to<O: Observer<V>>(
        &mut self,
        t_end: V::Real,
        observer: &mut O,
    ) -> Result<usize, IntegrateError> {
        let start = self.k;
        while let Some(short) = self.next_step_to(t_end, start) {
            let r = match short {
                None => self.step(),
                Some(h) => self.step_off_grid(h),
            };
            r.map_err(|source| IntegrateError::Step {
                step: self.k,
                t: self.time().to_f64_lossy(),
                source,
            })?;
            observer.observe(self.k, self.time(), self.x.borrow());
        }
        Ok(self.k - start)
    }

    /// Takes `steps` steps, calling `observer` after each one (with the step count since the
    /// stepper was built, the time and the state).
    ///
    /// # Errors
    /// [`IntegrateError::Step`] naming the failing step (counted from the stepper's start) and
    /// the time it started at; the state is the one at that time.
    pub fn advance<O: Observer<V>>(
        &mut self,
        steps: usize,
        observer: &mut O,
    ) -> Result<IntegrateReport<V::Real>, IntegrateError> {
        for _ in 0..steps {
            self.step().map_err(|source| IntegrateError::Step {
                step: self.k,
                t: self.time().to_f64_lossy(),
                source,
            })?;
            observer.observe(self.k, self.time(), self.x.borrow());
        }
        Ok(IntegrateReport {
            steps: self.k,
            t: self.time(),
            stats: self.flow.stats(),
        })
    }

    /// The state.
    pub fn state(&self) -> &V {
        self.x.borrow()
    }
    /// The time of the state: `t₀ + k h` on the grid (from the end of the last shorter step,
    /// if one was taken).
    pub fn time(&self) -> V::Real {
        self.t_base + V::Real::lit((self.k - self.k_base) as f64) * self.h
    }
    /// The time and the energies supplied through the ports and dissipated since the start
    /// (as accounted by the sub-flows that report them; see [`Ledger`]).
    pub fn ledger(&self) -> Ledger<V::Real> {
        Ledger {
            t: self.time(),
            ..self.ledger
        }
    }
    /// The state, for an external change between steps (an impulse, a reset). The next step
    /// of a projected flow checks that it is on the constraint manifold; a change that leaves
    /// it must be followed by a re-projection (see
    /// [`system::reproject`](crate::system::reproject)).
    pub fn state_mut(&mut self) -> &mut V {
        self.x.borrow_mut()
    }
    /// The next step on the way to `t_end` (for a run to it that started at step `start`):
    /// `Some(None)` a step of `h`, `Some(Some(r))` the last, shorter step `r`, `None` arrived —
    /// and when the grid reached `t_end` up to the rounding of the time itself, the time is
    /// reported as `t_end` exactly from then on.
    pub(crate) fn next_step_to(&mut self, t_end: V::Real, start: usize) -> Option<Option<V::Real>> {
        if !t_end.is_finite() {
            // No step reaches it (a NaN target compares false with everything: stepping on
            // would never end).
            return None;
        }
        let h = self.h;
        let slack = V::Real::lit(8.0) * V::Real::epsilon() * (t_end.abs() + h.abs());
        let remaining = t_end - self.time();
        if remaining * h.signum() <= slack {
            if remaining.abs() <= slack && remaining != V::Real::zero() && self.k > start {
                self.t_base = t_end;
                self.k_base = self.k;
            }
            return None;
        }
        Some((remaining.abs() < h.abs() - slack).then_some(remaining))
    }
    /// Changes the step size for the following steps (the grid restarts at the current time).
    pub fn set_step_size(&mut self, h: V::Real) {
        self.t_base = self.time();
        self.k_base = self.k;
        self.h = h;
    }
    /// The step size `h`.
    pub fn step_size(&self) -> V::Real {
        self.h
    }
    /// Steps taken since the stepper was built.
    pub fn steps_taken(&self) -> usize {
        self.k
    }
    /// The flow.
    pub fn flow(&self) -> &F {
        &self.flow
    }
    /// The flow, mutably (its options, its statistics).
    pub fn flow_mut(&mut self) -> &mut F {
        &mut self.flow
    }
    /// The flow and the state.
    pub fn into_parts(self) -> (F, S) {
        (self.flow, self.x)
    }
}
