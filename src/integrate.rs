//! Fixed-step integration with observers that record only what is asked for.

use crate::error::IntegrateError;
use crate::flow::{Flow, FlowStats};
use crate::real::Real;
use crate::system::HolonomicConstraint;
use crate::vector::{Vector, ops};
use num_traits::{Float as _, Zero};

/// Sees the state after every step (and the initial state, as step 0).
pub trait Observer<V: Vector> {
    /// Called with the step count `k` (0 for the initial state), the time and the state.
    fn observe(&mut self, k: usize, t: V::Real, x: &V);
}

impl<V: Vector> Observer<V> for () {
    #[inline(always)]
    fn observe(&mut self, _k: usize, _t: V::Real, _x: &V) {}
}

impl<V: Vector, F: FnMut(usize, V::Real, &V)> Observer<V> for F {
    #[inline(always)]
    fn observe(&mut self, k: usize, t: V::Real, x: &V) {
        self(k, t, x)
    }
}

macro_rules! tuple_observer {
    ($($name:ident $idx:tt),+) => {
        impl<V: Vector, $($name: Observer<V>),+> Observer<V> for ($($name,)+) {
            #[inline(always)]
            fn observe(&mut self, k: usize, t: V::Real, x: &V) {
                $(self.$idx.observe(k, t, x);)+
            }
        }
    };
}
tuple_observer!(A 0, B 1);
tuple_observer!(A 0, B 1, C 2);
tuple_observer!(A 0, B 1, C 2, D 3);

/// Tracks `max_k ‖g(x_k)‖∞` for a constraint (allocation-free after construction).
#[derive(Debug, Clone)]
pub struct MaxResidual<'a, C, V: Vector> {
    constraint: &'a C,
    buf: V,
    /// The largest residual seen.
    pub max: V::Real,
}

impl<'a, C: HolonomicConstraint<V>, V: Vector> MaxResidual<'a, C, V> {
    /// Observes `g = constraint`.
    pub fn new(constraint: &'a C) -> Self {
        Self {
            constraint,
            buf: V::zeros(constraint.dim()),
            max: V::Real::zero(),
        }
    }
}

impl<C: HolonomicConstraint<V>, V: Vector> Observer<V> for MaxResidual<'_, C, V> {
    fn observe(&mut self, _k: usize, _t: V::Real, x: &V) {
        let m = self.constraint.dim();
        let r = &mut self.buf.as_mut_slice()[..m];
        self.constraint.residual(x, r);
        self.max = self.max.max(ops::norm_inf(r));
    }
}

/// Tracks `max_k |I(x_k) − I(x_0)|` for an invariant (or any scalar quantity) `I`.
#[derive(Debug, Clone)]
pub struct InvariantError<F, T> {
    f: F,
    initial: Option<T>,
    /// The largest deviation seen.
    pub max: T,
}

impl<F, T: Real> InvariantError<F, T> {
    /// Observes the quantity `f(x)`.
    pub fn new(f: F) -> Self {
        Self {
            f,
            initial: None,
            max: T::zero(),
        }
    }
}

impl<V: Vector, F: FnMut(&V) -> V::Real> Observer<V> for InvariantError<F, V::Real> {
    fn observe(&mut self, _k: usize, _t: V::Real, x: &V) {
        let v = (self.f)(x);
        let i0 = *self.initial.get_or_insert(v);
        self.max = self.max.max((v - i0).abs());
    }
}

/// Records every `every`-th state with its time (allocates as it grows: only when asked for).
#[derive(Debug, Clone)]
pub struct Trajectory<V: Vector> {
    every: usize,
    /// Recorded times.
    pub t: Vec<V::Real>,
    /// Recorded states.
    pub x: Vec<V>,
}

impl<V: Vector> Trajectory<V> {
    /// Records every `every`-th state (`every ≥ 1`).
    pub fn every(every: usize) -> Self {
        Self {
            every: every.max(1),
            t: Vec::new(),
            x: Vec::new(),
        }
    }
}

impl<V: Vector> Observer<V> for Trajectory<V> {
    fn observe(&mut self, k: usize, t: V::Real, x: &V) {
        if k.is_multiple_of(self.every) {
            self.t.push(t);
            self.x.push(x.clone());
        }
    }
}

/// What a run did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IntegrateReport<T> {
    /// Steps taken.
    pub steps: usize,
    /// Final time.
    pub t: T,
    /// The flow's work counters at the end of the run (cumulative over the flow's life).
    pub stats: FlowStats,
}

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
    if let Some(component) = ops::first_non_finite(x.as_slice()) {
        return Err(IntegrateError::NonFiniteInitialState { component });
    }
    flow.prepare(x);
    observer.observe(0, t0, x);
    // Closed-form flows cannot report a blow-up themselves: keep the last good state.
    let mut last = x.clone();
    let mut t = t0;
    for k in 0..steps {
        last.copy_from(x);
        flow.step(h, x).map_err(|source| IntegrateError::Step {
            step: k,
            t: t.to_f64_lossy(),
            source,
        })?;
        if let Some(component) = ops::first_non_finite(x.as_slice()) {
            x.copy_from(&last);
            return Err(IntegrateError::Step {
                step: k,
                t: t.to_f64_lossy(),
                source: crate::error::StepError::NonFinite { component },
            });
        }
        // t_k = t0 + k h, not a running sum, so long runs do not accumulate round-off in t.
        t = t0 + V::Real::lit((k + 1) as f64) * h;
        observer.observe(k + 1, t, x);
    }
    Ok(IntegrateReport {
        steps,
        t,
        stats: flow.stats(),
    })
}
