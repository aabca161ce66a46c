//! Force elements on joint coordinates: a hinge's angle ([`HingeAngle`]), a slider's
//! displacement ([`SliderDisplacement`]), a spring on the angle
//! ([`JointSpring`], a potential of the positions: part of the kick), and a damper on its rate
//! along the constraint-consistent direction ([`JointDamper`], an exact flow of the momenta).

mod damper;
mod hinge_angle;
mod slider_displacement;

pub(crate) use damper::DamperScratch;
pub use damper::JointDamper;
pub use hinge_angle::HingeAngle;
pub use slider_displacement::SliderDisplacement;

/// A spring `½ k (θ − θ₀)²` on a hinge's angle.
#[derive(Debug, Clone, PartialEq)]
pub struct JointSpring {
    pub(crate) angle: HingeAngle,
    pub(crate) stiffness: f64,
    pub(crate) rest: f64,
}
