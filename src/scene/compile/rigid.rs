//! A rigid body of a scene as four slots of the state (`../shared/docs/METHOD.md` §8,
//! docs/method.md §12c): its centre of mass with the mass `m`, and its three directors — the
//! columns of `Q = R P`, `R` its orientation and `P` its principal axes — each a slot with the
//! mass `Eᵢ = (J_j + J_k − J_i)/2`, so the kinetic energy is `Σ |p_s|²/2m_s` over slots as for
//! points; the six rows of `QᵀQ = I` are the body's own constraint term. Effects select the
//! centre (gravity acts there); the directors are not named. In a planar scene (`dim = 2`) a
//! body is three slots — its centre and the two directors in the plane, the third being the
//! normal `z` it turns about — and three rows.

use super::Result;
use super::validate::{err, finite, vector, vector_or};
use crate::rigid::{RigidBody, cross};
use crate::scene::bodies::{Bodies, Body, RigidEntry};
use crate::scene::constraints::{Constraint, Declared, Rows};
use crate::scene::error::{FieldPath, SceneErrorKind};
use crate::scene::schema::BodySpec;

/// The rigid body `b` declares (at `path`): its mass and inertia, pose and velocities.
pub(super) fn rigid_body(
    b: &BodySpec,
    inertia: &crate::scene::schema::InertiaSpec,
    dim: usize,
    path: &FieldPath,
) -> Result<RigidBody> {
    if finite(b.charge, &path.key("charge"))? != 0.0 {
        return Err(err(
            SceneErrorKind::Unsupported,
            path.key("charge"),
            "a charge is for point bodies; a rigid body carries none",
        ));
    }
    let (mass, inertia) = inertia.resolve(b.mass, path, dim)?;
    let orientation = match &b.orientation {
        Some(o) => o.resolve(&path.key("orientation"), dim)?,
        None => crate::rigid::Rotation::identity(),
    };
    // In the plane the angular velocity is the one rate about the normal: `[ω]`.
    let wp = path.key("angular_velocity");
    let angular_velocity = match (dim, &b.angular_velocity) {
        (2, Some(w)) => match w.as_slice() {
            &[w] => [0.0, 0.0, finite(w, &wp.index(0))?],
            _ => {
                return Err(err(
                    SceneErrorKind::Dimension,
                    wp,
                    format!(
                        "a planar body turns about the plane's normal: one rate `[ω]`, not {} entries",
                        w.len()
                    ),
                ));
            }
        },
        _ => vector_or(&b.angular_velocity, 3, &wp, [0.0; 3])?,
    };
    Ok(RigidBody {
        mass,
        inertia,
        position: vector(&b.position, dim, &path.key("position"))?,
        orientation,
        velocity: vector_or(&b.velocity, dim, &path.key("velocity"), [0.0; 3])?,
        angular_velocity,
    })
}

/// Appends the rigid body `body` named `name` (declared at `bodies[i]`, `path`): its four slots
/// and its orthonormality rows; returns its centre.
pub(super) fn push_rigid(
    bodies: &mut Bodies,
    name: &str,
    body: &RigidBody,
    i: usize,
    path: &FieldPath,
    generated: &mut Vec<Declared>,
) -> Result<usize> {
    let RigidBody {
        mass,
        inertia,
        position: q,
        orientation,
        velocity: v,
        angular_velocity: omega,
    } = *body;
    let dim = bodies.dim;
    bodies.reserve(1 + dim, path)?;
    // A planar body's (a merged one's too) third principal axis is its normal.
    let inertia = if dim == 2 {
        inertia
            .about_normal()
            .map_err(|e| err(SceneErrorKind::Value, path.key("inertia"), e.to_string()))?
    } else {
        inertia
    };
    let axes = crate::rigid::Rotation(inertia.axes());
    let directors = orientation.then(&axes);
    let centre = bodies.push(Body {
        name: name.to_owned(),
        mass,
        q,
        v,
        charge: 0.0,
        director: false,
    });
    for (k, &e) in inertia.director_masses().iter().enumerate().take(dim) {
        let d = directors.column(k);
        bodies.push(Body {
            name: format!("{name}#d{}", k + 1),
            mass: e,
            q: d,
            v: cross(omega, d),
            charge: 0.0,
            director: true,
        });
    }
    bodies.add_group(name, vec![centre], &path.key("name"))?;
    bodies.rigid.push(RigidEntry {
        centre,
        orientation,
        axes,
        shape: None,
    });
    generated.push((
        Constraint::Rows(Rows::new(
            "directors",
            (centre, None),
            crate::rigid::orthonormality(centre, dim),
            dim * (centre + 1 + dim),
            dim,
        )),
        format!("bodies[{i}] '{name}' directors"),
        path.clone(),
    ));
    Ok(centre)
}
