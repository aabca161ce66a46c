//! A damper on a hinge's angle, `c θ'²` of power: a joint's viscous friction between two rigid
//! bodies (or a rigid body and the world) about an axis they share. Its exact flow acts along
//! the constraint-consistent direction (`scene/model/hinge_damper.rs`, docs/method.md §12c):
//! a sub-flow of the kick, like the dashpots, switched by the `damping` flag.

use super::{Assembler, Effect, Potential};
use crate::scene::error::FieldPath;
use crate::scene::names::Flag;
use crate::scene::validate::{Result, non_negative};
use serde::Deserialize;

/// `type = "hinge-damper"`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HingeDamperSpec {
    /// Label in summaries (default `hinge-damper`).
    #[serde(default)]
    pub name: Option<String>,
    /// One rigid body (turning against the world) or two, the first rigid.
    pub bodies: Vec<String>,
    /// The axis in the world at the start.
    #[serde(default)]
    pub axis: Option<Vec<f64>>,
    /// Or: the axis in each body's frame (a world direction for the world).
    #[serde(default)]
    pub axes: Option<Vec<Vec<f64>>>,
    /// `c ≥ 0`, N m s per radian: the torque `−c θ'`.
    pub coefficient: f64,
}

impl Effect for HingeDamperSpec {
    const FLAG: Flag = Flag::Damping;
    fn assemble(
        &self,
        cx: &mut Assembler<'_>,
        path: &FieldPath,
        label: &str,
        on: bool,
    ) -> Result<Option<Potential<f64>>> {
        let angle = crate::scene::ports::hinge_angle(
            &self.bodies,
            &self.axis,
            &self.axes,
            cx.bodies,
            path,
        )?;
        let c = non_negative(
            self.coefficient,
            &path.key("coefficient"),
            "damper coefficient",
        )?;
        if on && c > 0.0 {
            cx.hinge_dampers
                .push((crate::rigid::Coordinate::Angle(angle), c));
            cx.hinge_damper_labels.push(label.to_owned());
        }
        Ok(None)
    }
}
