//! A damper along the line between two bodies' points, `c r'²` of power (`r` their distance):
//! the damper of a spring-damper element (a `spring` beside it is its spring), the force
//! `−c r'` along the line on the first body and its opposite on the second. Unlike a `dashpot`
//! (which damps the whole relative velocity of two centres) it leaves motion across the line
//! free: two bodies turning together about an axis feel nothing. Its exact flow acts along the
//! constraint-consistent direction, as a hinge damper's (`scene/model/hinge_damper.rs`): a
//! sub-flow of the kick, switched by the `damping` flag.

use super::{Assembler, Effect, Potential};
use crate::rigid::{BodyRef, Coordinate, Distance};
use crate::scene::constraints::joint;
use crate::scene::error::{FieldPath, SceneErrorKind};
use crate::scene::names::Flag;
use crate::scene::validate::{Result, err, non_negative};
use serde::Deserialize;

/// `type = "line-damper"`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LineDamperSpec {
    /// Label in summaries (default `line-damper`).
    #[serde(default)]
    pub name: Option<String>,
    /// Two bodies, or one (against a world point).
    pub bodies: Vec<String>,
    /// The line's ends, one per body in its own frame (a world point for the world); default
    /// each body's centre (needed with one body).
    #[serde(default)]
    pub anchors: Option<Vec<Vec<f64>>>,
    /// `c ≥ 0`, N s/m: the force `−c r'` along the line.
    pub coefficient: f64,
}

impl Effect for LineDamperSpec {
    const FLAG: Flag = Flag::Damping;
    fn assemble(
        &self,
        cx: &mut Assembler<'_>,
        path: &FieldPath,
        label: &str,
        on: bool,
    ) -> Result<Option<Potential<f64>>> {
        let ends = joint::ends(&self.bodies, cx.bodies, path, "line-damper")?;
        let [pa, pb] = match (&self.anchors, ends.b) {
            (Some(_), _) => joint::anchors(&None, &self.anchors, ends, cx.bodies, path)?,
            (None, Some(_)) => [ends.place[0].point([0.0; 3]), ends.place[1].point([0.0; 3])],
            (None, None) => {
                return Err(err(
                    SceneErrorKind::Value,
                    path.key("anchors"),
                    "a line damper on one body needs `anchors`: the point in its frame and the world point",
                ));
            }
        };
        let entries = cx.bodies.entries(&ends.list());
        let frames = cx.bodies.frames(&entries);
        let b = ends.b.map_or(BodyRef::World, |_| BodyRef::Body(1));
        let distance = Distance::of(BodyRef::Body(0), pa, b, pb, &frames)
            .map_err(|e| err(SceneErrorKind::Value, path.clone(), e.to_string()))?;
        let c = non_negative(
            self.coefficient,
            &path.key("coefficient"),
            "damper coefficient",
        )?;
        if on && c > 0.0 {
            cx.hinge_dampers.push((Coordinate::Distance(distance), c));
            cx.hinge_damper_labels.push(label.to_owned());
        }
        Ok(None)
    }
}
