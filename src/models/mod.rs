//! Ready-made models, one file each. Every model implements the traits generically for any
//! [`Vector`](crate::Vector) storage, so the same model runs on the stack or on the heap.

#[cfg(feature = "autodiff")]
pub mod andrews;
pub mod bricard;
pub mod damped_pendulum;
pub mod four_bar;
pub mod paper;
pub mod pendulum_chain;
pub mod rigid_body;
pub mod sphere_particles;
pub mod spherical_pendulum;
pub mod spring_chain;

pub use damped_pendulum::DampedPendulum;
pub use pendulum_chain::PendulumChain;
pub use rigid_body::RigidBody;
pub use sphere_particles::SphereParticles;
pub use spherical_pendulum::SphericalPendulum;
pub use spring_chain::SpringChain;

use crate::error::SetupError;
use crate::real::Real;

/// Checks model parameters: every entry of each `positive` list positive and finite (the error
/// names it, `"mass 3"`, or just `"rod length"` for a single value), and every `non_negative`
/// value finite and `≥ 0`.
pub(crate) fn check_parameters<T: Real>(
    positive: &[(&str, &[T])],
    non_negative: &[(&str, T)],
) -> Result<(), SetupError> {
    for (what, values) in positive {
        if let Some(i) = values
            .iter()
            .position(|v| !(*v > T::zero() && v.is_finite()))
        {
            let name = if values.len() > 1 {
                format!("{what} {i}")
            } else {
                what.to_string()
            };
            return Err(SetupError::InvalidParameter {
                name,
                value: values[i].to_f64_lossy(),
                requirement: "positive and finite",
            });
        }
    }
    for (what, v) in non_negative {
        if !(*v >= T::zero() && v.is_finite()) {
            return Err(SetupError::InvalidParameter {
                name: what.to_string(),
                value: v.to_f64_lossy(),
                requirement: "finite and non-negative",
            });
        }
    }
    Ok(())
}
