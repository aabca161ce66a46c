//! The slider (prismatic) joint: the bodies keep their relative orientation and move apart
//! along one axis only. Orientation: `d_A1·f_2 = 0`, `d_A1·f_3 = 0`, `d_A2·f_3 = 0`, with
//! `f_j = Q_B Q_B0ᵀ Q_A0 e_j` where `A`'s director `j` would be if it turned with `B` (three
//! bilinear rows, independent where they hold); translation: `(r_B − r_A)·u_A` and
//! `(r_B − r_A)·v_A` at their initial values, `u_A, v_A ⟂` the axis in `A` (two rows).

use super::{BodyRef, JointKind, dot_row, perpendiculars, planar_axis, unit_axis};
use crate::error::SetupError;
use crate::rigid::frames::Frames;
use crate::rigid::rows::RowBuilder;

/// A slider between `a` and `b` along `axis_a` (in `a`'s frame) through the anchors.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Slider {
    /// The first body.
    pub a: BodyRef,
    /// Its anchor, in its frame.
    pub anchor_a: [f64; 3],
    /// The sliding axis, in its frame.
    pub axis_a: [f64; 3],
    /// The second body (or the world).
    pub b: BodyRef,
    /// Its anchor, in its frame.
    pub anchor_b: [f64; 3],
}

impl JointKind for Slider {
    fn name(&self) -> &'static str {
        "slider"
    }
    /// In a planar model the axis must lie in the plane: one row of orientation and one across
    /// the axis remain.
    fn rows(&self, frames: &Frames<'_>) -> Result<Vec<RowBuilder<f64>>, SetupError> {
        planar_axis(frames, "slider", self.axis_a, false)?;
        let q0 = frames.initial_positions();
        // Orientation: A's directors against where they would be turning with B.
        let da = frames.directors(self.a)?;
        let f: Vec<_> = (0..3)
            .map(|j| frames.follow(self.b, da[j].at(q0)))
            .collect::<Result<_, _>>()?;
        let mut rows = vec![
            dot_row(&da[0], &f[1], 0.0),
            dot_row(&da[0], &f[2], 0.0),
            dot_row(&da[1], &f[2], 0.0),
        ];
        // Translation: no motion across the axis.
        let (u, v) = perpendiculars(unit_axis("slider", self.axis_a)?);
        let ra = frames.point(self.a, self.anchor_a)?;
        let rb = frames.point(self.b, self.anchor_b)?;
        let mut gap = rb.clone();
        gap.constant = core::array::from_fn(|k| rb.constant[k] - ra.constant[k]);
        gap.terms.extend(ra.terms.iter().map(|&(s, c)| (s, -c)));
        for w in [u, v] {
            let across = frames.axis(self.a, w)?;
            let value = crate::rigid::pose::dot(gap.at(q0), across.at(q0));
            rows.push(dot_row(&gap, &across, value));
        }
        Ok(rows)
    }
}
