//! A damper on a slider's displacement, `c d'²` of power: viscous friction between two rigid
//! bodies (or a rigid body and the world) sliding along an axis the first carries. Its exact
//! flow acts along the constraint-consistent direction, as a hinge damper's
//! (`scene/model/hinge_damper.rs`, docs/method.md §12c): a sub-flow of the kick, switched by the
//! `damping` flag.

use super::{Assembler, Effect, Potential};
use crate::scene::error::FieldPath;
use crate::scene::names::Flag;
use crate::scene::validate::{Result, non_negative};
use serde::Deserialize;

/// `type = "slider-damper"`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SliderDamperSpec {
    /// Label in summaries (default `slider-damper`).
    #[serde(default)]
    pub name: Option<String>,
    /// One rigid body (sliding against the world) or two, the first rigid.
    pub bodies: Vec<String>,
    /// A point of the axis in the world at the start (default: the first body's centre).
    #[serde(default)]
    pub anchor: Option<Vec<f64>>,
    /// Or: that point in each body's frame (a world point for the world).
    #[serde(default)]
    pub anchors: Option<Vec<Vec<f64>>>,
    /// The axis in the world at the start.
    #[serde(default)]
    pub axis: Option<Vec<f64>>,
    /// Or: the axis in each body's frame (a world direction for the world).
    #[serde(default)]
    pub axes: Option<Vec<Vec<f64>>>,
    /// `c ≥ 0`, N s/m: the force `−c d'` along the axis.
    pub coefficient: f64,
}

impl Effect for SliderDamperSpec {
    const FLAG: Flag = Flag::Damping;
    fn assemble(
        &self,
        cx: &mut Assembler<'_>,
        path: &FieldPath,
        label: &str,
        on: bool,
    ) -> Result<Option<Potential<f64>>> {
        let displacement = crate::scene::ports::slider_displacement(
            &self.bodies,
            &self.anchor,
            &self.anchors,
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
                .push((crate::rigid::Coordinate::Displacement(displacement), c));
            cx.hinge_damper_labels.push(label.to_owned());
        }
        Ok(None)
    }
}
