//! The ball (spherical) joint: a point of one body held at a point of the other,
//! `r_A(X_A) − r_B(X_B) = 0` — three linear rows.

use super::{BodyRef, JointKind, coincide};
use crate::error::SetupError;
use crate::rigid::frames::Frames;
use crate::rigid::rows::RowBuilder;

/// A ball joint between `a` and `b` at the anchors given in each body's frame (about its centre
/// of mass; a world anchor is a world point).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ball {
    /// The first body.
    pub a: BodyRef,
    /// Its anchor, in its frame.
    pub anchor_a: [f64; 3],
    /// The second body (or the world).
    pub b: BodyRef,
    /// Its anchor, in its frame.
    pub anchor_b: [f64; 3],
}

impl JointKind for Ball {
    fn name(&self) -> &'static str {
        "ball"
    }
    fn rows(&self, frames: &Frames<'_>) -> Result<Vec<RowBuilder<f64>>, SetupError> {
        let ra = frames.point(self.a, self.anchor_a)?;
        let rb = frames.point(self.b, self.anchor_b)?;
        Ok(coincide(&ra, &rb))
    }
}
