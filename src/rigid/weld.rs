//! Welding: rigid bodies and point masses fixed to one another are one rigid body. Merging
//! them before the run — rather than holding them together with six rows a weld — gives a
//! smaller state, no multipliers and no stiffness between parts that never move apart (MuJoCo's
//! and Drake's compilers do the same: a body's geoms, a `WeldJoint` folded into its parent).
//!
//! The merged body has the mass `M = Σ mᵢ`, its centre at `c = Σ mᵢ cᵢ / M`, and about `c`
//! the inertia tensor (Huygens–Steiner's parallel axes)
//!
//! ```text
//! J = Σᵢ ( Rᵢ Jᵢ Rᵢᵀ + mᵢ (|rᵢ|² I − rᵢ rᵢᵀ) ),   rᵢ = cᵢ − c,
//! ```
//!
//! `Rᵢ Jᵢ Rᵢᵀ` the part's own tensor turned into the world (zero for a point mass). Its frame is
//! the orientation of one chosen part; every part's place in that frame is kept
//! ([`Placement`]) so anchors and axes given in a part's frame can be carried to the merged
//! body's. The parts must already move as one body: the same angular velocity `ω`, and centre
//! velocities `vᵢ = v + ω × rᵢ` (Goldstein, *Classical Mechanics*, §5.3).

use super::pose::{Rotation, cross, dot};
use super::{Inertia, RigidBody};
use crate::error::SetupError;

/// A part of a welded body: a rigid body, or a point mass at a position with a velocity.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Part {
    /// A rigid body.
    Rigid(RigidBody),
    /// A point mass: `mass`, `position`, `velocity`.
    Point {
        /// The mass.
        mass: f64,
        /// Its position in the world.
        position: [f64; 3],
        /// Its velocity.
        velocity: [f64; 3],
    },
}

/// Where a part sits in the merged body: its centre (`offset`, from the merged centre of mass)
/// and its frame (`rotation`, the part's axes as columns), both in the merged body's frame. A
/// point `p` of the part's frame is `offset + rotation · p` in the merged body's frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Placement {
    /// The part's centre in the merged body's frame.
    pub offset: [f64; 3],
    /// The part's frame in the merged body's frame.
    pub rotation: Rotation,
}

impl Placement {
    /// The part's own frame: no offset, no turn.
    pub fn identity() -> Self {
        Self {
            offset: [0.0; 3],
            rotation: Rotation::identity(),
        }
    }

    /// A point of the part's frame in the merged body's frame.
    pub fn point(&self, p: [f64; 3]) -> [f64; 3] {
        let r = self.rotation.apply(p);
        core::array::from_fn(|k| self.offset[k] + r[k])
    }

    /// A direction of the part's frame in the merged body's frame.
    pub fn direction(&self, d: [f64; 3]) -> [f64; 3] {
        self.rotation.apply(d)
    }
}

/// Welded parts as one body: the body, and each part's [`Placement`] in it (in the parts'
/// order).
#[derive(Debug, Clone, PartialEq)]
pub struct Welded {
    /// The merged body, in the frame of the part [`weld`] was given.
    pub body: RigidBody,
    /// Where each part sits in it.
    pub placements: Vec<Placement>,
}

/// How far parts' velocities may differ from one body's motion, relative to its speeds.
const RIGID_MOTION_TOL: f64 = 1e-9;

