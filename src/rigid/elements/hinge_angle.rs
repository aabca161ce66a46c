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

pub(super) fn at<T: Real>(v: &Affine, q: &[T]) -> [T; 3] {
    let mut out = v.constant.map(T::lit);
    let d = v.dim;
    for &(s, c) in &v.terms {
        for (k, o) in out.iter_mut().take(d).enumerate() {
            *o = *o + T::lit(c) * q[d * s + k];
        }
    }
    out
}

/// The linear part of `x` (its terms, without the constant) at the displacement `v`, each
/// slot's part of `v` scaled by `scale[slot]` when given.
pub(super) fn along<T: Real>(x: &Affine, v: &[T], scale: Option<&[T]>) -> [T; 3] {
    let mut o = [T::zero(); 3];
    let d = x.dim;
    for &(slot, coef) in &x.terms {
        let c = T::lit(coef) * scale.map_or(T::one(), |s| s[slot]);
        for (k, ok) in o.iter_mut().take(d).enumerate() {
            *ok = *ok + c * v[d * slot + k];
        }
    }
    o
}

fn cross<T: Real>(a: [T; 3], b: [T; 3]) -> [T; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// `out += Σ_{(s, α) ∈ x} α d e_s`: a derivative `d` with respect to the vector `x` carried to
/// the slots `x` combines (the transpose of [`along`]).
pub(super) fn spread<T: Real>(x: &Affine, d: [T; 3], out: &mut [T]) {
    let n = x.dim;
    for &(slot, coef) in &x.terms {
        for (k, dk) in d.iter().take(n).enumerate() {
            out[n * slot + k] = out[n * slot + k] + T::lit(coef) * *dk;
        }
    }
}

pub(super) fn dot<T: Real>(a: [T; 3], b: [T; 3]) -> T {
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

    /// `∂θ/∂(a, u_A, u_B)` at `q`, each times `scale`.
    fn partials<T: Real>(&self, q: &[T], scale: T) -> [[T; 3]; 3] {
        let (a, ua, ub, s, c) = self.parts(q);
        let f = scale / (s * s + c * c);
        let da = cross(ua, ub).map(|v| f * c * v);
        let b_a = cross(ub, a);
        let dua: [T; 3] = core::array::from_fn(|k| f * (c * b_a[k] - s * ub[k]));
        let a_u = cross(a, ua);
        let dub: [T; 3] = core::array::from_fn(|k| f * (c * a_u[k] - s * ua[k]));
        [da, dua, dub]
    }

    /// `out += scale ∇θ(q)` (positions only; `out` has at least the positions' length).
    pub fn gradient_add<T: Real>(&self, q: &[T], scale: T, out: &mut [T]) {
        let d = self.partials(q, scale);
        for (v, d) in [&self.axis, &self.u_a, &self.u_b].into_iter().zip(d) {
            spread(v, d, out);
        }
    }

    /// `∇θ(q) · v`, the rate of `θ` along `v` (positions only).
    pub fn derivative<T: Real>(&self, q: &[T], v: &[T]) -> T {
        let d = self.partials(q, T::one());
        [&self.axis, &self.u_a, &self.u_b]
            .into_iter()
            .zip(d)
            .fold(T::zero(), |acc, (x, d)| acc + dot(d, along(x, v, None)))
    }

    /// `θ' = ∇θ(q) · W⁻¹ p` for momenta `p` and the inverse mass `inv[s]` of each slot `s`.
    pub fn rate<T: Real>(&self, q: &[T], p: &[T], inv: &[T]) -> T {
        let d = self.partials(q, T::one());
        [&self.axis, &self.u_a, &self.u_b]
            .into_iter()
            .zip(d)
            .fold(T::zero(), |acc, (x, d)| {
                acc + dot(d, along(x, p, Some(inv)))
            })
    }

    /// `out += scale ∇²θ(q) v` (positions only): the directional derivative of the gradient
    /// above along `v`, with `δS = ∇S·v`, `δC = ∇C·v`, `N = S² + C²`:
    ///
    /// ```text
    /// δ∇θ = (δC ∇S − δS ∇C + C δ∇S − S δ∇C)/N − 2 (S δS + C δC)/N · ∇θ
    /// ```
    ///
    /// (`∇S = (u_A × u_B, u_B × a, a × u_A)`, `∇C = (0, u_B, u_A)` over `(a, u_A, u_B)`).
    pub fn hessian_apply_add<T: Real>(&self, q: &[T], v: &[T], scale: T, out: &mut [T]) {
        let (a, ua, ub, s, c) = self.parts(q);
        let (da, dua, dub) = (
            along(&self.axis, v, None),
            along(&self.u_a, v, None),
            along(&self.u_b, v, None),
        );
        let zero = [T::zero(); 3];
        let add = |x: [T; 3], y: [T; 3]| [x[0] + y[0], x[1] + y[1], x[2] + y[2]];
        let gs = [cross(ua, ub), cross(ub, a), cross(a, ua)];
        let gc = [zero, ub, ua];
        let ds = dot(gs[0], da) + dot(gs[1], dua) + dot(gs[2], dub);
        let dc = dot(ub, dua) + dot(ua, dub);
        let dgs = [
            add(cross(dua, ub), cross(ua, dub)),
            add(cross(dub, a), cross(ub, da)),
            add(cross(da, ua), cross(a, dua)),
        ];
        let dgc = [zero, dub, dua];
        let n = s * s + c * c;
        let k = T::lit(2.0) * (s * ds + c * dc) / n;
        for (i, x) in [&self.axis, &self.u_a, &self.u_b].into_iter().enumerate() {
            let d: [T; 3] = core::array::from_fn(|j| {
                scale
                    * ((dc * gs[i][j] - ds * gc[i][j] + c * dgs[i][j] - s * dgc[i][j])
                        - k * (c * gs[i][j] - s * gc[i][j]))
                    / n
            });
            spread(x, d, out);
        }
    }

    /// The slots `θ` depends on.
    pub fn slots(&self) -> Vec<usize> {
        let mut s: Vec<usize> = [&self.axis, &self.u_a, &self.u_b]
            .iter()
            .flat_map(|x| x.terms.iter().map(|t| t.0))
            .collect();
        s.sort_unstable();
        s.dedup();
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rigid::frames::Entry;
    use crate::rigid::joints::BodyRef;
    use crate::rigid::pose::Rotation;

    /// The Hessian product is the derivative of the gradient: central differences of
    /// `∇θ` along `v` agree with `∇²θ v` to their truncation `h²/6 |∇⁴θ|` plus round-off
    /// `ε |∇θ| / h` (`h = 1e-4`: below 1e-7 for these unit-scale directors).
    #[test]
    fn the_hessian_product_is_the_gradient_s_derivative() {
        let r = Rotation::from_axis_angle([0.3, -0.4, 0.8], 0.7).unwrap();
        let mut q0 = vec![0.0; 24];
        for i in 0..3 {
            let (c, d) = (Rotation::identity().column(i), r.column(i));
            q0[3 * (1 + i)..3 * (2 + i)].copy_from_slice(&c);
            q0[3 * (5 + i)..3 * (6 + i)].copy_from_slice(&d);
        }
        let entries = [
            Entry::Rigid {
                slot: 0,
                axes: Rotation::identity(),
            },
            Entry::Rigid { slot: 4, axes: r },
        ];
        let frames = Frames {
            entries: &entries,
            q0: &q0,
            dim: 3,
        };
        let hinge = Hinge {
            a: BodyRef::Body(0),
            anchor_a: [0.0; 3],
            axis_a: [0.0, 0.0, 1.0],
            b: BodyRef::Body(1),
            anchor_b: [0.0; 3],
            axis_b: r.transpose().apply([0.0, 0.0, 1.0]),
        };
        let angle = HingeAngle::of(&hinge, &frames).unwrap();
        // Away from the initial poses, in a direction that touches every slot.
        let q: Vec<f64> = q0
            .iter()
            .enumerate()
            .map(|(i, x)| x + 0.05 * ((i as f64) * 0.7).sin())
            .collect();
        let v: Vec<f64> = (0..24).map(|i| ((i as f64) * 1.3).cos()).collect();
        let h = 1e-4;
        let grad = |s: f64| {
            let x: Vec<f64> = q.iter().zip(&v).map(|(a, b)| a + s * b).collect();
            let mut g = vec![0.0; 24];
            angle.gradient_add(&x, 1.0, &mut g);
            g
        };
        let (gp, gm) = (grad(h), grad(-h));
        let mut hv = vec![0.0; 24];
        angle.hessian_apply_add(&q, &v, 1.0, &mut hv);
        let scale = hv.iter().fold(1.0f64, |a, x| a.max(x.abs()));
        for i in 0..24 {
            let fd = (gp[i] - gm[i]) / (2.0 * h);
            assert!((fd - hv[i]).abs() < 1e-7 * scale, "{i}: {fd} vs {}", hv[i]);
        }
        // And the rate is the gradient's product with the direction.
        let mut g = vec![0.0; 24];
        angle.gradient_add(&q, 1.0, &mut g);
        let gv: f64 = g.iter().zip(&v).map(|(a, b)| a * b).sum();
        assert!((angle.derivative(&q, &v) - gv).abs() < 1e-14 * (1.0 + gv.abs()));
    }
}
