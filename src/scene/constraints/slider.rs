//! `type = "slider"`: a slider (prismatic) joint, the bodies keep their relative orientation
//! and move apart along one axis only — five rows on the slots (`crate::rigid::Slider`).

use super::joint::{self, body_ref};
use super::{Declare, Declared};
use crate::rigid::Slider;
use crate::scene::bodies::Bodies;
use crate::scene::error::FieldPath;
use crate::scene::validate::Result;
use serde::Deserialize;

/// A slider between two bodies, or a body and the world (3D).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SliderSpec {
    /// A name: the joint's label in messages, its multipliers' CSV columns, and what
    /// `--off NAME` switches off.
    #[serde(default)]
    pub name: Option<String>,
    /// One body (sliding in the world) or two; the first must be rigid.
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
    /// Or: the sliding axis in each body's frame (the first is used; the second must be the
    /// same line).
    #[serde(default)]
    pub axes: Option<Vec<Vec<f64>>>,
}

impl Declare for SliderSpec {
    fn declare(
        &self,
        i: usize,
        path: &FieldPath,
        bodies: &Bodies,
        out: &mut Vec<Declared>,
    ) -> Result<()> {
        let ends = joint::ends(&self.bodies, bodies, path, "slider")?;
        let anchor = match (&self.anchor, &self.anchors) {
            (None, None) => Some(bodies.list[ends.a].q[..bodies.dim].to_vec()),
            (a, _) => a.clone(),
        };
        let [anchor_a, anchor_b] = joint::anchors(&anchor, &self.anchors, ends, bodies, path)?;
        let [axis_a, _] =
            joint::axes(&self.axis, &self.axes, ("axis", "axes"), ends, bodies, path)?;
        let slider = Slider {
            a: body_ref(0, Some(ends.a)),
            anchor_a,
            axis_a,
            b: body_ref(1, ends.b),
            anchor_b,
        };
        joint::declare(
            &slider,
            ends,
            ([anchor_a, anchor_b], Some(axis_a)),
            bodies,
            i,
            path,
            out,
        )
    }
}
