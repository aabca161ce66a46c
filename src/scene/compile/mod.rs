//! Scene → model and scheme: validation with located errors, the assembly of only the declared
//! terms, the choice of scheme, and the initial-state checks.

mod assemble;
pub(crate) mod bodies;
mod builtin;
mod columns;
mod constraints;
mod density;
mod effects;
mod fingerprint;
mod implicit;
mod initial;
mod raise;
mod rigid;
mod scheme;
mod storage;
mod tolerance;
mod weld;

pub(crate) use super::validate::{self, Result, err};
pub use crate::scene::bodies::MAX_BODIES;
pub use crate::scene::effects::MAX_PAIRS;

use super::error::{FieldPath, SceneError, SceneErrorKind};
use super::model::SceneModel;
use super::ports::{SceneEvents, compile_events, compile_outputs};
use super::run::{RunPlan, Simulation};
use super::schema::{SCENE_VERSION, SceneFile};
use assemble::{Assembled, assemble};
use builtin::compile_builtin;
use faer::Col;
pub use raise::Raise;
use scheme::{SchemeFlow, scheme_flow};
pub use scheme::{Splitting, heap_splitting, splitting_flow};
use std::sync::Arc;
use storage::{EventSource, RunParts};

/// The most steps a run may plan (`t_end / dt`).
pub const MAX_STEPS: usize = 1_000_000_000_000;

/// [`Assembly::structure`] of a canonical `J`.
pub const CANONICAL: &str = "J canonical";

/// The largest number of unknowns (`n + m` of the joint midpoint system) on which a model
/// without a mechanical form factors a dense Newton matrix at every step (a scene's model has
/// one, and solves with its sparsity at any size).
pub const DENSE_MAX_DIM: usize = 400;

/// What a compiled scene assembled: printed by `lieflow check`.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Assembly {
    /// The scene's name.
    pub name: String,
    /// Dimension of the space (scenes of bodies).
    pub dim: Option<usize>,
    /// Number of bodies (points and rigid bodies).
    pub bodies: usize,
    /// How many of them are rigid (each four slots of the state: its centre and directors).
    pub rigid_bodies: usize,
    /// Length of the state.
    pub state_len: usize,
    /// Constraint terms by type and their rows, e.g. `("rod", 12)`.
    pub constraints: Vec<(String, usize)>,
    /// Total constraint rows `m`.
    pub constraint_rows: usize,
    /// The assembled terms: `(label, kind)`.
    pub effects: Vec<(String, String)>,
    /// Declared parts switched off by flags.
    pub disabled: Vec<String>,
    /// The skew part `J` of `M` canonical (no magnetic field).
    pub canonical: bool,
    /// What `J` is, in words: [`CANONICAL`], or what makes it non-canonical (a magnetic field,
    /// a built-in model's Lie–Poisson structure).
    pub structure: String,
    /// `M` has a dissipative part.
    pub dissipative: bool,
    /// The paper's case: `degenerate` (`⟨g,g⟩ = 0`) or `non-degenerate`; `None` without constraints.
    pub case: Option<String>,
    /// The projection variant (`decoupled`, `coupled`, `symmetric`).
    pub projection: Option<String>,
    /// The scheme, described.
    pub scheme: String,
    /// Its order.
    pub order: u32,
    /// Why this scheme (`lieflow check` prints it).
    pub reason: String,
    /// The multiplier solver backend.
    pub solver: Option<String>,
    /// Steps planned.
    pub steps: usize,
    /// The initial projection, if the scene asked for one: `(max |Δq|, max |Δp|)`.
    pub initial_projection: Option<(f64, f64)>,
    /// Redundant constraints removed (`redundant = "drop-dependent"`), by label.
    pub dropped_constraints: Vec<String>,
    /// What the scene does that a reader might not expect and that is accepted, said once:
    /// effects that add up (two gravities), an initial state off its constraints by more
    /// than round-off but less than the refusal threshold.
    pub notes: Vec<String>,
    /// The declared inputs: `(name, what it drives)`.
    pub inputs: Vec<(String, String)>,
    /// The declared outputs' column names.
    pub outputs: Vec<String>,
    /// The declared events: `(name, action)`.
    pub events: Vec<(String, String)>,
}

