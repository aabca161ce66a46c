//! The hinge (revolute) joint: a ball joint whose bodies also share an axis,
//! `a_A · u_B = 0`, `a_A · v_B = 0` with `u_B, v_B` perpendicular to the axis in `B` — five
//! rows, independent (not `a_A × a_B = 0`, three rows of rank two).

use super::{BodyRef, JointKind, coincide, dot_row, perpendiculars, planar_axis, unit_axis};
use crate::error::SetupError;
use crate::rigid::frames::Frames;
use crate::rigid::rows::RowBuilder;

/// A hinge between `a` and `b` at the anchors, turning about `axis_a` (in `a`'s frame), which
/// stays along `axis_b` (in `b`'s frame).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hinge {
    /// The first body.
    pub a: BodyRef,
    /// Its anchor, in its frame.
    pub anchor_a: [f64; 3],
    /// The hinge's axis in its frame.
    pub axis_a: [f64; 3],
    /// The second body (or the world).
    pub b: BodyRef,
    /// Its anchor, in its frame.
    pub anchor_b: [f64; 3],
    /// The hinge's axis in its frame.
    pub axis_b: [f64; 3],
}

impl JointKind for Hinge {
    fn name(&self) -> &'static str {
        "hinge"
    }
    /// In a planar model the axes must be the normal `z`: the pin's two rows remain.
    fn rows(&self, frames: &Frames<'_>) -> Result<Vec<RowBuilder<f64>>, SetupError> {
        planar_axis(frames, "hinge", self.axis_a, true)?;
        planar_axis(frames, "hinge", self.axis_b, true)?;
        let mut rows = coincide(
            &frames.point(self.a, self.anchor_a)?,
            &frames.point(self.b, self.anchor_b)?,
        );
        let axis_a = frames.axis(self.a, unit_axis("hinge", self.axis_a)?)?;
        let (u, v) = perpendiculars(unit_axis("hinge", self.axis_b)?);
        for w in [u, v] {
            rows.push(dot_row(&axis_a, &frames.axis(self.b, w)?, 0.0));
        }
        Ok(rows)
    }
}
