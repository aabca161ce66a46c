//! A spring along a slider's axis, `V = k/2 (d − d₀)²`: `d` the displacement of the first body
//! from the second (or the world) along the sliding axis the first carries, zero at the initial
//! poses ([`SliderDisplacement`]: quadratic in the slots, its gradient and constant Hessian in
//! closed form). Put it beside a `slider` on the same axis: `d` is the slider's coordinate only
//! while the bodies keep to that line.

use super::coordinate::{slot_pairs, spring_hessian_add};
use super::{Assembler, Effect, Potential, PotentialOps};
use crate::real::Real;
use crate::rigid::SliderDisplacement;
use crate::scene::error::FieldPath;
use crate::scene::names::Flag;
use crate::scene::validate::{Result, finite, non_negative};
use serde::Deserialize;

/// `type = "slider-spring"`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SliderSpringSpec {
    /// Label in summaries (default `slider-spring`).
    #[serde(default)]
    pub name: Option<String>,
    /// One rigid body (sliding in the world) or two, the first rigid.
    pub bodies: Vec<String>,
    /// A point of the sliding line in the world at the start (default: the first body's
    /// centre).
    #[serde(default)]
    pub anchor: Option<Vec<f64>>,
    /// Or: that point in each body's frame (a world point for the world).
    #[serde(default)]
    pub anchors: Option<Vec<Vec<f64>>>,
    /// The sliding axis in the world at the start.
    #[serde(default)]
    pub axis: Option<Vec<f64>>,
    /// Or: the sliding axis in each body's frame (the first is used).
    #[serde(default)]
    pub axes: Option<Vec<Vec<f64>>>,
    /// Stiffness `k ≥ 0`, N/m.
    pub stiffness: f64,
    /// The rest displacement `d₀` from the initial poses, m (default 0: at rest where it
    /// starts).
    #[serde(default)]
    pub rest: Option<f64>,
}

/// `k/2 (d − d₀)²` on a slider's displacement.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct SliderSpring<T> {
    displacement: SliderDisplacement,
    stiffness: T,
    rest: T,
    slots: Vec<usize>,
}

impl Effect for SliderSpringSpec {
    const FLAG: Flag = Flag::Springs;
    fn assemble(
        &self,
        cx: &mut Assembler<'_>,
        path: &FieldPath,
        _label: &str,
        _on: bool,
    ) -> Result<Option<Potential<f64>>> {
        let displacement = crate::scene::ports::slider_displacement(
            &self.bodies,
            &self.anchor,
            &self.anchors,
            &self.axis,
            &self.axes,
            cx.bodies,
            path,
        )?;
        let k = non_negative(self.stiffness, &path.key("stiffness"), "stiffness")?;
        let rest = self
            .rest
            .map(|r| finite(r, &path.key("rest")))
            .transpose()?
            .unwrap_or(0.0);
        let slots = displacement.slots();
        Ok(Some(Potential::SliderSpring(SliderSpring {
            displacement,
            stiffness: k,
            rest,
            slots,
        })))
    }
}

impl SliderSpring<f64> {
    pub(crate) fn with_scalar<U: Real>(&self) -> SliderSpring<U> {
        SliderSpring {
            displacement: self.displacement.clone(),
            stiffness: U::lit(self.stiffness),
            rest: U::lit(self.rest),
            slots: self.slots.clone(),
        }
    }
}

impl<T: Real> PotentialOps<T> for SliderSpring<T> {
    fn energy(&self, q: &[T], _d: usize) -> T {
        let s = self.displacement.value(q) - self.rest;
        T::lit(0.5) * self.stiffness * s * s
    }
    fn gradient_add(&self, q: &[T], _d: usize, alpha: T, out: &mut [T]) {
        let s = self.displacement.value(q) - self.rest;
        self.displacement
            .gradient_add(q, alpha * self.stiffness * s, out);
    }
    /// `k (∇d·v) ∇d + k (d − d₀) ∇²d v`.
    fn hessian_apply_add(&self, q: &[T], _d: usize, v: &[T], out: &mut [T]) {
        let s = self.displacement.value(q) - self.rest;
        spring_hessian_add(&self.displacement, q, v, self.stiffness, s, out);
    }
    fn is_quadratic(&self) -> bool {
        false
    }
    fn hessian_bodies(&self, out: &mut Vec<(usize, usize)>) {
        slot_pairs(&self.slots, out);
    }
}
