//! `type = "ball"`: a ball (spherical) joint, the bodies' anchors coincide — three linear rows
//! on the slots (`crate::rigid::Ball`).

use super::joint::{self, body_ref};
use super::{Declare, Declared};
use crate::rigid::Ball;
use crate::scene::bodies::Bodies;
use crate::scene::error::FieldPath;
use crate::scene::validate::Result;
use serde::Deserialize;

/// A ball joint between two bodies, or a body and the world (3D).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BallSpec {
    /// A name: the joint's label in messages, its multipliers' CSV columns, and what
    /// `--off NAME` switches off.
    #[serde(default)]
    pub name: Option<String>,
    /// One body (joined to the world) or two.
    pub bodies: Vec<String>,
    /// The joint's centre in the world at the start.
    #[serde(default)]
    pub anchor: Option<Vec<f64>>,
    /// Or: the joint's centre in each body's frame (a world point for the world).
    #[serde(default)]
    pub anchors: Option<Vec<Vec<f64>>>,
}

impl Declare for BallSpec {
    fn declare(
        &self,
        i: usize,
        path: &FieldPath,
        bodies: &Bodies,
        out: &mut Vec<Declared>,
    ) -> Result<()> {
        let ends = joint::ends(&self.bodies, bodies, path, "ball")?;
        let [anchor_a, anchor_b] = joint::anchors(&self.anchor, &self.anchors, ends, bodies, path)?;
        let ball = Ball {
            a: body_ref(0, Some(ends.a)),
            anchor_a,
            b: body_ref(1, ends.b),
            anchor_b,
        };
        joint::declare(
            &ball,
            ends,
            ([anchor_a, anchor_b], None),
            bodies,
            i,
            path,
            out,
        )
    }
}
