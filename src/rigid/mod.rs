//! Rigid bodies and joints: a body as its centre of mass and the three columns of its rotation
//! matrix (directors), with a constant diagonal mass matrix `diag(m, E₁, E₂, E₃)` and
//! `QᵀQ = I` as six quadratic rows; joints as rows of degree ≤ 2 (`../shared/docs/METHOD.md`
//! §8, docs/method.md §14). The existing projection is then RATTLE on the rotations, exact to
//! round-off on every row, with no new flow: [`Multibody`] is a [`System`](crate::System) of
//! mechanical form with an exact drift and a gravity kick.
//!
//! Files: `rows.rs` the rows of degree ≤ 2 ([`QuadraticRows`]), `inertia.rs` principal moments,
//! axes and shapes ([`Inertia`]), `pose.rs` orientations ([`Rotation`]), `body.rs` a rigid
//! body's description ([`RigidBody`]), `joints/` one file per joint kind ([`JointKind`]),
//! `model.rs` the assembled model ([`Multibody`]), `weld.rs` parts fixed to one another merged
//! into one body ([`weld`]).

mod body;
mod drift;
pub mod elements;
mod energy;
mod frames;
mod inertia;
pub mod joints;
mod kick;
mod model;
mod pose;
mod rows;
mod weld;

pub use body::RigidBody;
#[cfg(feature = "scene")]
pub(crate) use body::orthonormality;
pub use drift::MultibodyDrift;
pub use elements::{
    Coordinate, Distance, HingeAngle, JointCoordinate, JointDamper, JointSpring, SliderDisplacement,
};
#[cfg(feature = "scene")]
pub(crate) use frames::Entry;
pub use frames::{Affine, Frames};
pub use inertia::Inertia;
pub use joints::{Ball, BodyRef, Hinge, JointKind, Slider, Universal};
pub use kick::MultibodyKick;
pub use model::{Multibody, MultibodyEnergy};
pub use pose::{Rotation, cross, dot};
#[cfg(feature = "scene")]
pub(crate) use pose::{body_frame, director_spin, planar_rotation};
pub use rows::{QuadraticRows, RowBuilder};
pub use weld::{Part, Placement, Welded, weld};
