//! A torsion spring about a hinge's axis, `V = k/2 (θ − θ₀)²`: `θ` the angle between two rigid
//! bodies (or a rigid body and the world) about an axis they share, measured from the initial
//! poses by the library's [`HingeAngle`] (`θ = atan2(a·(u_A × u_B), u_A·u_B)`, its gradient and
//! Hessian on the directors in closed form). Put it beside a `hinge` about the same axis: the
//! angle is a hinge's angle only while the bodies keep the axis in common.

use super::coordinate::{slot_pairs, spring_hessian_add};
use super::{Assembler, Effect, Potential, PotentialOps};
use crate::real::Real;
use crate::rigid::HingeAngle;
use crate::scene::error::FieldPath;
use crate::scene::names::Flag;
use crate::scene::validate::{Result, finite, non_negative};
use serde::Deserialize;

/// `type = "torsion-spring"`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TorsionSpringSpec {
    /// Label in summaries (default `torsion-spring`).
    #[serde(default)]
    pub name: Option<String>,
    /// One rigid body (turning against the world) or two, the first rigid.
    pub bodies: Vec<String>,
    /// The axis in the world at the start.
    #[serde(default)]
    pub axis: Option<Vec<f64>>,
    /// Or: the axis in each body's frame (a world direction for the world).
    #[serde(default)]
    pub axes: Option<Vec<Vec<f64>>>,
    /// Stiffness `k ≥ 0`, N m per radian.
    pub stiffness: f64,
    /// The rest angle `θ₀` from the initial poses, degrees (default 0: at rest where it starts).
    #[serde(default)]
    pub rest_angle_deg: Option<f64>,
}

/// `k/2 (θ − θ₀)²` on a hinge angle.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Torsion<T> {
    angle: HingeAngle,
    stiffness: T,
    rest: T,
    slots: Vec<usize>,
}

impl Effect for TorsionSpringSpec {
    const FLAG: Flag = Flag::Springs;
    fn assemble(
        &self,
        cx: &mut Assembler<'_>,
        path: &FieldPath,
        _label: &str,
        _on: bool,
    ) -> Result<Option<Potential<f64>>> {
        let bodies = cx.bodies;
        let angle =
            crate::scene::ports::hinge_angle(&self.bodies, &self.axis, &self.axes, bodies, path)?;
        let k = non_negative(self.stiffness, &path.key("stiffness"), "stiffness")?;
        let rest = self
            .rest_angle_deg
            .map(|a| finite(a, &path.key("rest_angle_deg")))
            .transpose()?
            .unwrap_or(0.0)
            .to_radians();
        let slots = angle.slots();
        Ok(Some(Potential::Torsion(Torsion {
            angle,
            stiffness: k,
            rest,
            slots,
        })))
    }
}

impl Torsion<f64> {
    pub(crate) fn with_scalar<U: Real>(&self) -> Torsion<U> {
        Torsion {
            angle: self.angle.clone(),
            stiffness: U::lit(self.stiffness),
            rest: U::lit(self.rest),
            slots: self.slots.clone(),
        }
    }
}

impl<T: Real> Torsion<T> {
    /// `θ − θ₀` taken in `(−π, π]`: the angle is measured modulo a turn, so the spring's
    /// potential is continuous everywhere and its one cusp is half a turn from its rest (a
    /// spring wound past half a turn is not what it models).
    fn stretch(&self, q: &[T]) -> T {
        let s = self.angle.value(q) - self.rest;
        let turn = T::lit(2.0 * core::f64::consts::PI);
        s - turn * (s / turn).round()
    }
}

impl<T: Real> PotentialOps<T> for Torsion<T> {
    fn energy(&self, q: &[T], _d: usize) -> T {
        let s = self.stretch(q);
        T::lit(0.5) * self.stiffness * s * s
    }
    fn gradient_add(&self, q: &[T], _d: usize, alpha: T, out: &mut [T]) {
        let s = self.stretch(q);
        self.angle.gradient_add(q, alpha * self.stiffness * s, out);
    }
    /// `k (∇θ·v) ∇θ + k (θ − θ₀) ∇²θ v`.
    fn hessian_apply_add(&self, q: &[T], _d: usize, v: &[T], out: &mut [T]) {
        spring_hessian_add(&self.angle, q, v, self.stiffness, self.stretch(q), out);
    }
    fn is_quadratic(&self) -> bool {
        false
    }
    fn hessian_bodies(&self, out: &mut Vec<(usize, usize)>) {
        slot_pairs(&self.slots, out);
    }
}
