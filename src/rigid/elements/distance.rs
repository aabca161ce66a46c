//! The distance between two bodies' points as a function of the slots, `r = |P_A − P_B|`: the
//! length of a spring-damper element (a line force between the points). `P_A − P_B` is affine
//! in the slots (a centre plus directors times body-frame coordinates, `g`), so with `e = g/r`,
//!
//! ```text
//! ∂r/∂x = Σ_{(s, α) ∈ g} α e e_s,     ∇²r v = Σ_{(s, α) ∈ g} α ((I − e eᵀ)/r) (g·v) e_s
//! ```
//!
//! (`(g·v)` the linear part of `g` along `v`).

use super::hinge_angle::{along, at, dot, spread};
use crate::error::SetupError;
use crate::real::Real;
use crate::rigid::frames::{Affine, Frames};
use crate::rigid::joints::BodyRef;

/// The distance between a point of one body and a point of another (or of the world).
#[derive(Debug, Clone, PartialEq)]
pub struct Distance {
    gap: Affine,
}

impl Distance {
    /// The distance between the point `pa` of body `a` and `pb` of `b` (each in its body's
    /// frame; a world point for the world).
    ///
    /// # Errors
    /// An unknown body; coincident points at the initial poses (the line has no direction).
    pub fn of(
        a: BodyRef,
        pa: [f64; 3],
        b: BodyRef,
        pb: [f64; 3],
        frames: &Frames<'_>,
    ) -> Result<Self, SetupError> {
        let ra = frames.point(a, pa)?;
        let rb = frames.point(b, pb)?;
        let mut gap = ra.clone();
        gap.constant = core::array::from_fn(|k| ra.constant[k] - rb.constant[k]);
        gap.terms.extend(rb.terms.iter().map(|&(s, c)| (s, -c)));
        let g0 = gap.at(frames.initial_positions());
        let r0 = crate::rigid::pose::dot(g0, g0).sqrt();
        if !(r0 > 0.0 && r0.is_finite()) {
            return Err(SetupError::InvalidParameter {
                name: "distance between the points".to_owned(),
                value: r0,
                requirement: "positive at the initial poses (a line force needs a direction)",
            });
        }
        Ok(Self { gap })
    }

    fn unit<T: Real>(&self, q: &[T]) -> ([T; 3], T) {
        let g = at(&self.gap, q);
        let r = dot(g, g).sqrt();
        (g.map(|x| x / r), r)
    }

    /// `r(q)`.
    pub fn value<T: Real>(&self, q: &[T]) -> T {
        let g = at(&self.gap, q);
        dot(g, g).sqrt()
    }

    /// `out += scale ∇r(q)` (positions only).
    pub fn gradient_add<T: Real>(&self, q: &[T], scale: T, out: &mut [T]) {
        let (e, _) = self.unit(q);
        spread(&self.gap, e.map(|x| scale * x), out);
    }

    /// `∇r(q)·v` (positions only).
    pub fn derivative<T: Real>(&self, q: &[T], v: &[T]) -> T {
        let (e, _) = self.unit(q);
        dot(e, along(&self.gap, v, None))
    }

    /// `r' = ∇r(q)·W⁻¹ p` for momenta `p` and the inverse mass `inv[s]` of each slot `s`.
    pub fn rate<T: Real>(&self, q: &[T], p: &[T], inv: &[T]) -> T {
        let (e, _) = self.unit(q);
        dot(e, along(&self.gap, p, Some(inv)))
    }

    /// `out += scale ∇²r v`.
    pub fn hessian_apply_add<T: Real>(&self, q: &[T], v: &[T], scale: T, out: &mut [T]) {
        let (e, r) = self.unit(q);
        let gv = along(&self.gap, v, None);
        let ev = dot(e, gv);
        let w: [T; 3] = core::array::from_fn(|k| scale * (gv[k] - e[k] * ev) / r);
        spread(&self.gap, w, out);
    }

    /// The slots `r` depends on.
    pub fn slots(&self) -> Vec<usize> {
        let mut s: Vec<usize> = self.gap.terms.iter().map(|t| t.0).collect();
        s.sort_unstable();
        s.dedup();
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rigid::frames::Entry;
    use crate::rigid::pose::Rotation;

    /// The gradient and Hessian product against central differences, between a point of a
    /// turned rigid body and a point mass.
    #[test]
    fn the_gradient_and_hessian_are_the_derivatives_of_the_distance() {
        let r = Rotation::from_axis_angle([0.3, -0.4, 0.8], 0.7).unwrap();
        let mut q0 = vec![0.0; 15];
        for i in 0..3 {
            q0[3 * (1 + i)..3 * (2 + i)].copy_from_slice(&r.column(i));
        }
        q0[12..15].copy_from_slice(&[0.9, -0.3, 0.5]);
        let entries = [Entry::Rigid { slot: 0, axes: r }, Entry::Point { slot: 4 }];
        let frames = Frames {
            entries: &entries,
            q0: &q0,
            dim: 3,
        };
        let d = Distance::of(
            BodyRef::Body(0),
            [0.2, 0.1, -0.3],
            BodyRef::Body(1),
            [0.0; 3],
            &frames,
        )
        .unwrap();
        // Away from the initial poses, every slot moved.
        let q: Vec<f64> = q0
            .iter()
            .enumerate()
            .map(|(i, x)| x + 0.01 * (i as f64).sin())
            .collect();
        let v: Vec<f64> = (0..15).map(|i| (0.7 * i as f64).cos()).collect();
        let h = 1e-6;
        let mut grad = vec![0.0; 15];
        d.gradient_add(&q, 1.0, &mut grad);
        let mut hv = vec![0.0; 15];
        d.hessian_apply_add(&q, &v, 1.0, &mut hv);
        for i in 0..15 {
            let mut qp = q.clone();
            let mut qm = q.clone();
            qp[i] += h;
            qm[i] -= h;
            let fd = (d.value(&qp) - d.value(&qm)) / (2.0 * h);
            assert!((fd - grad[i]).abs() < 1e-8, "{i}: {fd} vs {}", grad[i]);
            let (mut gp, mut gm) = (vec![0.0; 15], vec![0.0; 15]);
            d.gradient_add(&qp, 1.0, &mut gp);
            d.gradient_add(&qm, 1.0, &mut gm);
            let fdh: f64 = (0..15).map(|j| (gp[j] - gm[j]) / (2.0 * h) * v[j]).sum();
            assert!((fdh - hv[i]).abs() < 1e-7, "{i}: {fdh} vs {}", hv[i]);
        }
        let dv: f64 = grad.iter().zip(&v).map(|(g, v)| g * v).sum();
        assert!((d.derivative(&q, &v) - dv).abs() < 1e-14);
    }
}
