//! A hinge's angle as a function of the directors: `θ = atan2(a·(u_A × u_B), u_A·u_B)` with `a`
//! the hinge's axis in `A`, `u_A` and `u_B` perpendicular to it in each body and equal at the
//! initial poses (so `θ = 0` there), and its gradient
//!
//! ```text
//! ∂θ/∂a = C (u_A × u_B)/N,   ∂θ/∂u_A = (C (u_B × a) − S u_B)/N,   ∂θ/∂u_B = (C (a × u_A) − S u_A)/N
//! ```
//!
//! (`S = a·(u_A × u_B)`, `C = u_A·u_B`, `N = S² + C²`), carried to the slots through the
//! vectors' linear combinations.

use crate::error::SetupError;
use crate::real::Real;
use crate::rigid::frames::Frames;
use crate::rigid::joints::{Affine, Hinge, perpendiculars, unit_axis};

/// The angle of a hinge (see the module documentation).
#[derive(Debug, Clone, PartialEq)]
pub struct HingeAngle {
    axis: Affine,
    u_a: Affine,
    u_b: Affine,
}

fn at<T: Real>(v: &Affine, q: &[T]) -> [T; 3] {
    let mut out = v.constant.map(T::lit);
    for &(s, c) in &v.terms {
        for (k, o) in out.iter_mut().enumerate() {
            *o = *o + T::lit(c) * q[3 * s + k];
        }
    }
    out
}

fn cross<T: Real>(a: [T; 3], b: [T; 3]) -> [T; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn dot<T: Real>(a: [T; 3], b: [T; 3]) -> T {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

impl HingeAngle {
    /// The angle of `hinge`, zero at the initial poses.
    ///
    /// # Errors
    /// As the hinge's rows ([`Hinge`]): unknown bodies, a point mass, a zero axis.
    pub fn of(hinge: &Hinge, frames: &Frames<'_>) -> Result<Self, SetupError> {
        let axis = frames.axis(hinge.a, unit_axis("hinge", hinge.axis_a)?)?;
        let (u, _) = perpendiculars(unit_axis("hinge", hinge.axis_b)?);
        let u_b = frames.axis(hinge.b, u)?;
        // The same world vector at the initial poses, carried by A.
        let u_a = frames.follow(hinge.a, u_b.at(frames.initial_positions()))?;
        Ok(Self { axis, u_a, u_b })
    }

    /// `(S, C)` at positions `q`.
    fn parts<T: Real>(&self, q: &[T]) -> ([T; 3], [T; 3], [T; 3], T, T) {
        let (a, ua, ub) = (at(&self.axis, q), at(&self.u_a, q), at(&self.u_b, q));
        let s = dot(a, cross(ua, ub));
        let c = dot(ua, ub);
        (a, ua, ub, s, c)
    }

    /// `θ(q)` in `(−π, π]`.
    pub fn value<T: Real>(&self, q: &[T]) -> T {
        let (_, _, _, s, c) = self.parts(q);
        s.atan2(c)
    }

    /// `out += scale ∇θ(q)` (positions only; `out` has at least the positions' length).
    pub fn gradient_add<T: Real>(&self, q: &[T], scale: T, out: &mut [T]) {
        let (a, ua, ub, s, c) = self.parts(q);
        let f = scale / (s * s + c * c);
        let da = cross(ua, ub).map(|v| f * c * v);
        let b_a = cross(ub, a);
        let dua: [T; 3] = core::array::from_fn(|k| f * (c * b_a[k] - s * ub[k]));
        let a_u = cross(a, ua);
        let dub: [T; 3] = core::array::from_fn(|k| f * (c * a_u[k] - s * ua[k]));
        for (v, d) in [(&self.axis, da), (&self.u_a, dua), (&self.u_b, dub)] {
            for &(slot, coef) in &v.terms {
                for k in 0..3 {
                    out[3 * slot + k] = out[3 * slot + k] + T::lit(coef) * d[k];
                }
            }
        }
    }
}
