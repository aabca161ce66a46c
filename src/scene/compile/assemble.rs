//! The first half of compiling a scene: its bodies, constraints and effects assembled into a
//! model, the initial state and its checks, and the order the scheme is raised to. The second
//! half (the scheme's flow, the run) is `compile_impl`; the two are apart so that what needs the
//! model alone (a unit test, an analysis) does not compile every flow a scene can run.

use super::bodies::expand_bodies;
use super::constraints::{check_independent, constraint_term, constraint_terms, drop_dependent};
use super::effects::assemble_effects;
use super::initial::{ROUND_OFF_RATIO, constraint_offset, off_constraints, project_initial};
use super::scheme::{choose_scheme, plan};
use super::{Raise, Result, check_off_names, columns, err, gravity_notes};
use crate::scene::bodies::Bodies;
use crate::scene::error::{FieldPath, SceneErrorKind};
use crate::scene::model::{ConstraintTerm, SceneModel};
use crate::scene::ports::{ConstraintRows, compile_inputs};
use crate::scene::run::RunPlan;
use crate::scene::schema::{Method, Redundant, SceneFile};
use crate::vector::Vector;
use faer::Col;
use std::sync::Arc;

/// A scene's model, initial state and what compiling it decided, before any flow is built.
pub(super) struct Assembled {
    pub(super) dim: usize,
    pub(super) bodies: Bodies,
    pub(super) model: Arc<SceneModel>,
    pub(super) x0: Col<f64>,
    pub(super) run_plan: RunPlan,
    pub(super) steps: usize,
    pub(super) disabled: Vec<String>,
    pub(super) effects: Vec<(String, String)>,
    pub(super) dropped_constraints: Vec<String>,
    /// The constraint rows as declared and as assembled (what outputs name).
    pub(super) rows: ConstraintRows,
    pub(super) initial_projection: Option<(f64, f64)>,
    pub(super) notes: Vec<String>,
    pub(super) raise: Raise,
    pub(super) order: u32,
    /// The scheme is a splitting (not an implicit one).
    pub(super) splitting: bool,
}

