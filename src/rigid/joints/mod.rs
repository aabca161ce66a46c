//! Joints as constraint rows of degree ≤ 2 in the bodies' coordinates
//! (`../shared/docs/METHOD.md` §8): a body point `r(X) = c + Σ Xᵢ dᵢ` and a body axis
//! `a = Σ aᵢ dᵢ` are linear in the state ([`Affine`]), so a coincidence of points is three
//! linear rows and a perpendicularity of axes one bilinear row. One file per kind; each
//! implements [`JointKind`].

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

/// The three rows `(a − b)_k = 0`.
pub(crate) fn coincide(a: &Affine, b: &Affine) -> Vec<RowBuilder<f64>> {
    (0..3)
        .map(|k| {
            let mut row = RowBuilder::new();
            for &(s, c) in &a.terms {
                row.linear(3 * s + k, c);
            }
            for &(s, c) in &b.terms {
                row.linear(3 * s + k, -c);
            }
            row.constant(a.constant[k] - b.constant[k]);
            row
        })
        .collect()
}

/// The row `a · b − value = 0`.
pub(crate) fn dot_row(a: &Affine, b: &Affine, value: f64) -> RowBuilder<f64> {
    let mut row = RowBuilder::new();
    for k in 0..3 {
        for &(s, x) in &a.terms {
            for &(t, y) in &b.terms {
                row.product(3 * s + k, 3 * t + k, x * y);
            }
            row.linear(3 * s + k, x * b.constant[k]);
        }
        for &(t, y) in &b.terms {
            row.linear(3 * t + k, y * a.constant[k]);
        }
    }
    let c: f64 = (0..3).map(|k| a.constant[k] * b.constant[k]).sum();
    row.constant(c - value);
    row
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
