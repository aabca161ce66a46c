//! `type = "hinge"`: a hinge (revolute) joint, a ball joint whose bodies also keep an axis in
//! common — five rows on the slots (`crate::rigid::Hinge`).

use super::joint::{self, body_ref};
use super::{Declare, Declared};
use crate::rigid::Hinge;
use crate::scene::bodies::Bodies;
use crate::scene::error::FieldPath;
use crate::scene::validate::Result;
use serde::Deserialize;

/// A hinge between two bodies, or a body and the world (in a planar scene: a pin, about the
/// plane's normal).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HingeSpec {
    /// A name: the joint's label in messages, its multipliers' CSV columns, and what
    /// `--off NAME` switches off.
    #[serde(default)]
    pub name: Option<String>,
    /// One body (joined to the world) or two; the first must be rigid.
    pub bodies: Vec<String>,
    /// A point of the hinge's axis in the world at the start.
    #[serde(default)]
    pub anchor: Option<Vec<f64>>,
    /// Or: that point in each body's frame (a world point for the world).
    #[serde(default)]
    pub anchors: Option<Vec<Vec<f64>>>,
    /// The hinge's axis in the world at the start.
    #[serde(default)]
    pub axis: Option<Vec<f64>>,
    /// Or: the axis in each body's frame (a world direction for the world).
    #[serde(default)]
    pub axes: Option<Vec<Vec<f64>>>,
}

impl Declare for HingeSpec {
    fn declare(
        &self,
        i: usize,
        path: &FieldPath,
        bodies: &Bodies,
        out: &mut Vec<Declared>,
    ) -> Result<()> {
        let ends = joint::ends(&self.bodies, bodies, path, "hinge")?;
        let [anchor_a, anchor_b] = joint::anchors(&self.anchor, &self.anchors, ends, bodies, path)?;
        let [axis_a, axis_b] = joint::hinge_axes(&self.axis, &self.axes, ends, bodies, path)?;
        let hinge = Hinge {
            a: body_ref(0, Some(ends.a)),
            anchor_a,
            axis_a,
            b: body_ref(1, ends.b),
            anchor_b,
            axis_b,
        };
        joint::declare(
            &hinge,
            ends,
            ([anchor_a, anchor_b], Some(axis_a)),
            bodies,
            i,
            path,
            out,
        )
    }
}
