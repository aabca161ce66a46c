//! Force elements on joint coordinates: a hinge's angle ([`HingeAngle`]), a slider's
//! displacement ([`SliderDisplacement`]), a spring on the angle
//! ([`JointSpring`], a potential of the positions: part of the kick), and a damper on its rate
//! along the constraint-consistent direction ([`JointDamper`], an exact flow of the momenta);
//! [`Coordinate`] either coordinate.

use crate::real::Real;

mod coordinate;
mod damper;
mod distance;
mod hinge_angle;
mod slider_displacement;

pub use coordinate::Coordinate;
pub(crate) use damper::DamperScratch;
pub use damper::JointDamper;
pub use distance::Distance;
pub use hinge_angle::HingeAngle;
pub use slider_displacement::SliderDisplacement;

/// A joint's coordinate as a function of the slots' positions, with its gradient and Hessian
/// products in closed form: what a spring, a stop or a motor on a joint needs of it
/// ([`HingeAngle`], [`SliderDisplacement`]). Positions only: `q`, `v` and `out` are position
/// slices (three entries a slot).
pub trait JointCoordinate {
    /// The coordinate at `q`, zero at the initial poses.
    fn value<T: Real>(&self, q: &[T]) -> T;
    /// `out += scale ∇c(q)`.
    fn gradient_add<T: Real>(&self, q: &[T], scale: T, out: &mut [T]);
    /// `∇c(q) · v`.
    fn derivative<T: Real>(&self, q: &[T], v: &[T]) -> T;
    /// `out += scale ∇²c(q) v`.
    fn hessian_apply_add<T: Real>(&self, q: &[T], v: &[T], scale: T, out: &mut [T]);
    /// The slots the coordinate depends on.
    fn slots(&self) -> Vec<usize>;
}

macro_rules! joint_coordinate {
    ($($Type:ty),+) => {$(
        impl JointCoordinate for $Type {
            fn value<T: Real>(&self, q: &[T]) -> T {
                <$Type>::value(self, q)
            }
            fn gradient_add<T: Real>(&self, q: &[T], scale: T, out: &mut [T]) {
                <$Type>::gradient_add(self, q, scale, out)
            }
            fn derivative<T: Real>(&self, q: &[T], v: &[T]) -> T {
                <$Type>::derivative(self, q, v)
            }
            fn hessian_apply_add<T: Real>(&self, q: &[T], v: &[T], scale: T, out: &mut [T]) {
                <$Type>::hessian_apply_add(self, q, v, scale, out)
            }
            fn slots(&self) -> Vec<usize> {
                <$Type>::slots(self)
            }
        }
    )+};
}

joint_coordinate!(HingeAngle, SliderDisplacement, Distance);

/// A spring `½ k (θ − θ₀)²` on a hinge's angle.
#[derive(Debug, Clone, PartialEq)]
pub struct JointSpring {
    pub(crate) angle: HingeAngle,
    pub(crate) stiffness: f64,
    pub(crate) rest: f64,
}
