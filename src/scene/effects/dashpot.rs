//! A dashpot between two bodies, `p_a' = … − c (v_a − v_b)`, `p_b' = … + c (v_a − v_b)`: a
//! term `c (e_a − e_b)(e_a − e_b)ᵀ ⊗ I` of the `R` in `M = J − R` that damps the relative
//! velocity only (the total momentum is kept), dissipating the power `c |v_a − v_b|²`. Its
//! exact flow (`model/dashpot.rs`) joins the kick of the splitting.

use super::{Assembler, Effect, Potential};
use crate::scene::error::{FieldPath, SceneErrorKind};
use crate::scene::names::Flag;
use crate::scene::validate::{Result, err, non_negative};
use serde::Deserialize;

/// `type = "dashpot"`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DashpotSpec {
    /// Label in summaries (default `dashpot`).
    #[serde(default)]
    pub name: Option<String>,
    /// Exactly two bodies.
    pub bodies: Vec<String>,
    /// Coefficient `c ≥ 0` (force per relative velocity).
    pub coefficient: f64,
}

impl Effect for DashpotSpec {
    const FLAG: Flag = Flag::Damping;
    fn assemble(
        &self,
        cx: &mut Assembler<'_>,
        path: &FieldPath,
        label: &str,
        on: bool,
    ) -> Result<Option<Potential<f64>>> {
        let bp = path.key("bodies");
        let ends = cx.bodies.select_all(&self.bodies, &bp)?;
        if self.bodies.len() != 2 || ends.len() != 2 || ends[0] == ends[1] {
            return Err(err(
                SceneErrorKind::Value,
                bp,
                "a dashpot joins exactly two different bodies (damping against the ground is `type = \"damping\"`)",
            ));
        }
        let c = non_negative(
            self.coefficient,
            &path.key("coefficient"),
            "dashpot coefficient",
        )?;
        if on && c > 0.0 {
            cx.dashpots.push((ends[0], ends[1], c));
            cx.dashpot_labels.push(label.to_owned());
        }
        Ok(None)
    }
}