/// A compiled scene: the simulation, what was assembled, and the run's plan.
pub struct Compiled {
    /// The simulation, ready to step.
    pub simulation: Box<dyn Simulation>,
    /// What was assembled.
    pub assembly: Assembly,
    /// Steps and diagnostics.
    pub plan: RunPlan,
    /// The assembled model (`None` for built-in models).
    pub model: Option<Arc<SceneModel>>,
    /// What a viewer draws of it (`None` for built-in models).
    pub sketch: Option<crate::scene::sketch::Sketch>,
}

impl std::fmt::Debug for Compiled {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Compiled")
            .field("assembly", &self.assembly)
            .field("plan", &self.plan)
            .finish_non_exhaustive()
    }
}

/// A non-finite initial state, found when the run is set up (the compile-time checks refuse
/// non-finite inputs, so this names what they could not see).
fn initial_state_error(e: crate::error::IntegrateError) -> SceneError {
    err(SceneErrorKind::Value, FieldPath::root(), e.to_string())
}

/// Compiles a parsed scene (no source text: errors carry paths but no line numbers).
pub fn compile(file: &SceneFile) -> Result<Compiled> {
    identified(compile_impl(file, false)?)
}

/// `compiled` with its simulation told what it is ([`Simulation::set_identity`]).
fn identified(mut compiled: Compiled) -> Result<Compiled> {
    let print = fingerprint::fingerprint(&compiled.assembly, compiled.simulation.as_ref());
    let name = compiled.assembly.name.clone();
    compiled.simulation.set_identity(name, print);
    Ok(compiled)
}

/// As [`compile`], but a composition of order above 2 may run damping backwards: for reference
/// runs of mildly damped scenes only, where an order-8 composition's accuracy matters more than
/// the damping's sign in its backward sub-steps.
pub fn compile_reference(file: &SceneFile) -> Result<Compiled> {
    identified(compile_impl(file, true)?)
}

/// The model of a scene of bodies and its initial state, without the scheme's flow: for what
/// needs the model alone (the library's unit tests build no flow of a scene this way).
///
/// # Errors
/// As [`compile`]; a built-in model has no scene model ([`SceneErrorKind::Unsupported`]).
#[cfg(test)]
pub(crate) fn model_of(file: &SceneFile) -> Result<(Arc<SceneModel>, Col<f64>)> {
    check_version(file)?;
    if file.builtin.is_some() {
        return Err(err(
            SceneErrorKind::Unsupported,
            FieldPath::root().key("builtin"),
            "a built-in model is not a scene model",
        ));
    }
    let a = assemble(file, false)?;
    Ok((a.model, a.x0))
}

/// The scene file's version is the one this library reads.
fn check_version(file: &SceneFile) -> Result<()> {
    if file.version != SCENE_VERSION {
        return Err(err(
            SceneErrorKind::Version,
            FieldPath::root().key("version"),
            format!(
                "version {} is not supported; this library reads version {SCENE_VERSION}",
                file.version
            ),
        ));
    }
    Ok(())
}

