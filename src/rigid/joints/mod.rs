//! Joints as constraint rows of degree ≤ 2 in the bodies' coordinates
//! (`../shared/docs/METHOD.md` §8): a body point `r(X) = c + Σ Xᵢ dᵢ` and a body axis
//! `a = Σ aᵢ dᵢ` are linear in the state ([`Affine`]), so a coincidence of points is three
//! linear rows and a perpendicularity of axes one bilinear row. One file per kind; each
//! implements [`JointKind`].
//!
//! In a planar model (`dim = 2`, [`Frames::dim`]) the same rows are built with the normal `e_z`
//! a constant director: a coincidence of points is then two rows, and a row the plane makes
//! identically zero (the hinge's axes, both along `e_z`; the slider's out-of-plane rows) is
//! dropped by [`joint_rows`], which the models call. So a planar hinge is two rows (the pin), a
//! planar slider two (no turning, no motion across its axis).

mod ball;
mod hinge;
mod slider;
mod universal;

pub use ball::Ball;
pub use hinge::Hinge;
pub use slider::Slider;
pub use universal::Universal;

pub use super::frames::{Affine, BodyRef, Frames};
use super::rows::RowBuilder;
use crate::error::SetupError;

/// A kind of joint: the rows it adds between its bodies.
pub trait JointKind {
    /// The kind's name, for messages (`"hinge"`).
    fn name(&self) -> &'static str;
    /// The rows (each `= 0` on the joint's motion), built from the bodies' frames at the model's
    /// initial poses.
    ///
    /// # Errors
    /// [`SetupError`] for a body that is not in the model, a zero axis, or a point body where
    /// the joint needs orientation.
    fn rows(&self, frames: &Frames<'_>) -> Result<Vec<RowBuilder<f64>>, SetupError>;
}

/// `joint`'s rows in `frames`, without the rows a planar model makes identically zero (no
/// column and no constant: the plane holds them).
///
/// # Errors
/// The joint's own ([`JointKind::rows`]).
pub fn joint_rows(
    joint: &dyn JointKind,
    frames: &Frames<'_>,
) -> Result<Vec<RowBuilder<f64>>, SetupError> {
    let mut rows = joint.rows(frames)?;
    rows.retain(|r| !r.is_zero());
    Ok(rows)
}

/// The rows `(a − b)_k = 0`, one per position of a slot (three, or two in a planar model; the
/// planar points' heights are constants and equal).
pub(crate) fn coincide(a: &Affine, b: &Affine) -> Vec<RowBuilder<f64>> {
    let dim = a.dim.min(b.dim);
    (0..dim)
        .map(|k| {
            let mut row = RowBuilder::new();
            for &(s, c) in &a.terms {
                row.linear(dim * s + k, c);
            }
            for &(s, c) in &b.terms {
                row.linear(dim * s + k, -c);
            }
            row.constant(a.constant[k] - b.constant[k]);
            row
        })
        .collect()
}

/// The row `a · b − value = 0`.
pub(crate) fn dot_row(a: &Affine, b: &Affine, value: f64) -> RowBuilder<f64> {
    let dim = a.dim.min(b.dim);
    let mut row = RowBuilder::new();
    for k in 0..dim {
        for &(s, x) in &a.terms {
            for &(t, y) in &b.terms {
                row.product(dim * s + k, dim * t + k, x * y);
            }
            if b.constant[k] != 0.0 {
                row.linear(dim * s + k, x * b.constant[k]);
            }
        }
        if a.constant[k] != 0.0 {
            for &(t, y) in &b.terms {
                row.linear(dim * t + k, y * a.constant[k]);
            }
        }
    }
    let c: f64 = (0..3).map(|k| a.constant[k] * b.constant[k]).sum();
    row.constant(c - value);
    row
}

/// In a planar model, refuses an axis that is not `along` the normal (`true`: a hinge's) or
/// not in the plane (`false`: a slider's), naming the joint; in 3D every axis is accepted.
pub(crate) fn planar_axis(
    frames: &Frames<'_>,
    joint: &str,
    axis: [f64; 3],
    along: bool,
) -> Result<(), SetupError> {
    if frames.dim() != 2 {
        return Ok(());
    }
    let a = unit_axis(joint, axis)?;
    let off = if along { a[0].hypot(a[1]) } else { a[2].abs() };
    if off == 0.0 {
        return Ok(());
    }
    Err(SetupError::InvalidParameter {
        name: format!("{joint} axis in a planar model"),
        value: off,
        requirement: if along {
            "along the plane's normal z (a planar hinge turns in the plane)"
        } else {
            "in the plane (z = 0)"
        },
    })
}

/// Two unit vectors perpendicular to the unit vector `a` (and to each other).
pub(crate) fn perpendiculars(a: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    // Start from the world axis least aligned with `a`.
    let k = (0..3)
        .min_by(|&i, &j| a[i].abs().total_cmp(&a[j].abs()))
        .unwrap_or(0);
    let mut e = [0.0; 3];
    e[k] = 1.0;
    let u = normalized(super::pose::cross(a, e)).unwrap_or([1.0, 0.0, 0.0]);
    let v = super::pose::cross(a, u);
    (u, v)
}

/// `v/|v|`; `None` for a zero or non-finite vector.
pub(crate) fn normalized(v: [f64; 3]) -> Option<[f64; 3]> {
    let n = super::pose::dot(v, v).sqrt();
    (n > 0.0 && n.is_finite()).then(|| v.map(|x| x / n))
}

/// `v` normalized, or the error naming the joint's axis.
pub(crate) fn unit_axis(joint: &str, v: [f64; 3]) -> Result<[f64; 3], SetupError> {
    normalized(v).ok_or_else(|| SetupError::InvalidParameter {
        name: format!("{joint} axis"),
        value: super::pose::dot(v, v).sqrt(),
        requirement: "non-zero and finite",
    })
}
