//! A uniform magnetic field on charged bodies, `p_b' = … + e_b v_b × B`: a non-canonical `J`,
//! merged per body as `e_b B` with the other fields; its exact flow (a rotation of the
//! momentum) is part of the free flight (`model/flight.rs`). It does no work.

use super::{Assembler, Effect, Potential};
use crate::scene::error::{FieldPath, SceneErrorKind};
use crate::scene::names::Flag;
use crate::scene::validate::{Result, err};
use crate::scene::validate::{finite, vector};
use serde::Deserialize;

/// `type = "magnetic"`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MagneticSpec {
    /// Label in summaries (default `magnetic`).
    #[serde(default)]
    pub name: Option<String>,
    /// `B`: one entry (`B_z`, out of the plane) in 2D, three in 3D.
    pub field: Vec<f64>,
    /// Bodies it acts on (default: all; bodies without charge feel nothing).
    #[serde(default)]
    pub bodies: Option<Vec<String>>,
}

impl Effect for MagneticSpec {
    const FLAG: Flag = Flag::Magnetic;
    fn assemble(
        &self,
        cx: &mut Assembler<'_>,
        path: &FieldPath,
        label: &str,
        on: bool,
    ) -> Result<Option<Potential<f64>>> {
        let field = &self.field;
        let fp = path.key("field");
        let b = match (cx.dim, field.len()) {
            (2, 1) => [0.0, 0.0, finite(field[0], &fp.index(0))?],
            (3, 3) => vector(field, 3, &fp)?,
            (d, len) => {
                return Err(err(
                    SceneErrorKind::Dimension,
                    fp,
                    format!(
                        "{len} entries: the field has 1 entry (B_z) in 2D and 3 in 3D (dim = {d})"
                    ),
                ));
            }
        };
        let list = cx.bodies.select_opt(&self.bodies, &path.key("bodies"))?;
        if on {
            for i in list {
                let e = cx.bodies.list[i].charge;
                for k in 0..3 {
                    cx.magnetic[i][k] += e * b[k];
                }
            }
            cx.magnetic_labels.push(label.to_owned());
        }
        Ok(None)
    }
}
