//! Viscous damping of the momenta, `p_b' = … − c v_b`: the `R` of `M = J − R`, merged per body
//! with the other damping effects; its exact flow is part of the free flight
//! (`model/flight.rs`), and it dissipates the power `Σ_b c_b |v_b|²`.

use super::{Assembler, Effect, Potential};
use crate::scene::error::FieldPath;
use crate::scene::names::Flag;
use crate::scene::validate::Result;
use crate::scene::validate::non_negative;
use serde::Deserialize;

/// `type = "damping"`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DampingSpec {
    /// Label in summaries (default `damping`).
    #[serde(default)]
    pub name: Option<String>,
    /// Coefficient `c ≥ 0` (force per velocity).
    pub coefficient: f64,
    /// Bodies it acts on (default: all).
    #[serde(default)]
    pub bodies: Option<Vec<String>>,
}

impl Effect for DampingSpec {
    const FLAG: Flag = Flag::Damping;
    fn assemble(
        &self,
        cx: &mut Assembler<'_>,
        path: &FieldPath,
        label: &str,
        on: bool,
    ) -> Result<Option<Potential<f64>>> {
        let c = non_negative(
            self.coefficient,
            &path.key("coefficient"),
            "damping coefficient",
        )?;
        let list = cx.bodies.select_opt(&self.bodies, &path.key("bodies"))?;
        if on {
            for b in list {
                cx.damping[b] += c;
            }
            cx.damping_labels.push(label.to_owned());
        }
        Ok(None)
    }
}

/// The dissipated power `∇Hᵀ R ∇H = Σ_b c_b |p_b / m_b|²` of per-body coefficients `c`, inverse
/// masses `w` and momenta `p` in `d` dimensions.
pub(crate) fn dissipated_power(c: &[f64], w: &[f64], p: &[f64], d: usize) -> f64 {
    let mut power = 0.0;
    for (b, c) in c.iter().enumerate() {
        let w = w[b];
        for k in 0..d {
            let v = w * p[b * d + k];
            power += c * v * v;
        }
    }
    power
}
