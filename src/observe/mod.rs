//! Observers: what a run records after every step, and only that. `()` records nothing, a
//! closure anything; [`MaxResidual`], [`InvariantError`] and [`Trajectory`] are the common
//! ones, each in its own file; tuples run several (argmin's `Observe`, composed).

mod invariant;
mod max_residual;
mod trajectory;

pub use invariant::InvariantError;
pub use max_residual::MaxResidual;
pub use trajectory::Trajectory;

use crate::vector::Vector;

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
