//! The scene's effects assembled into terms of `H` (potentials) and of `M` (damping, magnetic
//! field), only those declared and switched on; each effect's own checks and term are in its
//! file under `scene/effects/`.

use super::{Result, bodies::Bodies};
use crate::scene::effects::{Assembler, PotentialTerm};
use crate::scene::error::FieldPath;
use crate::scene::model::{Counter, StructureTerm};
use crate::scene::schema::SceneFile;

/// Effects split by where they go: potential terms, and the merged `M` terms.
pub(super) struct Effects {
    pub(super) potentials: Vec<PotentialTerm>,
    pub(super) damping: Option<StructureTerm<f64>>,
    pub(super) magnetic: Option<StructureTerm<[f64; 3]>>,
    pub(super) disabled: Vec<String>,
    /// Damping declared and on, zero on every body (see `SceneModel::zero_damping`).
    pub(super) zero_damping: bool,
    /// The dashpots that are on, with their merged label.
    pub(super) dashpots: Option<crate::scene::model::Dashpots<f64>>,
    /// The hinge dampers that are on, with their merged label.
    pub(super) hinge_dampers: Option<crate::scene::model::HingeDampers<f64>>,
}

/// Checks every declared effect (switched on or not) and assembles the ones switched on.
/// A potential whose force is not finite at the initial positions (two bodies at one point
/// under a pair law or a spring of non-zero rest length) is refused here, naming the bodies,
/// rather than failing the first step as a Newton failure.
fn finite_at_start(
    potential: &crate::scene::effects::Potential,
    bodies: &Bodies,
    path: &FieldPath,
    label: &str,
) -> Result<()> {
    let d = bodies.dim;
    let q: Vec<f64> = bodies.list.iter().flat_map(|b| b.q[..d].to_vec()).collect();
    let mut grad = vec![0.0; q.len()];
    potential.gradient_add(&q, d, 1.0, &mut grad);
    let bad: Vec<usize> = (0..bodies.list.len())
        .filter(|&b| grad[b * d..b * d + d].iter().any(|g| !g.is_finite()))
        .collect();
    if bad.is_empty() {
        return Ok(());
    }
    let names: Vec<String> = bad
        .iter()
        .take(4)
        .map(|&b| format!("'{}'", bodies.list[b].name))
        .collect();
    let at = |b: usize| &bodies.list[b].q[..d];
    let coincide = bad.len() >= 2 && at(bad[0]) == at(bad[1]);
    Err(super::err(
        crate::scene::error::SceneErrorKind::Value,
        path.clone(),
        format!(
            "{label}: its force is not finite at the initial positions of {}{}{}: a pair law or a spring with a rest length has no direction at zero distance; move them apart",
            names.join(", "),
            if bad.len() > 4 { " and others" } else { "" },
            if coincide {
                format!(" (which coincide at {:?})", at(bad[0]))
            } else {
                String::new()
            }
        ),
    ))
}

/// The spring `½ k_p θ²` and damper `k_d` of each `hinge-servo` input, as the effects they are
/// (labelled `<servo> spring`, `<servo> damper`); its motor torque is the input itself.
fn servo_parts(file: &SceneFile, cx: &mut Assembler<'_>, fx: &mut Effects) -> Result<()> {
    use crate::scene::effects::{EffectSpec, HingeDamperSpec, TorsionSpringSpec};
    use crate::scene::ports::InputSpec;
    let root = FieldPath::root().key("inputs");
    for (i, input) in file.inputs.iter().enumerate() {
        let InputSpec::HingeServo {
            name,
            bodies,
            axis,
            axes,
            stiffness,
            damping,
            ..
        } = input
        else {
            continue;
        };
        let path = root.index(i);
        let mut parts = vec![(
            format!("{name} spring"),
            EffectSpec::TorsionSpring(TorsionSpringSpec {
                name: None,
                bodies: bodies.clone(),
                axis: axis.clone(),
                axes: axes.clone(),
                stiffness: *stiffness,
                rest_angle_deg: None,
            }),
        )];
        crate::scene::validate::non_negative(*damping, &path.key("damping"), "damping")?;
        if *damping > 0.0 {
            parts.push((
                format!("{name} damper"),
                EffectSpec::HingeDamper(HingeDamperSpec {
                    name: None,
                    bodies: bodies.clone(),
                    axis: axis.clone(),
                    axes: axes.clone(),
                    coefficient: *damping,
                }),
            ));
        }
        for (label, part) in parts {
            if let Some(potential) = part.assemble(cx, &path, &label, true)? {
                fx.potentials.push(PotentialTerm {
                    label,
                    kind: part.kind(),
                    potential,
                    counter: Counter::default(),
                });
            }
        }
    }
    Ok(())
}

pub(super) fn assemble_effects(file: &SceneFile, bodies: &Bodies) -> Result<Effects> {
    let n = bodies.list.len();
    let mut fx = Effects {
        potentials: Vec::new(),
        damping: None,
        magnetic: None,
        disabled: Vec::new(),
        zero_damping: false,
        dashpots: None,
        hinge_dampers: None,
    };
    let mut cx = Assembler {
        bodies,
        dim: bodies.dim,
        damping: vec![0.0; n],
        damping_labels: Vec::new(),
        magnetic: vec![[0.0; 3]; n],
        magnetic_labels: Vec::new(),
        dashpots: Vec::new(),
        dashpot_labels: Vec::new(),
        hinge_dampers: Vec::new(),
        hinge_damper_labels: Vec::new(),
    };
    let root = FieldPath::root().key("effects");
    for (i, e) in file.effects.iter().enumerate() {
        let path = root.index(i);
        let kind = e.kind();
        let label = e.label().cloned().unwrap_or_else(|| kind.name().to_owned());
        let on = file.flags.get(e.flag()) && !e.label().is_some_and(|n| file.off.contains(n));
        let potential = e.assemble(&mut cx, &path, &label, on)?;
        if !on {
            fx.disabled
                .push(format!("effects[{i}] {} ({})", label, kind.name()));
            continue;
        }
        if let Some(potential) = potential {
            finite_at_start(&potential, bodies, &path, &label)?;
            fx.potentials.push(PotentialTerm {
                label,
                kind,
                potential,
                counter: Counter::default(),
            });
        }
    }
    servo_parts(file, &mut cx, &mut fx)?;
    let Assembler {
        damping,
        mut damping_labels,
        magnetic,
        mut magnetic_labels,
        dashpots,
        dashpot_labels,
        hinge_dampers,
        hinge_damper_labels,
        ..
    } = cx;
    if !hinge_dampers.is_empty() {
        fx.hinge_dampers = Some(crate::scene::model::HingeDampers {
            label: hinge_damper_labels.join("+"),
            dampers: hinge_dampers,
            counter: Counter::default(),
        });
    }
    if !dashpots.is_empty() {
        fx.dashpots = Some(crate::scene::model::Dashpots {
            label: dashpot_labels.join("+"),
            pairs: dashpots,
            counter: Counter::default(),
        });
    }
    // A damping or field that acts on nothing (zero coefficients, no charge, no bodies) has no
    // term: the model stays conservative (or canonical) and says so.
    if !damping_labels.is_empty() && !damping.iter().any(|&c| c > 0.0) {
        fx.disabled.push(format!(
            "{} (damping: zero on every body, no term)",
            damping_labels.join("+")
        ));
        damping_labels.clear();
        fx.zero_damping = true;
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
