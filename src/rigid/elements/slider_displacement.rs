//! A slider's displacement as a function of the slots: `d = (P_A − P_B)·u_A − d₀`, how far the
//! first body's anchor has moved from the second's (or the world's) along the sliding axis
//! `u_A` the first body carries, zero at the initial poses. Both factors are affine in the slots
//! (a centre plus directors times body-frame coordinates), so `d` is quadratic: with
//! `g = P_A − P_B`,
//!
//! ```text
//! ∂d/∂x = Σ_{(s, α) ∈ g} α u_A e_s + Σ_{(s, α) ∈ u_A} α g e_s,
//! ∇²d v = Σ_{(s, α) ∈ g} α (u_A·v) e_s + Σ_{(s, α) ∈ u_A} α (g·v) e_s
//! ```
//!
//! (`(x·v)` the linear part of `x` along `v`): constant second derivatives.

use super::hinge_angle::{along, at, dot, spread};
use crate::error::SetupError;
use crate::real::Real;
use crate::rigid::frames::{Affine, Frames};
use crate::rigid::joints::{Slider, unit_axis};

/// The displacement of a slider (see the module documentation).
#[derive(Debug, Clone, PartialEq)]
pub struct SliderDisplacement {
    gap: Affine,
    axis: Affine,
    zero: f64,
}

impl SliderDisplacement {
    /// The displacement along `slider`'s axis, zero at the initial poses.
    ///
    /// # Errors
    /// As the slider's rows ([`Slider`]): unknown bodies, a point mass, a zero axis.
    pub fn of(slider: &Slider, frames: &Frames<'_>) -> Result<Self, SetupError> {
        let axis = frames.axis(slider.a, unit_axis("slider", slider.axis_a)?)?;
        let ra = frames.point(slider.a, slider.anchor_a)?;
        let rb = frames.point(slider.b, slider.anchor_b)?;
        let mut gap = ra.clone();
        gap.constant = core::array::from_fn(|k| ra.constant[k] - rb.constant[k]);
        gap.terms.extend(rb.terms.iter().map(|&(s, c)| (s, -c)));
        let q0 = frames.initial_positions();
        let zero = crate::rigid::pose::dot(gap.at(q0), axis.at(q0));
        Ok(Self { gap, axis, zero })
    }

    /// `d(q)`.
    pub fn value<T: Real>(&self, q: &[T]) -> T {
        dot(at(&self.gap, q), at(&self.axis, q)) - T::lit(self.zero)
    }

    /// `out += scale ∇d(q)` (positions only).
    pub fn gradient_add<T: Real>(&self, q: &[T], scale: T, out: &mut [T]) {
        let (g, u) = (at(&self.gap, q), at(&self.axis, q));
        spread(&self.gap, u.map(|x| scale * x), out);
        spread(&self.axis, g.map(|x| scale * x), out);
    }

    /// `∇d(q)·v` (positions only).
    pub fn derivative<T: Real>(&self, q: &[T], v: &[T]) -> T {
        let (g, u) = (at(&self.gap, q), at(&self.axis, q));
        dot(u, along(&self.gap, v, None)) + dot(g, along(&self.axis, v, None))
    }

    /// `d' = ∇d(q)·W⁻¹ p` for momenta `p` and the inverse mass `inv[s]` of each slot `s`.
    pub fn rate<T: Real>(&self, q: &[T], p: &[T], inv: &[T]) -> T {
        let (g, u) = (at(&self.gap, q), at(&self.axis, q));
        dot(u, along(&self.gap, p, Some(inv))) + dot(g, along(&self.axis, p, Some(inv)))
    }

    /// `out += scale ∇²d v` (constant: `q` is not read).
    pub fn hessian_apply_add<T: Real>(&self, _q: &[T], v: &[T], scale: T, out: &mut [T]) {
        let (gv, uv) = (along(&self.gap, v, None), along(&self.axis, v, None));
        spread(&self.gap, uv.map(|x| scale * x), out);
        spread(&self.axis, gv.map(|x| scale * x), out);
    }

    /// The slots `d` depends on.
    pub fn slots(&self) -> Vec<usize> {
        let mut s: Vec<usize> = [&self.gap, &self.axis]
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

    /// The gradient against central differences of `d` (exact for a quadratic: only round-off,
    /// `ε |d| / h`), and the Hessian product against central differences of the gradient
    /// (exact likewise), at a point away from the initial poses where every slot counts.
    #[test]
    fn the_gradient_and_hessian_are_the_derivatives_of_the_displacement() {
        let r = Rotation::from_axis_angle([0.3, -0.4, 0.8], 0.7).unwrap();
        let mut q0 = vec![0.0; 24];
        q0[12..15].copy_from_slice(&[0.4, 0.2, -0.1]);
        for i in 0..3 {
            q0[3 * (1 + i)..3 * (2 + i)].copy_from_slice(&r.column(i));
            q0[3 * (5 + i)..3 * (6 + i)].copy_from_slice(&Rotation::identity().column(i));
        }
        let entries = [
            Entry::Rigid { slot: 0, axes: r },
            Entry::Rigid {
                slot: 4,
                axes: Rotation::identity(),
            },
        ];
        let frames = Frames {
            entries: &entries,
            q0: &q0,
            dim: 3,
        };
        let slider = Slider {
            a: BodyRef::Body(0),
            anchor_a: [0.1, -0.2, 0.3],
            axis_a: [0.2, 0.5, 1.0],
            b: BodyRef::Body(1),
            anchor_b: [-0.3, 0.1, 0.2],
        };
        let d = SliderDisplacement::of(&slider, &frames).unwrap();
        assert!(d.value(&q0).abs() < 1e-15);
        let q: Vec<f64> = q0
            .iter()
            .enumerate()
            .map(|(i, x)| x + 0.05 * ((i as f64) * 0.7).sin())
            .collect();
        let v: Vec<f64> = (0..24).map(|i| ((i as f64) * 1.3).cos()).collect();
        let h = 1e-3;
        let shifted = |s: f64| -> Vec<f64> { q.iter().zip(&v).map(|(a, b)| a + s * b).collect() };
        let mut g = vec![0.0; 24];
        d.gradient_add(&q, 1.0, &mut g);
        let fd = (d.value(&shifted(h)) - d.value(&shifted(-h))) / (2.0 * h);
        let gv: f64 = g.iter().zip(&v).map(|(a, b)| a * b).sum();
        assert!((fd - gv).abs() < 1e-12, "{fd} vs {gv}");
        assert!((d.derivative(&q, &v) - gv).abs() < 1e-14);
        let grad = |s: f64| {
            let mut g = vec![0.0; 24];
            d.gradient_add(&shifted(s), 1.0, &mut g);
            g
        };
        let (gp, gm) = (grad(h), grad(-h));
        let mut hv = vec![0.0; 24];
        d.hessian_apply_add(&q, &v, 1.0, &mut hv);
        for i in 0..24 {
            let fd = (gp[i] - gm[i]) / (2.0 * h);
            assert!((fd - hv[i]).abs() < 1e-12, "{i}: {fd} vs {}", hv[i]);
        }
    }
}
