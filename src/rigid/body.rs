//! A rigid body's description: mass, inertia, pose and velocities.

use super::{Inertia, Rotation};

/// A rigid body: its `mass`, its `inertia` about the centre of mass (principal moments and
/// axes in the body's frame), the world position of its centre of mass, its `orientation`
/// (the body's frame in the world), the velocity of its centre and its angular velocity (in
/// the world's frame).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RigidBody {
    /// The mass.
    pub mass: f64,
    /// The inertia about the centre of mass, in the body's frame.
    pub inertia: Inertia,
    /// The centre of mass, in the world.
    pub position: [f64; 3],
    /// The body's frame in the world.
    pub orientation: Rotation,
    /// The centre's velocity.
    pub velocity: [f64; 3],
    /// The angular velocity, in the world's frame.
    pub angular_velocity: [f64; 3],
}

impl RigidBody {
    /// A body of `mass` and `inertia` at rest at `position`, its frame along the world's.
    pub fn at_rest(mass: f64, inertia: Inertia, position: [f64; 3]) -> Self {
        Self {
            mass,
            inertia,
            position,
            orientation: Rotation::identity(),
            velocity: [0.0; 3],
            angular_velocity: [0.0; 3],
        }
    }
}

/// `QᵀQ = I` for a body whose directors are the slots `slot + 1 …` (`dim` positions each, `dim`
/// directors): `(|dᵢ|² − 1)/2` and `dᵢ·dⱼ`, six rows in 3D, three in the plane.
pub(crate) fn orthonormality(slot: usize, dim: usize) -> Vec<super::RowBuilder<f64>> {
    let col = |i: usize, k: usize| dim * (slot + 1 + i) + k;
    let mut rows = Vec::with_capacity(dim * (dim + 1) / 2);
    for i in 0..dim {
        let mut row = super::RowBuilder::new();
        for k in 0..dim {
            row.product(col(i, k), col(i, k), 0.5);
        }
        row.constant(-0.5);
        rows.push(row);
    }
    for (i, j) in [(0, 1), (0, 2), (1, 2)] {
        if j >= dim {
            continue;
        }
        let mut row = super::RowBuilder::new();
        for k in 0..dim {
            row.product(col(i, k), col(j, k), 1.0);
        }
        rows.push(row);
    }
    rows
}
