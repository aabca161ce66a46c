//! The scene's constraint terms, their rows in `g`, and what is done with redundant ones
//! (refused with the label of a dependent row, or dropped).

use super::{
    Result,
    bodies::{Bodies, Declared},
    err,
    initial::row_scales,
};
use crate::error::{LinearSolveError, SetupError};
use crate::scene::constraints::Constraint;
use crate::scene::error::{FieldPath, SceneError, SceneErrorKind};
use crate::scene::gram::MassGram;
use crate::scene::model::{ConstraintTerm, SceneModel};
use crate::scene::schema::SceneFile;

/// The declared constraints' terms after the generators' own, each labelled with its name when
/// it has one; a constraint whose name is in `file.off` is checked and left out, and listed in
/// `disabled`.
pub(super) fn constraint_terms(
    file: &SceneFile,
    bodies: &Bodies,
    generated: Vec<Declared>,
    disabled: &mut Vec<String>,
) -> Result<Vec<Declared>> {
    let mut out = generated;
    let root = FieldPath::root().key("constraints");
    for (i, c) in file.constraints.iter().enumerate() {
        let path = root.index(i);
        let start = out.len();
        c.declare(i, &path, bodies, &mut out)?;
        if let Some(name) = c.name() {
            if file.off.contains(name) {
                out.truncate(start);
                disabled.push(format!("constraints[{i}] '{name}'"));
                continue;
            }
            for term in &mut out[start..] {
                term.1 = format!("'{name}' ({})", term.1);
            }
        }
    }
    Ok(out)
}

/// The label of the constraint term that owns row `row`.
pub(super) fn constraint_term(model: &SceneModel, row: usize) -> Option<&ConstraintTerm> {
    model.constraints.iter().rev().find(|c| c.row <= row)
}

/// Removes dependent constraints one at a time (`redundant = "drop-dependent"`): factor
/// `G W⁻¹ Gᵀ` at the initial positions; a pivot that vanishes names a row that depends on the
/// rows before it in the factorization's order, and its constraint goes. Returns the labels of
/// the dropped constraints (a joint's dropped row as `'<name>' (…) row k`). A joint loses the
/// dependent row alone; a dependent row inside another multi-row constraint (a pin) is refused:
/// dropping the whole pin would remove independent rows too.
pub(super) fn drop_dependent(model: &mut SceneModel, q: &[f64]) -> Result<Vec<String>> {
    let mut dropped = Vec::new();
    while model.m > 0 {
        let result = MassGram::new(model, q).and_then(|mut g| g.factor(model, q));
        let row = match result {
            Ok(()) => break,
            Err(LinearSolveError::Singular { pivot, .. }) => pivot,
            Err(LinearSolveError::StructurallySingular { column }) => column,
            Err(e) => return Err(setup_error(model, SetupError::Linear(e))),
        };
        let Some(index) = model.constraints.iter().rposition(|c| c.row <= row) else {
            break;
        };
        let term = &model.constraints[index];
        // A joint's rows go one at a time: a loop of hinges (Bricard's) repeats one row of one
        // joint, and the joint keeps the others.
        if let (true, Constraint::Rows(rows)) = (term.rows(model.dim) > 1, &term.kind) {
            let (kept, gone) = rows.without_row(row - term.row);
            let label = format!("{} row {gone}", term.label);
            let term = &mut model.constraints[index];
            term.kind = Constraint::Rows(kept);
            dropped.push(label);
            // Every term kept: the rows after this one renumbered.
            model.retain_constraints(|_| true);
            continue;
        }
        if term.rows(model.dim) != 1 {
            return Err(err(
                SceneErrorKind::Redundant,
                term.path.clone(),
                format!(
                    "{} is redundant in one of its {} rows; only single-row constraints are dropped (declare it as rods)",
                    term.label,
                    term.rows(model.dim)
                ),
            ));
        }
        // A dependent constraint that contradicts the others (a second rod of another length)
        // is not redundant but inconsistent: dropping it would run with it violated.
        let value = model.term_residual(q, index).unwrap_or(0.0);
        let scale = row_scales(model, q)[term.row].0;
        if value.abs() > f64::EPSILON.sqrt() * scale {
            return Err(err(
                SceneErrorKind::OffConstraints,
                term.path.clone(),
                format!(
                    "{} depends on the others but is not satisfied at the initial state (residual {value:.3e}): it contradicts them, and is not dropped",
                    term.label
                ),
            ));
        }
        dropped.push(term.label.clone());
        model.retain_constraints(|i| i != index);
    }
    Ok(dropped)
}

