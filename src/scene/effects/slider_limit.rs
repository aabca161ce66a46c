//! A slider's stops as one-sided springs: the hinge stops' penalty law (`hinge_limit.rs`) on
//! the displacement `d = (P_A − P_B)·u_A` from the initial poses,
//!
//! ```text
//! V = k/2 (d − d_max)²   for d > d_max,     k/2 (d_min − d)²   for d < d_min,     0 between,
//! ```
//!
//! conservative (restitution 1, the overshoot at a relative speed `v` being `v √(μ/k)`, `μ` the
//! mass the slider moves), its energy part of the run's; losses at the stop are a
//! `slider-damper` beside it.

use super::hinge_limit::HingeLimit;
use super::{Assembler, Effect, Potential};
use crate::rigid::Coordinate;
use crate::scene::error::FieldPath;
use crate::scene::names::Flag;
use crate::scene::validate::{Result, finite};
use serde::Deserialize;

/// `type = "slider-limit"`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SliderLimitSpec {
    /// Label in summaries (default `slider-limit`).
    #[serde(default)]
    pub name: Option<String>,
    /// One rigid body (sliding against the world) or two, the first rigid.
    pub bodies: Vec<String>,
    /// A point of the axis in the world at the start (default: the first body's centre).
    #[serde(default)]
    pub anchor: Option<Vec<f64>>,
    /// Or: that point in each body's frame (a world point for the world).
    #[serde(default)]
    pub anchors: Option<Vec<Vec<f64>>>,
    /// The axis in the world at the start.
    #[serde(default)]
    pub axis: Option<Vec<f64>>,
    /// Or: the axis in each body's frame (a world direction for the world).
    #[serde(default)]
    pub axes: Option<Vec<Vec<f64>>>,
    /// The stops' stiffness `k > 0`, N/m.
    pub stiffness: f64,
    /// The lower stop `d_min` from the initial poses, m (none if absent).
    #[serde(default)]
    pub min: Option<f64>,
    /// The upper stop `d_max`, m, above `min` (none if absent).
    #[serde(default)]
    pub max: Option<f64>,
}

impl Effect for SliderLimitSpec {
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
        let min = self.min.map(|v| finite(v, &path.key("min"))).transpose()?;
        let max = self.max.map(|v| finite(v, &path.key("max"))).transpose()?;
        let limit = HingeLimit::checked(
            Coordinate::Displacement(displacement),
            self.stiffness,
            [min, max],
            path,
            ("slider", ["min", "max"]),
        )?;
        Ok(Some(Potential::HingeLimit(limit)))
    }
}
