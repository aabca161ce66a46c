//! Pair potentials, `Σ φ(|q_a − q_b|)` over every two bodies of a group, with the radial laws
//! `s / rⁿ`, `−s ln r` and Lennard-Jones' (and the spring's, for [`super::spring`]).

use super::{Assembler, Effect, Potential, PotentialOps};
use crate::real::Real;
use crate::scene::compile::validate::{finite, positive};
use crate::scene::compile::{MAX_PAIRS, Result, err};
use crate::scene::error::{FieldPath, SceneErrorKind};
use crate::scene::schema::Flag;
use serde::Deserialize;

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
    fn label(&self) -> Option<&String> {
        self.name.as_ref()
    }
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
        Ok(Some(Potential::Pairs(Pairs { pairs, law })))
    }
}

/// A radial law `φ(r)` of a pair potential.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum PairLaw<T = f64> {
    /// `s / rⁿ`.
    InversePower { strength: T, power: T },
    /// `−s ln r`.
    Log { strength: T },
    /// `4ε ((σ/r)¹² − (σ/r)⁶)`.
    LennardJones { epsilon: T, sigma: T },
    /// `k/2 (r − L)²` (a spring).
    Spring { stiffness: T, rest: T },
}

impl<T: Real> PairLaw<T> {
    /// `(φ(r), φ'(r)/r, φ''(r))`.
    #[inline]
    pub(super) fn eval(self, r: T) -> (T, T, T) {
        // One division per pair: everything in powers of 1/r.
        let inv_r = T::lit(1.0) / r;
        let inv_r2 = inv_r * inv_r;
        match self {
            PairLaw::InversePower { strength, power } => {
                // Integer powers (Coulomb, dipoles) by multiplication: powf costs ~10x more.
                let rn = if power == T::lit(1.0) {
                    inv_r
                } else if power.fract() == T::lit(0.0) && power <= T::lit(32.0) {
                    inv_r.powi(num_traits::ToPrimitive::to_i32(&power).unwrap_or(1))
                } else {
                    r.powf(-power)
                };
                let phi = strength * rn;
                (
                    phi,
                    -power * phi * inv_r2,
                    power * (power + T::lit(1.0)) * phi * inv_r2,
                )
            }
            PairLaw::Log { strength } => {
                (-strength * r.ln(), -strength * inv_r2, strength * inv_r2)
            }
            PairLaw::LennardJones { epsilon, sigma } => {
                let s2 = sigma * sigma * inv_r2;
                let s6 = s2 * s2 * s2;
                let s12 = s6 * s6;
                (
                    T::lit(4.0) * epsilon * (s12 - s6),
                    T::lit(4.0) * epsilon * (-T::lit(12.0) * s12 + T::lit(6.0) * s6) * inv_r2,
                    T::lit(4.0) * epsilon * (T::lit(156.0) * s12 - T::lit(42.0) * s6) * inv_r2,
                )
            }
            PairLaw::Spring { stiffness, rest } => super::spring::law(stiffness, rest, r, inv_r),
        }
    }
}

/// `Σ φ(|q_a − q_b|)` over the listed pairs.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Pairs<T> {
    pairs: Vec<(usize, usize)>,
    law: PairLaw<T>,
}

impl<T> Pairs<T> {
    /// The pairs `(a, b)` under `law`.
    pub(super) fn new(pairs: Vec<(usize, usize)>, law: PairLaw<T>) -> Self {
        Self { pairs, law }
    }
}

#[inline]
fn distance<T: Real>(q: &[T], d: usize, a: usize, b: usize) -> T {
    let mut s = T::lit(0.0);
    for k in 0..d {
        let z = q[a * d + k] - q[b * d + k];
        s = s + (z * z);
    }
    s.sqrt()
}

impl<T: Real> PotentialOps<T> for Pairs<T> {
    fn energy(&self, q: &[T], d: usize) -> T {
        let mut e = T::lit(0.0);
        for &(a, b) in &self.pairs {
            e = e + (self.law.eval(distance(q, d, a, b)).0);
        }
        e
    }
    fn gradient_add(&self, q: &[T], d: usize, alpha: T, out: &mut [T]) {
        for &(a, b) in &self.pairs {
            let r = distance(q, d, a, b);
            let s = alpha * self.law.eval(r).1;
            for k in 0..d {
                let z = s * (q[a * d + k] - q[b * d + k]);
                out[a * d + k] = out[a * d + k] + (z);
                out[b * d + k] = out[b * d + k] - (z);
            }
        }
    }
    fn hessian_apply_add(&self, q: &[T], d: usize, v: &[T], out: &mut [T]) {
        for &(a, b) in &self.pairs {
            let r = distance(q, d, a, b);
            let (_, d1, d2) = self.law.eval(r);
            // ∇²φ u = (φ'/r) u + (φ'' − φ'/r) (r̂·u) r̂, u = v_a − v_b.
            let mut ru = T::lit(0.0);
            for k in 0..d {
                ru = ru + ((q[a * d + k] - q[b * d + k]) * (v[a * d + k] - v[b * d + k]));
            }
            // A zero-length spring has d2 = d1: no radial term (and no 0/0 at r = 0).
            let s = if d2 == d1 {
                T::lit(0.0)
            } else {
                (d2 - d1) * ru / (r * r)
            };
            for k in 0..d {
                let z = d1 * (v[a * d + k] - v[b * d + k]) + s * (q[a * d + k] - q[b * d + k]);
                out[a * d + k] = out[a * d + k] + (z);
                out[b * d + k] = out[b * d + k] - (z);
            }
        }
    }
    /// Radial laws are not quadratic in `q` (a zero-length spring is, but is not told apart).
    fn is_quadratic(&self) -> bool {
        false
    }
}

impl Pairs<f64> {
    pub(crate) fn with_scalar<U: Real>(&self) -> Pairs<U> {
        let c = U::lit;
        let law = match self.law {
            PairLaw::InversePower { strength, power } => PairLaw::InversePower {
                strength: c(strength),
                power: c(power),
            },
            PairLaw::Log { strength } => PairLaw::Log {
                strength: c(strength),
            },
            PairLaw::LennardJones { epsilon, sigma } => PairLaw::LennardJones {
                epsilon: c(epsilon),
                sigma: c(sigma),
            },
            PairLaw::Spring { stiffness, rest } => PairLaw::Spring {
                stiffness: c(stiffness),
                rest: c(rest),
            },
        };
        Pairs {
            pairs: self.pairs.clone(),
            law,
        }
    }
}
