//! A spring between two bodies, `V = k/2 (|q_a − q_b| − L)²`: a pair term with the spring's
//! radial law.

use super::radial::{PairLaw, Pairs};
use super::{Assembler, Effect, Potential};
use crate::scene::error::{FieldPath, SceneErrorKind};
use crate::scene::names::Flag;
use crate::scene::validate::{Result, err};
use crate::scene::validate::{non_negative, norm, sub};
use serde::Deserialize;

/// `type = "spring"`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpringSpec {
    /// Label in summaries (default `spring`).
    #[serde(default)]
    pub name: Option<String>,
    /// Exactly two bodies.
    pub bodies: Vec<String>,
    /// Stiffness `k ≥ 0`.
    pub stiffness: f64,
    /// Rest length `L ≥ 0` (default: the initial distance).
    #[serde(default)]
    pub rest_length: Option<f64>,
}

impl Effect for SpringSpec {
    const FLAG: Flag = Flag::Springs;
    fn assemble(
        &self,
        cx: &mut Assembler<'_>,
        path: &FieldPath,
        _label: &str,
        _on: bool,
    ) -> Result<Option<Potential<f64>>> {
        let bodies = cx.bodies;
        let bp = path.key("bodies");
        let ends = bodies.select_all(&self.bodies, &bp)?;
        if self.bodies.len() != 2 || ends.len() != 2 {
            return Err(err(
                SceneErrorKind::Value,
                bp,
                "a spring joins exactly two different bodies",
            ));
        }
        let k = non_negative(self.stiffness, &path.key("stiffness"), "stiffness")?;
        let rest = match self.rest_length {
            Some(l) => non_negative(l, &path.key("rest_length"), "rest length")?,
            None => norm(sub(bodies.list[ends[0]].q, bodies.list[ends[1]].q)),
        };
        Ok(Some(Potential::Pairs(Pairs::new(
            vec![(ends[0], ends[1])],
            PairLaw::Spring { stiffness: k, rest },
        ))))
    }
}
