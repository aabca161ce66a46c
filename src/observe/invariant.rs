//! The largest deviation of an invariant from its initial value.

use super::Observer;
use crate::real::Real;
use crate::vector::Vector;
use num_traits::Float as _;

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