/// Merges `parts` into one rigid body whose frame is the orientation of `parts[frame]` (a rigid
/// part); see the module documentation.
///
/// # Errors
/// [`SetupError::InvalidParameter`] when `parts[frame]` is not a rigid body, when a part's
/// mass is not positive and finite, when a part does not move with the others as one body (its
/// angular velocity or its centre's velocity differs from that motion by more than 1e-9 of its
/// speeds), and as [`Inertia::tensor`] when the merged tensor is no body's (point masses on one
/// line alone).
pub fn weld(parts: &[Part], frame: usize) -> Result<Welded, SetupError> {
    let Some(Part::Rigid(base)) = parts.get(frame) else {
        return Err(SetupError::InvalidParameter {
            name: format!("welded part {frame}"),
            value: f64::NAN,
            requirement: "a rigid body (its orientation is the merged body's frame)",
        });
    };
    let (mut mass, mut moment) = (0.0, [0.0; 3]);
    for (i, part) in parts.iter().enumerate() {
        let (m, c, _) = motion(part);
        if !(m > 0.0 && m.is_finite()) {
            return Err(SetupError::InvalidParameter {
                name: format!("mass of welded part {i}"),
                value: m,
                requirement: "positive and finite",
            });
        }
        mass += m;
        for k in 0..3 {
            moment[k] += m * c[k];
        }
    }
    let centre = moment.map(|x| x / mass);
    let omega = base.angular_velocity;
    let lever = |c: [f64; 3]| -> [f64; 3] { core::array::from_fn(|k| c[k] - centre[k]) };
    // v = v_f − ω × r_f: the merged centre's velocity from the frame part's.
    let turn = cross(omega, lever(base.position));
    let velocity: [f64; 3] = core::array::from_fn(|k| base.velocity[k] - turn[k]);
    let mut tensor = [[0.0; 3]; 3];
    for (i, part) in parts.iter().enumerate() {
        let (m, c, v) = motion(part);
        let r = lever(c);
        let expected = cross(omega, r);
        let scale = 1.0 + norm(velocity) + norm(omega) * norm(r);
        let mut off: f64 = (0..3)
            .map(|k| (v[k] - velocity[k] - expected[k]).abs())
            .fold(0.0, f64::max);
        if let Part::Rigid(b) = part {
            let spin = (0..3)
                .map(|k| (b.angular_velocity[k] - omega[k]).abs())
                .fold(0.0, f64::max);
            off = off.max(spin * (1.0 + norm(r)));
            let q = b.orientation.then(&Rotation(b.inertia.axes()));
            let j = b.inertia.moments();
            for (row, t) in tensor.iter_mut().enumerate() {
                for (col, t) in t.iter_mut().enumerate() {
                    *t += (0..3)
                        .map(|a| q.0[row][a] * j[a] * q.0[col][a])
                        .sum::<f64>();
                }
            }
        }
        if off > RIGID_MOTION_TOL * scale {
            return Err(SetupError::InvalidParameter {
                name: format!("velocity of welded part {i}"),
                value: off,
                requirement: "the motion of one body with the others (the same angular velocity, and centre velocity v + ω × r)",
            });
        }
        let rr = dot(r, r);
        for (row, t) in tensor.iter_mut().enumerate() {
            for (col, t) in t.iter_mut().enumerate() {
                let delta = if row == col { rr } else { 0.0 };
                *t += m * (delta - r[row] * r[col]);
            }
        }
    }
    // The tensor in the frame part's axes: Rᵀ J R.
    let frame_rotation = base.orientation;
    let rt = frame_rotation.transpose();
    let body_tensor: [[f64; 3]; 3] = core::array::from_fn(|a| {
        core::array::from_fn(|b| {
            (0..3)
                .map(|i| {
                    (0..3)
                        .map(|j| rt.0[a][i] * tensor[i][j] * rt.0[b][j])
                        .sum::<f64>()
                })
                .sum()
        })
    });
    let inertia = Inertia::tensor(body_tensor)?;
    let placements = parts
        .iter()
        .map(|part| {
            let (_, c, _) = motion(part);
            let rotation = match part {
                Part::Rigid(b) => rt.then(&b.orientation),
                // A point's frame is the world's axes at the point.
                Part::Point { .. } => rt,
            };
            Placement {
                offset: rt.apply(lever(c)),
                rotation,
            }
        })
        .collect();
    Ok(Welded {
        body: RigidBody {
            mass,
            inertia,
            position: centre,
            orientation: frame_rotation,
            velocity,
            angular_velocity: omega,
        },
        placements,
    })
}

/// A part's mass, centre and centre velocity.
fn motion(part: &Part) -> (f64, [f64; 3], [f64; 3]) {
    match *part {
        Part::Rigid(b) => (b.mass, b.position, b.velocity),
        Part::Point {
            mass,
            position,
            velocity,
        } => (mass, position, velocity),
    }
}

fn norm(v: [f64; 3]) -> f64 {
    dot(v, v).sqrt()
}

#[cfg(test)]
#[path = "weld_tests.rs"]
mod tests;
