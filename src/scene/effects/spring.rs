//! A spring between two bodies, `V = k/2 (|q_a − q_b| − L)²`: a pair term with the spring's
//! radial law; or from one body to a fixed `point`, `V = k/2 (|q_b − c| − L)²` (a trap with a
//! rest length, without the fake pinned body it would otherwise take).

use super::radial::{PairLaw, Pairs};
use super::trap::Trap;
use super::{Assembler, Effect, Potential};
use crate::scene::error::{FieldPath, SceneErrorKind};
use crate::scene::names::Flag;
use crate::scene::validate::{Result, err};
use crate::scene::validate::{non_negative, norm, sub, vector};
use serde::Deserialize;

/// `type = "spring"`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpringSpec {
    /// Label in summaries (default `spring`).
    #[serde(default)]
    pub name: Option<String>,
    /// Two bodies, or one body and a fixed `point`.
    pub bodies: Vec<String>,
    /// The fixed end, when one body is named: a spring to a point of space.
    #[serde(default)]
    pub point: Option<Vec<f64>>,
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
        let k = non_negative(self.stiffness, &path.key("stiffness"), "stiffness")?;
        if let Some(point) = &self.point {
            if self.bodies.len() != 1 || ends.len() != 1 {
                return Err(err(
                    SceneErrorKind::Value,
                    bp,
                    "a spring with a `point` joins one body to it",
                ));
            }
            let point = vector(point, cx.dim, &path.key("point"))?;
            let rest = match self.rest_length {
                Some(l) => non_negative(l, &path.key("rest_length"), "rest length")?,
                None => norm(sub(bodies.list[ends[0]].q, point)),
            };
            return Ok(Some(Potential::Trap(Trap::anchored(k, point, rest, ends))));
        }
        if self.bodies.len() != 2 || ends.len() != 2 {
            return Err(err(
                SceneErrorKind::Value,
                bp,
                "a spring joins exactly two different bodies, or one body and a fixed `point`",
            ));
        }
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
