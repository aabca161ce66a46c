//! What an output or an event reads of a rigid body: its orientation as a unit quaternion, and
//! its angular velocity in the world or in its own frame — from its directors (the slots after
//! its centre): `R = Q Pᵀ`, `ω = ½ Σ dᵢ × ḋᵢ`, `Ω = Rᵀ ω`; and what a joint exerts on its first
//! body: the force `−Σ λ_r ∂g_r/∂c` on its centre and the torque `Σᵢ dᵢ × (−Σ λ_r ∂g_r/∂dᵢ)`
//! about it (the moment of the directors' generalized forces).

use crate::rigid::{Rotation, body_frame, cross, director_spin};
use crate::scene::constraints::Constraint;
use crate::scene::model::SceneModel;

/// A rigid body's read: the body (its centre's slot), its principal axes `P`, what is read.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct RigidRead {
    pub(crate) centre: usize,
    pub(crate) axes: Rotation,
    /// Positions per slot (2: a planar body, its third director the normal `z`).
    pub(crate) dim: usize,
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
        let d = self.dim;
        let spin = || director_spin(q, p, self.centre, |s| 1.0 / inv_masses[s], d);
        let frame = || body_frame(q, self.centre, &self.axes, d);
        match self.what {
            RigidQuantity::Orientation(k) => frame().quaternion()[k],
            RigidQuantity::AngularVelocity(k) => spin()[k],
            RigidQuantity::BodyAngularVelocity(k) => {
                let r = frame();
                r.transpose().apply(spin())[k]
            }
        }
    }
}

/// A joint's reaction on its first body: the scene's constraint term, force or torque, and the
/// component.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct JointRead {
    pub(crate) term: usize,
    pub(crate) torque: bool,
    pub(crate) k: usize,
}

impl JointRead {
    /// The value at the state `x`, from the step's multipliers `(λ_k, λ_{k+1})` (their mean);
    /// `NaN` before the first step, with a scheme that reports none, or for a term that is not
    /// a joint between bodies.
    pub(crate) fn value(
        &self,
        model: &SceneModel,
        x: &[f64],
        multipliers: Option<(&[f64], &[f64])>,
    ) -> f64 {
        let Some((a, b)) = multipliers else {
            return f64::NAN;
        };
        let term = &model.constraints[self.term];
        let Constraint::Rows(rows) = &term.kind else {
            return f64::NAN;
        };
        let Some((centre, rigid)) = rows.first_body() else {
            return f64::NAN;
        };
        if self.torque && !rigid {
            return f64::NAN;
        }
        let q = &x[..x.len() / 2];
        let d = model.dim;
        let (mut force, mut torque) = ([0.0; 3], [0.0; 3]);
        term.kind.gradients(q, d, |r, slot, g| {
            let lambda = 0.5 * (a[term.row + r] + b[term.row + r]);
            let f = g.map(|v| -lambda * v);
            if slot == centre {
                for k in 0..3 {
                    force[k] += f[k];
                }
            } else if rigid && slot > centre && slot <= centre + d {
                let di: [f64; 3] =
                    core::array::from_fn(|k| if k < d { q[d * slot + k] } else { 0.0 });
                let m = cross(di, f);
                for k in 0..3 {
                    torque[k] += m[k];
                }
            }
        });
        if self.torque {
            torque[self.k]
        } else {
            force[self.k]
        }
    }
}
