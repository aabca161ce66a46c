//! What an output or an event reads of a rigid body: its orientation as a unit quaternion, and
//! its angular velocity in the world or in its own frame — from its directors (the slots after
//! its centre): `R = Q Pᵀ`, `ω = ½ Σ dᵢ × ḋᵢ`, `Ω = Rᵀ ω`.

use crate::rigid::{Rotation, body_frame, director_spin};

/// A rigid body's read: the body (its centre's slot), its principal axes `P`, what is read.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct RigidRead {
    pub(crate) centre: usize,
    pub(crate) axes: Rotation,
    pub(crate) what: RigidQuantity,
}

/// Which of a rigid body's quantities, and its component.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum RigidQuantity {
    /// Quaternion component `[w, x, y, z][k]` (`w ≥ 0`).
    Orientation(usize),
    /// `ω_k` in the world.
    AngularVelocity(usize),
    /// `Ω_k` in the body's frame.
    BodyAngularVelocity(usize),
}

impl RigidRead {
    /// The value at the state `x = (q, p)` of a scene with the masses `masses` (one per slot).
    pub(crate) fn value(&self, x: &[f64], inv_masses: &[f64]) -> f64 {
        let (q, p) = x.split_at(x.len() / 2);
        let spin = || director_spin(q, p, self.centre, |s| 1.0 / inv_masses[s]);
        match self.what {
            RigidQuantity::Orientation(k) => body_frame(q, self.centre, &self.axes).quaternion()[k],
            RigidQuantity::AngularVelocity(k) => spin()[k],
            RigidQuantity::BodyAngularVelocity(k) => {
                let r = body_frame(q, self.centre, &self.axes);
                r.transpose().apply(spin())[k]
            }
        }
    }
}
