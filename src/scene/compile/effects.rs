//! The scene's effects assembled into terms of `H` (potentials) and of `M` (damping, magnetic
//! field), only those declared and switched on.

use super::{
    MAX_PAIRS, Result,
    bodies::Bodies,
    err,
    validate::{finite, non_negative, norm, positive, sub, vector, vector_or},
};
use crate::scene::error::{FieldPath, SceneErrorKind};
use crate::scene::model::{Counter, EffectKind, PairLaw, Potential, PotentialTerm, StructureTerm};
use crate::scene::schema::{EffectSpec, SceneFile};

/// Effects split by where they go: potential terms, and the merged `M` terms.
pub(super) struct Effects {
    pub(super) potentials: Vec<PotentialTerm>,
    pub(super) damping: Option<StructureTerm<f64>>,
    pub(super) magnetic: Option<StructureTerm<[f64; 3]>>,
    pub(super) disabled: Vec<String>,
}

pub(super) fn assemble_effects(file: &SceneFile, bodies: &Bodies) -> Result<Effects> {
    let dim = bodies.dim;
    let flags = &file.flags;
    let n = bodies.list.len();
    let mut fx = Effects {
        potentials: Vec::new(),
        damping: None,
        magnetic: None,
        disabled: Vec::new(),
    };
    let (mut damping, mut damping_labels) = (vec![0.0; n], Vec::new());
    let (mut magnetic, mut magnetic_labels) = (vec![[0.0; 3]; n], Vec::new());
    let root = FieldPath::root().key("effects");
    for (i, e) in file.effects.iter().enumerate() {
        let path = root.index(i);
        let (kind, name, on) = match e {
            EffectSpec::Gravity { name, .. } => (EffectKind::Gravity, name, flags.gravity),
            EffectSpec::Spring { name, .. } => (EffectKind::Spring, name, flags.springs),
            EffectSpec::Pair { name, .. } => (EffectKind::Pair, name, flags.pair),
            EffectSpec::Trap { name, .. } => (EffectKind::Trap, name, flags.trap),
            EffectSpec::Damping { name, .. } => (EffectKind::Damping, name, flags.damping),
            EffectSpec::Magnetic { name, .. } => (EffectKind::Magnetic, name, flags.magnetic),
        };
        let label = name.clone().unwrap_or_else(|| kind.name().to_owned());
        // Validate even what is switched off: a flag must not hide an error in the file.
        let potential = match e {
            EffectSpec::Gravity { g, bodies: sel, .. } => {
                let g = vector(g, dim, &path.key("g"))?;
                let forces = bodies
                    .select_opt(sel, &path.key("bodies"))?
                    .into_iter()
                    .map(|b| {
                        let m = bodies.list[b].mass;
                        (b, g.map(|x| m * x))
                    })
                    .collect();
                Some(Potential::Gravity { forces })
            }
            EffectSpec::Spring {
                bodies: sel,
                stiffness,
                rest_length,
                ..
            } => {
                let bp = path.key("bodies");
                let ends = bodies.select_all(sel, &bp)?;
                if sel.len() != 2 || ends.len() != 2 {
                    return Err(err(
                        SceneErrorKind::Value,
                        bp,
                        "a spring joins exactly two different bodies",
                    ));
                }
                let k = non_negative(*stiffness, &path.key("stiffness"), "stiffness")?;
                let rest = match rest_length {
                    Some(l) => non_negative(*l, &path.key("rest_length"), "rest length")?,
                    None => norm(sub(bodies.list[ends[0]].q, bodies.list[ends[1]].q)),
                };
                Some(Potential::Pairs {
                    pairs: vec![(ends[0], ends[1])],
                    law: PairLaw::Spring { stiffness: k, rest },
                })
            }
            EffectSpec::Pair {
                bodies: sel,
                law,
                strength,
                power,
                epsilon,
                sigma,
                ..
            } => {
                let group = bodies.select_opt(sel, &path.key("bodies"))?;
                let need = |v: &Option<f64>, key: &str| -> Result<f64> {
                    v.ok_or_else(|| {
                        err(
                            SceneErrorKind::Value,
                            path.key("law"),
                            format!("the law '{law}' needs `{key}`"),
                        )
                    })
                };
                // Parameters of another law are an error, not silently dropped.
                let used: &[&str] = match law.as_str() {
                    "inverse-power" => &["strength", "power"],
                    "log" => &["strength"],
                    "lennard-jones" => &["epsilon", "sigma"],
                    _ => &["strength", "power", "epsilon", "sigma"],
                };
                for (key, value) in [
                    ("strength", strength),
                    ("power", power),
                    ("epsilon", epsilon),
                    ("sigma", sigma),
                ] {
                    if value.is_some() && !used.contains(&key) {
                        return Err(err(
                            SceneErrorKind::Value,
                            path.key(key),
                            format!(
                                "the law '{law}' takes no `{key}` (it takes {})",
                                used.join(", ")
                            ),
                        ));
                    }
                }
                let law = match law.as_str() {
                    "inverse-power" => PairLaw::InversePower {
                        strength: finite(need(strength, "strength")?, &path.key("strength"))?,
                        power: positive(power.unwrap_or(1.0), &path.key("power"), "power")?,
                    },
                    "log" => PairLaw::Log {
                        strength: finite(need(strength, "strength")?, &path.key("strength"))?,
                    },
                    "lennard-jones" => PairLaw::LennardJones {
                        epsilon: positive(
                            need(epsilon, "epsilon")?,
                            &path.key("epsilon"),
                            "epsilon",
                        )?,
                        sigma: positive(need(sigma, "sigma")?, &path.key("sigma"), "sigma")?,
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
                Some(Potential::Pairs { pairs, law })
            }
            EffectSpec::Trap {
                stiffness,
                center,
                bodies: sel,
                ..
            } => Some(Potential::Trap {
                stiffness: non_negative(*stiffness, &path.key("stiffness"), "stiffness")?,
                center: vector_or(center, dim, &path.key("center"), [0.0; 3])?,
                bodies: bodies.select_opt(sel, &path.key("bodies"))?,
            }),
            EffectSpec::Damping {
                coefficient,
                bodies: sel,
                ..
            } => {
                let c = non_negative(
                    *coefficient,
                    &path.key("coefficient"),
                    "damping coefficient",
                )?;
                let list = bodies.select_opt(sel, &path.key("bodies"))?;
                if on {
                    for b in list {
                        damping[b] += c;
                    }
                    damping_labels.push(label.clone());
                }
                None
            }
            EffectSpec::Magnetic {
                field, bodies: sel, ..
            } => {
                let fp = path.key("field");
                let b = match (dim, field.len()) {
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
                let list = bodies.select_opt(sel, &path.key("bodies"))?;
                if on {
                    for i in list {
                        let e = bodies.list[i].charge;
                        for k in 0..3 {
                            magnetic[i][k] += e * b[k];
                        }
                    }
                    magnetic_labels.push(label.clone());
                }
                None
            }
        };
        if !on {
            fx.disabled
                .push(format!("effects[{i}] {} ({})", label, kind.name()));
            continue;
        }
        if let Some(potential) = potential {
            fx.potentials.push(PotentialTerm {
                label,
                kind,
                potential,
                counter: Counter::default(),
            });
        }
    }
    // A damping or field that acts on nothing (zero coefficients, no charge, no bodies) has no
    // term: the model stays conservative (or canonical) and says so.
    if !damping_labels.is_empty() && !damping.iter().any(|&c| c > 0.0) {
        fx.disabled.push(format!(
            "{} (damping: zero on every body, no term)",
            damping_labels.join("+")
        ));
        damping_labels.clear();
    }
    if !magnetic_labels.is_empty() && !magnetic.iter().any(|b| *b != [0.0; 3]) {
        fx.disabled.push(format!(
            "{} (magnetic: no charged body, no term)",
            magnetic_labels.join("+")
        ));
        magnetic_labels.clear();
    }
    if !damping_labels.is_empty() {
        fx.damping = Some(StructureTerm {
            label: damping_labels.join("+"),
            per_body: damping,
            counter: Counter::default(),
        });
    }
    if !magnetic_labels.is_empty() {
        fx.magnetic = Some(StructureTerm {
            label: magnetic_labels.join("+"),
            per_body: magnetic,
            counter: Counter::default(),
        });
    }
    Ok(fx)
}
