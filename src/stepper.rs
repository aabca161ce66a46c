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

use crate::error::{IntegrateError, StepError};
use crate::flow::{Flow, FlowStats};
use crate::observe::Observer;
use crate::real::Real;
use crate::vector::{Vector, ops};
use std::borrow::BorrowMut;
use std::marker::PhantomData;

/// A flow, the state it advances (`S`: `V` or `&mut V`), the step size and the time.
#[derive(Debug)]
pub struct Stepper<V: Vector, F, S = V> {
    flow: F,
    x: S,
    /// The state before the current step: restored when a step yields a non-finite state.
    last: V,
    t0: V::Real,
    h: V::Real,
    k: usize,
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
        Ok(Self {
            flow,
            x: x0,
            last,
            t0,
            h,
            k: 0,
            state: PhantomData,
        })
    }

    /// One step of size `h`: `x ← Φ_h(x)`, `t ← t₀ + (k + 1) h`.
    ///
    /// # Errors
    /// The flow's [`StepError`], or [`StepError::NonFinite`] when the step produced NaN or
    /// infinity; either way the state and time are those before the step.
    pub fn step(&mut self) -> Result<(), StepError> {
        let x = self.x.borrow_mut();
        self.last.copy_from(x);
        self.flow.step(self.h, x)?;
        if let Some(component) = ops::first_non_finite(x.as_slice()) {
            x.copy_from(&self.last);
            return Err(StepError::NonFinite { component });
        }
        self.k += 1;
        Ok(())
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
    /// The time of the state, `t₀ + k h`.
    pub fn time(&self) -> V::Real {
        self.t0 + V::Real::lit(self.k as f64) * self.h
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
