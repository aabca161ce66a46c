//! [`Coordinate`]: a joint's coordinate of any kind — a hinge's angle, a slider's
//! displacement, the distance between two bodies' points — for what treats them alike (dampers on the rate, outputs of the position and
//! rate).

use super::{Distance, HingeAngle, JointCoordinate, SliderDisplacement};
use crate::real::Real;

/// A hinge's angle (rad) or a slider's displacement (m).
#[derive(Debug, Clone, PartialEq)]
pub enum Coordinate {
    /// A hinge's angle, in `(−π, π]`.
    Angle(HingeAngle),
    /// A slider's displacement.
    Displacement(SliderDisplacement),
    /// The distance between two bodies' points (a line element's length).
    Distance(Distance),
}

impl Coordinate {
    /// The rate `∇c(q) · W⁻¹p` (`inv` the inverse mass of each slot).
    pub fn rate<T: Real>(&self, q: &[T], p: &[T], inv: &[T]) -> T {
        match self {
            Self::Angle(a) => a.rate(q, p, inv),
            Self::Displacement(d) => d.rate(q, p, inv),
            Self::Distance(d) => d.rate(q, p, inv),
        }
    }
}

impl JointCoordinate for Coordinate {
    fn value<T: Real>(&self, q: &[T]) -> T {
        match self {
            Self::Angle(a) => a.value(q),
            Self::Displacement(d) => d.value(q),
            Self::Distance(d) => d.value(q),
        }
    }
    fn gradient_add<T: Real>(&self, q: &[T], scale: T, out: &mut [T]) {
        match self {
            Self::Angle(a) => a.gradient_add(q, scale, out),
            Self::Displacement(d) => d.gradient_add(q, scale, out),
            Self::Distance(d) => d.gradient_add(q, scale, out),
        }
    }
    fn derivative<T: Real>(&self, q: &[T], v: &[T]) -> T {
        match self {
            Self::Angle(a) => a.derivative(q, v),
            Self::Displacement(d) => d.derivative(q, v),
            Self::Distance(d) => d.derivative(q, v),
        }
    }
    fn hessian_apply_add<T: Real>(&self, q: &[T], v: &[T], scale: T, out: &mut [T]) {
        match self {
            Self::Angle(a) => a.hessian_apply_add(q, v, scale, out),
            Self::Displacement(d) => d.hessian_apply_add(q, v, scale, out),
            Self::Distance(d) => d.hessian_apply_add(q, v, scale, out),
        }
    }
    fn slots(&self) -> Vec<usize> {
        match self {
            Self::Angle(a) => a.slots(),
            Self::Displacement(d) => d.slots(),
            Self::Distance(d) => d.slots(),
        }
    }
}