fn compile_impl(file: &SceneFile, backward: bool) -> Result<Compiled> {
    let root = FieldPath::root();
    check_version(file)?;
    if let Some(b) = &file.builtin {
        if !file.bodies.is_empty()
            || !file.chains.is_empty()
            || !file.shells.is_empty()
            || !file.grids.is_empty()
            || !file.constraints.is_empty()
            || !file.effects.is_empty()
            || !file.inputs.is_empty()
            || !file.outputs.is_empty()
            || !file.events.is_empty()
        {
            return Err(err(
                SceneErrorKind::Value,
                root.key("builtin"),
                "a built-in model takes no bodies, constraints, effects, inputs, outputs or events of its own",
            ));
        }
        return compile_builtin(file, b);
    }
    let Assembled {
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
    } = assemble(file, backward)?;
    let (n, m) = (model.state_len(), model.m);
    let dt = file.integrator.step();
    let dissipative = model.is_dissipative();
    let SchemeFlow {
        flow,
        name: scheme_name,
        case,
        projection,
        solver,
        split,
        detail,
    } = match implicit::implicit_flow(file, &model, &x0, raise.clone(), backward) {
        Some(implicit) => implicit?,
        None => scheme_flow(file, &model, &x0, raise.clone(), backward)?,
    };
    let scheme = raise.describe(scheme_name);
    let mut reason = raise
        .reason(file.integrator.scheme, dissipative, order)
        .to_owned();
    if let Some(detail) = detail {
        reason = format!("{reason}; {detail}");
    }
    let mut constraint_counts: Vec<(String, usize)> = Vec::new();
    for t in &model.constraints {
        let kind = t.kind.info().kind();
        match constraint_counts.iter_mut().find(|(k, _)| k == kind) {
            Some(e) => e.1 += t.rows(dim),
            None => constraint_counts.push((kind.to_owned(), t.rows(dim))),
        }
    }
    let outputs = compile_outputs(&file.outputs, &bodies, dim, model.inputs.as_ref(), &rows)?;
    super::ports::check_joint_reads(&outputs, &model)?;
    // Compiled here for the checks (and again for a stack state's run).
    let _: SceneEvents<Col<f64>> = compile_events(
        &file.events,
        &bodies,
        dim,
        model.inputs.as_ref(),
        &model,
        &rows.joints,
    )?;
    let assembly = Assembly {
        name: file.name.clone().unwrap_or_else(|| "scene".to_owned()),
        dim: Some(dim),
        bodies: bodies.all().len(),
        rigid_bodies: bodies.rigid.len(),
        state_len: n,
        constraints: constraint_counts,
        constraint_rows: m,
        effects,
        disabled,
        canonical: model.is_canonical(),
        structure: if model.is_canonical() {
            CANONICAL.to_owned()
        } else {
            "J non-canonical (magnetic field)".to_owned()
        },
        dissipative,
        case,
        projection,
        scheme,
        order,
        reason,
        solver,
        steps,
        initial_projection,
        dropped_constraints,
        notes,
        inputs: file
            .inputs
            .iter()
            .map(|i| (i.name().to_owned(), i.describe()))
            .collect(),
        outputs: outputs.iter().map(|o| o.name.clone()).collect(),
        events: file
            .events
            .iter()
            .map(|e| {
                let action = match e.action {
                    super::ports::EventAction::Stop => "stop",
                    super::ports::EventAction::Record => "record",
                };
                (e.name.clone(), action.to_owned())
            })
            .collect(),
    };
    let sketch = crate::scene::sketch::sketch(&bodies, &model);
    let parts = RunParts {
        model: &model,
        x0: &x0,
        dt,
        outputs,
        events: EventSource {
            specs: &file.events,
            bodies: &bodies,
            dim,
            joints: rows.joints.clone(),
        },
        // The splittings and Petrov–Galerkin book the damping exactly, the discrete gradient
        // its `−h v̄ᵀB v̄` (the midpoint rule does not: its power is integrated).
        books_dissipation: dissipative
            && (splitting || file.integrator.scheme == super::schema::Method::DiscreteGradient),
    };
    // A splitting of one to three bodies steps a stack state (compile/storage.rs).
    let simulation = storage::simulation(flow, parts, split.then_some((raise, backward)))?;
    Ok(Compiled {
        simulation,
        assembly,
        plan: run_plan,
        model: Some(model),
        sketch: Some(sketch),
    })
}

/// A note for each gravity beyond the first that is switched on: their fields add.
fn gravity_notes(file: &SceneFile) -> Vec<String> {
    let gravities: Vec<usize> = file
        .effects
        .iter()
        .enumerate()
        .filter(|(_, e)| {
            matches!(e, crate::scene::schema::EffectSpec::Gravity(_)) && file.flags.get(e.flag())
        })
        .map(|(i, _)| i)
        .collect();
    gravities
        .iter()
        .skip(1)
        .map(|i| {
            format!(
                "effects[{i}] is a second gravity: it adds to effects[{}] (the bodies both select feel the sum of the fields)",
                gravities[0]
            )
        })
        .collect()
}

/// Every name in `file.off` must name an effect or a constraint of the scene.
fn check_off_names(file: &SceneFile) -> Result<()> {
    let names: Vec<&String> = file
        .effects
        .iter()
        .filter_map(|e| e.label())
        .chain(file.constraints.iter().filter_map(|c| c.name()))
        .collect();
    match file.off.iter().find(|n| !names.contains(n)) {
        None => Ok(()),
        Some(n) => Err(err(
            SceneErrorKind::Reference,
            FieldPath::root(),
            format!(
                "--off {n}: not a kind of part ({}) and no effect or constraint is named '{n}' (named here: {})",
                crate::scene::schema::Flag::names(),
                if names.is_empty() {
                    "none".to_owned()
                } else {
                    names
                        .iter()
                        .map(|s| format!("'{s}'"))
                        .collect::<Vec<_>>()
                        .join(", ")
                }
            ),
        )),
    }
}