/// Refuses redundant constraints (a rod listed twice, an over-constraining loop): the
/// constraint gradients must be independent at the initial positions, i.e. the mass-weighted
/// Gram matrix `G W⁻¹ Gᵀ` non-singular. The projection's own analysis is skipped for scenes (the
/// case is known), and without this check a duplicated constraint would only fail at the first
/// step, with a singular Newton matrix that names no constraint.
pub(super) fn check_independent(model: &SceneModel, q: &[f64], bodies: &Bodies) -> Result<()> {
    let singular = |e: LinearSolveError| match e {
        LinearSolveError::Singular { pivot, ratio, .. } => SetupError::RankDeficient {
            constraint: pivot,
            ratio,
        },
        LinearSolveError::StructurallySingular { column } => SetupError::RankDeficient {
            constraint: column,
            ratio: 0.0,
        },
        other => SetupError::Linear(other),
    };
    let mut gram = MassGram::new(model, q).map_err(|e| setup_error(model, singular(e)))?;
    let Err(e) = gram.factor(model, q) else {
        return Ok(());
    };
    // Singular with the masses: redundant constraints, or masses so far apart that
    // `G W⁻¹ Gᵀ` rounds to singular. `G Gᵀ` (unit masses) tells which.
    let unit = vec![1.0; model.masses.len()];
    if gram.factor_weighted(model, q, &unit).is_ok() {
        return Err(mass_ratio_error(model, q, bodies, &e));
    }
    Err(setup_error(model, singular(e)))
}

/// The error for independent constraints whose force system `G W⁻¹ Gᵀ` is singular in double
/// precision because the constrained bodies' masses are too far apart: it names the lightest
/// and heaviest of them and the ratio.
fn mass_ratio_error(
    model: &SceneModel,
    q: &[f64],
    bodies: &Bodies,
    e: &LinearSolveError,
) -> SceneError {
    let mut constrained = vec![false; model.masses.len()];
    model.for_each_gradient(q, |_, body, _| constrained[body] = true);
    let by_mass = |pick: fn(f64, f64) -> bool| {
        (0..constrained.len())
            .filter(|&b| constrained[b])
            .reduce(|a, b| {
                if pick(model.masses[b], model.masses[a]) {
                    b
                } else {
                    a
                }
            })
            .unwrap_or(0)
    };
    let (light, heavy) = (by_mass(|a, b| a < b), by_mass(|a, b| a > b));
    let name = |b: usize| {
        bodies
            .list
            .get(b)
            .map_or_else(|| format!("body {b}"), |x| format!("'{}'", x.name))
    };
    let (row, ratio) = match e {
        LinearSolveError::Singular { pivot, ratio, .. } => (*pivot, *ratio),
        _ => (0, 0.0),
    };
    let path = constraint_term(model, row).map_or_else(FieldPath::root, |c| c.path.clone());
    err(
        SceneErrorKind::Value,
        path,
        format!(
            "a mass ratio of {:.1e} among the constrained bodies ({} {:e}, {} {:e}): the constraints are independent, but the system for their forces, G W⁻¹ Gᵀ, is singular in double precision (pivot ratio {ratio:.1e}); bring the masses closer together",
            model.masses[heavy] / model.masses[light],
            name(light),
            model.masses[light],
            name(heavy),
            model.masses[heavy],
        ),
    )
}

/// Turns a projection's setup error into a scene error that names the constraint and points at
/// where it is declared.
pub(super) fn setup_error(model: &SceneModel, e: SetupError) -> SceneError {
    let at = |row: usize| {
        constraint_term(model, row).map_or_else(
            || (FieldPath::root(), format!("row {row}")),
            |c| (c.path.clone(), c.label.clone()),
        )
    };
    match e {
        SetupError::RankDeficient { constraint, ratio } => {
            let (path, label) = at(constraint);
            err(
                SceneErrorKind::Redundant,
                path,
                format!(
                    "the constraints are redundant: {label} depends on the others (pivot ratio {ratio:.1e}); remove it or one of those it repeats"
                ),
            )
        }
        SetupError::SingularMultiplierMatrix { .. } => err(
            SceneErrorKind::Redundant,
            FieldPath::root(),
            format!("the constraints are redundant or singular at the initial state: {e}"),
        ),
        other => err(SceneErrorKind::Setup, FieldPath::root(), other.to_string()),
    }
}
