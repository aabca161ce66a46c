//! Ready-made models, one file each. Every model implements the traits generically for any
//! [`Vector`](crate::Vector) storage, so the same model runs on the stack or on the heap.

pub mod damped_pendulum;
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
