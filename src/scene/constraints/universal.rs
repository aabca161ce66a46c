//! `type = "universal"`: a universal (Cardan) joint, a ball joint whose cross's two arms stay
//! perpendicular — four rows on the slots (`crate::rigid::Universal`).

use super::joint::{self, body_ref};
use super::{Declare, Declared};
use crate::rigid::Universal;
use crate::scene::bodies::Bodies;
use crate::scene::error::FieldPath;
use crate::scene::validate::Result;
use serde::Deserialize;

/// A universal joint between two bodies, or a body and the world (3D).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct UniversalSpec {
    /// A name: the joint's label in messages, its multipliers' CSV columns, and what
    /// `--off NAME` switches off.
    #[serde(default)]
    pub name: Option<String>,
    /// One body (joined to the world) or two; the first must be rigid, and the second too.
    pub bodies: Vec<String>,
    /// The cross's centre in the world at the start.
    #[serde(default)]
    pub anchor: Option<Vec<f64>>,
    /// Or: that point in each body's frame (a world point for the world).
    #[serde(default)]
    pub anchors: Option<Vec<Vec<f64>>>,
    /// The cross's arm on each body, in the world at the start (perpendicular).
    #[serde(default)]
    pub arms: Option<Vec<Vec<f64>>>,
    /// Or: each arm in its body's frame (a world direction for the world).
    #[serde(default)]
    pub axes: Option<Vec<Vec<f64>>>,
}

impl Declare for UniversalSpec {
    fn declare(
        &self,
        i: usize,
        path: &FieldPath,
        bodies: &Bodies,
        out: &mut Vec<Declared>,
    ) -> Result<()> {
        let ends = joint::ends(&self.bodies, bodies, path, "universal")?;
        let [anchor_a, anchor_b] = joint::anchors(&self.anchor, &self.anchors, ends, bodies, path)?;
        if self.arms.is_some() && self.axes.is_some() {
            return Err(crate::scene::validate::err(
                crate::scene::error::SceneErrorKind::Value,
                path.clone(),
                "give `arms` (in the world, at the start) or `axes` (one per end, in its frame), not both",
            ));
        }
        let [axis_a, axis_b] = match (&self.arms, &self.axes) {
            (Some(arms), None) => {
                // Each world arm in its own body's frame.
                let ap = path.key("arms");
                let both = |k: usize| {
                    let one = arms.get(k).cloned();
                    joint::axes(&one, &None, ("arms", "axes"), ends, bodies, &ap.index(k))
                };
                if arms.len() != 2 {
                    return Err(crate::scene::validate::err(
                        crate::scene::error::SceneErrorKind::Dimension,
                        ap,
                        format!("two arms, one per body, not {}", arms.len()),
                    ));
                }
                [both(0)?[0], both(1)?[1]]
            }
            _ => joint::axes(&None, &self.axes, ("arms", "axes"), ends, bodies, path)?,
        };
        let universal = Universal {
            a: body_ref(0, Some(ends.a)),
            anchor_a,
            axis_a,
            b: body_ref(1, ends.b),
            anchor_b,
            axis_b,
        };
        joint::declare(
            &universal,
            ends,
            ([anchor_a, anchor_b], Some(axis_a)),
            bodies,
            i,
            path,
            out,
        )
    }
}
