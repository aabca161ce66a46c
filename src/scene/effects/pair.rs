//! Pair potentials, `Σ φ(|q_a − q_b|)` over every two bodies of a group, with the radial laws
//! `s / rⁿ`, `−s ln r` and Lennard-Jones' (their formulas and the pairwise kernel are in
//! `radial.rs`).

use super::radial::{PairLaw, Pairs};
use super::{Assembler, Effect, Potential};
use crate::scene::error::{FieldPath, SceneErrorKind};
use crate::scene::names::Flag;
use crate::scene::validate::{Result, err};
use crate::scene::validate::{finite, positive};
use serde::Deserialize;

/// The most pairs a pair potential may visit per evaluation (it has no cut-off).
pub const MAX_PAIRS: usize = 50_000_000;

/// `type = "pair"`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PairSpec {
    /// Label in summaries (default `pair`).
    #[serde(default)]
    pub name: Option<String>,
    /// The group (default: all bodies).
    #[serde(default)]
    pub bodies: Option<Vec<String>>,
    /// `"inverse-power"` (`s / rⁿ`), `"log"` (`−s ln r`) or `"lennard-jones"`
    /// (`4ε ((σ/r)¹² − (σ/r)⁶)`).
    pub law: String,
    /// `s` of `inverse-power` and `log`.
    #[serde(default)]
    pub strength: Option<f64>,
    /// `n > 0` of `inverse-power` (default 1: Coulomb).
    #[serde(default)]
    pub power: Option<f64>,
    /// `ε > 0` of `lennard-jones`.
    #[serde(default)]
    pub epsilon: Option<f64>,
    /// `σ > 0` of `lennard-jones`.
    #[serde(default)]
    pub sigma: Option<f64>,
}

impl Effect for PairSpec {
    const FLAG: Flag = Flag::Pair;
    fn assemble(
        &self,
        cx: &mut Assembler<'_>,
        path: &FieldPath,
        _label: &str,
        _on: bool,
    ) -> Result<Option<Potential<f64>>> {
        let group = cx.bodies.select_opt(&self.bodies, &path.key("bodies"))?;
        let need = |v: &Option<f64>, key: &str| -> Result<f64> {
            v.ok_or_else(|| {
                err(
                    SceneErrorKind::Value,
                    path.key("law"),
                    format!("the law '{}' needs `{key}`", self.law),
                )
            })
        };
        // Parameters of another law are an error, not silently dropped.
        let used: &[&str] = match self.law.as_str() {
            "inverse-power" => &["strength", "power"],
            "log" => &["strength"],
            "lennard-jones" => &["epsilon", "sigma"],
            _ => &["strength", "power", "epsilon", "sigma"],
        };
        for (key, value) in [
            ("strength", &self.strength),
            ("power", &self.power),
            ("epsilon", &self.epsilon),
            ("sigma", &self.sigma),
        ] {
            if value.is_some() && !used.contains(&key) {
                return Err(err(
                    SceneErrorKind::Value,
                    path.key(key),
                    format!(
                        "the law '{}' takes no `{key}` (it takes {})",
                        self.law,
                        used.join(", ")
                    ),
                ));
            }
        }
        let law = match self.law.as_str() {
            "inverse-power" => PairLaw::InversePower {
                strength: finite(need(&self.strength, "strength")?, &path.key("strength"))?,
                power: positive(self.power.unwrap_or(1.0), &path.key("power"), "power")?,
            },
            "log" => PairLaw::Log {
                strength: finite(need(&self.strength, "strength")?, &path.key("strength"))?,
            },
            "lennard-jones" => PairLaw::LennardJones {
                epsilon: positive(
                    need(&self.epsilon, "epsilon")?,
                    &path.key("epsilon"),
                    "epsilon",
                )?,
                sigma: positive(need(&self.sigma, "sigma")?, &path.key("sigma"), "sigma")?,
            },
            other => {
                return Err(err(
                    SceneErrorKind::Value,
                    path.key("law"),
                    format!("unknown law '{other}' (inverse-power, log, lennard-jones)"),
                ));
            }
        };
        let count = group.len() * group.len().saturating_sub(1) / 2;
        if count > MAX_PAIRS {
            return Err(err(
                SceneErrorKind::Unsupported,
                path.key("bodies"),
                format!(
                    "{} bodies make {count} pairs; a pair potential visits every pair each evaluation (no cut-off), limit {MAX_PAIRS}: use a smaller group",
                    group.len()
                ),
            ));
        }
        let mut pairs = Vec::with_capacity(count);
        for (x, &a) in group.iter().enumerate() {
            for &b in &group[x + 1..] {
                pairs.push((a, b));
            }
        }
        Ok(Some(Potential::Pairs(Pairs::new(pairs, law))))
    }
}