/// Assembles a scene of bodies (not a built-in model): see the module docs. `backward` lets a
/// composition run damping backwards (reference runs).
pub(super) fn assemble(file: &SceneFile, backward: bool) -> Result<Assembled> {
    let root = FieldPath::root();
    let dim = match file.dim {
        Some(d @ (2 | 3)) => d,
        Some(d) => {
            return Err(err(
                SceneErrorKind::Dimension,
                root.key("dim"),
                format!("dim = {d}: scenes are 2- or 3-dimensional"),
            ));
        }
        None => {
            return Err(err(
                SceneErrorKind::Syntax,
                root.key("dim"),
                "missing `dim` (2 or 3)",
            ));
        }
    };
    let (run_plan, profile) = plan(&file.integrator, &file.flags)?;
    let steps = run_plan.total_steps();
    let (bodies, generated) = expand_bodies(file, dim)?;
    let mut disabled = Vec::new();
    check_off_names(file)?;
    // The terms as declared (every constraint on): outputs number their rows.
    let all_on = if file.off.is_empty() {
        None
    } else {
        let mut all = file.clone();
        all.off.clear();
        Some(constraint_terms(
            &all,
            &bodies,
            generated.clone(),
            &mut Vec::new(),
        )?)
    };
    let constraints = constraint_terms(file, &bodies, generated, &mut disabled)?;
    let declared: Vec<(String, FieldPath, usize)> = all_on
        .as_ref()
        .unwrap_or(&constraints)
        .iter()
        .map(|(kind, label, path)| (label.clone(), path.clone(), kind.rows(dim)))
        .collect();
    let constraints = if file.flags.constraints {
        constraints
    } else {
        // A rigid body's own rows (`QᵀQ = I`) are part of the body, not a constraint a flag
        // switches off: without them its directors would leave the rotations.
        let (own, off): (Vec<_>, Vec<_>) = constraints
            .into_iter()
            .partition(|(c, _, _)| c.info().kind() == "directors");
        if !off.is_empty() {
            disabled.push(format!("{} constraints", off.len()));
        }
        own
    };
    let fx = assemble_effects(file, &bodies)?;
    disabled.extend(fx.disabled);
    let mut row = 0;
    let terms: Vec<ConstraintTerm> = constraints
        .into_iter()
        .map(|(kind, label, path)| {
            let t = ConstraintTerm {
                kind,
                row,
                label,
                path,
            };
            row += t.rows(dim);
            t
        })
        .collect();
    let effects: Vec<(String, String)> =
        std::iter::once(("kinetic".to_owned(), "kinetic".to_owned()))
            .chain(
                fx.potentials
                    .iter()
                    .map(|t| (t.label.clone(), t.kind.name().to_owned())),
            )
            .chain(
                fx.damping
                    .iter()
                    .map(|t| (t.label.clone(), "damping".to_owned())),
            )
            .chain(
                fx.dashpots
                    .iter()
                    .map(|t| (t.label.clone(), "dashpot".to_owned())),
            )
            .chain(
                fx.hinge_dampers
                    .iter()
                    .map(|t| (t.label.clone(), t.kind().to_owned())),
            )
            .chain(
                fx.magnetic
                    .iter()
                    .map(|t| (t.label.clone(), "magnetic".to_owned())),
            )
            .collect();
    let masses: Vec<f64> = bodies.list.iter().map(|b| b.mass).collect();
    let mut model = SceneModel::new(
        dim,
        masses,
        fx.potentials,
        terms,
        fx.damping,
        fx.magnetic,
        profile,
    );
    model.inputs = compile_inputs(&file.inputs, &bodies, dim, file.base_dir.as_deref())?;
    model.zero_damping = fx.zero_damping && fx.dashpots.is_none() && fx.hinge_dampers.is_none();
    model.dashpots = fx.dashpots;
    model.hinge_dampers = fx.hinge_dampers;
    let splitting = !matches!(
        file.integrator.scheme,
        Method::DiscreteGradient | Method::Midpoint | Method::Modified
    );
    let dropped_constraints = match file.integrator.redundant {
        Redundant::Refuse => Vec::new(),
        Redundant::DropDependent => {
            let q0: Vec<f64> = bodies
                .list
                .iter()
                .flat_map(|b| b.q[..dim].to_vec())
                .collect();
            drop_dependent(&mut model, &q0)?
        }
    };
    model.state_names = columns::state_names(&bodies);
    model.multiplier_names = columns::multiplier_names(&model, &bodies, file);
    let mut rows = ConstraintRows::new(
        declared,
        model
            .constraints
            .iter()
            .map(|t| (t.label.clone(), t.path.clone(), t.row, t.rows(dim))),
        file.constraints
            .iter()
            .enumerate()
            .filter_map(|(i, c)| Some((c.name()?.to_owned(), root.key("constraints").index(i)))),
        file.off.clone(),
        dropped_constraints.clone(),
        !file.flags.constraints,
    );
    rows.joints = Arc::new(crate::scene::ports::joint_table(file, &bodies)?);
    let model = Arc::new(model);
    let n = model.state_len();
    let nq = n / 2;
    let mut x0 = Col::<f64>::zeros(n);
    for (b, body) in bodies.list.iter().enumerate() {
        for k in 0..dim {
            x0[b * dim + k] = body.q[k];
            x0[nq + b * dim + k] = body.mass * body.v[k];
        }
    }
    let (mut raise, order) = choose_scheme(
        &file.integrator,
        model.is_dissipative() && !backward,
        Some(&bodies),
    )?;
    match &mut raise {
        Raise::Adaptive(control) => {
            control.resolve = model.stiff_relaxation();
            control.breakpoints = model.breakpoints();
        }
        Raise::Doubling(control, _) => {
            control.resolve = model.relaxation();
            control.breakpoints = model.breakpoints();
        }
        _ => {}
    }
    let m = model.m;
    let mut initial_projection = None;
    let mut notes = gravity_notes(file);
    if m > 0 {
        if file.integrator.consistent_velocities && !file.integrator.project_initial {
            // The velocities only, from positions that must hold as given (checked next).
            initial_projection = Some(project_initial(&model, &mut x0, true).map_err(|e| {
                err(
                    SceneErrorKind::OffConstraints,
                    root.key("integrator").key("consistent_velocities"),
                    e,
                )
            })?);
        }
        let off = off_constraints(&model, &x0);
        // Asked for, the projection takes any violation above round-off (the small ones the
        // run would otherwise accept with a note, too).
        let asked = file.integrator.project_initial
            && (off.is_some() || constraint_offset(&model, &x0, ROUND_OFF_RATIO).is_some());
        if asked {
            initial_projection = Some(project_initial(&model, &mut x0, false).map_err(|e| {
                err(
                    SceneErrorKind::OffConstraints,
                    root.key("integrator").key("project_initial"),
                    e,
                )
            })?);
        } else if let Some((value, row, level)) = off {
            let (path, label) = constraint_term(&model, row)
                .map_or((root.clone(), String::new()), |c| {
                    (c.path.clone(), c.label.clone())
                });
            return Err(err(
                SceneErrorKind::OffConstraints,
                path,
                format!(
                    "the initial state is off the constraints: {level} residual {value:.3e} at {label}; fix the positions/velocities, or set `integrator.project_initial = true` to project them (mass-weighted, reported), or `integrator.consistent_velocities = true` for the velocities alone"
                ),
            ));
        }
        if initial_projection.is_none()
            && let Some((ratio, value, row, level)) =
                constraint_offset(&model, &x0, ROUND_OFF_RATIO)
        {
            let label = constraint_term(&model, row).map_or_else(String::new, |c| c.label.clone());
            notes.push(format!(
                "the initial {level}s are off the constraints by {value:.1e} at {label} ({ratio:.0e} of its scale: accepted below √ε = 1.5e-8, above round-off); the first step projects them, so max |g| reports it at t = 0; fix the {level}s or set `integrator.project_initial = true`"
            ));
        }
        check_independent(&model, &x0.as_slice()[..nq], &bodies)?;
    }
    Ok(Assembled {
        dim,
        bodies,
        model,
        x0,
        run_plan,
        steps,
        disabled,
        effects,
        dropped_constraints,
        rows,
        initial_projection,
        notes,
        raise,
        order,
        splitting,
    })
}
