//! The universal (Cardan) joint: a ball joint whose two cross axes stay perpendicular,
//! `a_A · b_B = 0` — four rows.

use super::{BodyRef, JointKind, coincide, dot_row, unit_axis};
use crate::error::SetupError;
use crate::rigid::frames::Frames;
use crate::rigid::rows::RowBuilder;

/// A universal joint between `a` and `b` at the anchors, with the cross's arms `axis_a` (in
/// `a`'s frame) and `axis_b` (in `b`'s frame), perpendicular.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Universal {
    /// The first body.
    pub a: BodyRef,
    /// Its anchor, in its frame.
    pub anchor_a: [f64; 3],
    /// Its arm of the cross, in its frame.
    pub axis_a: [f64; 3],
    /// The second body (or the world).
    pub b: BodyRef,
    /// Its anchor, in its frame.
    pub anchor_b: [f64; 3],
    /// Its arm of the cross, in its frame.
    pub axis_b: [f64; 3],
}

impl JointKind for Universal {
    fn name(&self) -> &'static str {
        "universal"
    }
    /// Refused in a planar model (its cross axes leave the plane).
    fn rows(&self, frames: &Frames<'_>) -> Result<Vec<RowBuilder<f64>>, SetupError> {
        if frames.dim() == 2 {
            return Err(SetupError::Dimension {
                what: "a universal joint needs a 3D model (in the plane its axes would leave it)"
                    .to_owned(),
            });
        }
        let mut rows = coincide(
            &frames.point(self.a, self.anchor_a)?,
            &frames.point(self.b, self.anchor_b)?,
        );
        let a = frames.axis(self.a, unit_axis("universal", self.axis_a)?)?;
        let b = frames.axis(self.b, unit_axis("universal", self.axis_b)?)?;
        rows.push(dot_row(&a, &b, 0.0));
        Ok(rows)
    }
}
