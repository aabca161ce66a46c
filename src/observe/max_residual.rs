//! The largest constraint residual of a run.

use super::Observer;
use crate::system::HolonomicConstraint;
use crate::vector::{Vector, ops};
use num_traits::{Float as _, Zero};

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
