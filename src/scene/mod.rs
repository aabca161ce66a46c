//! Scenes: mechanical and port-Hamiltonian systems described as data (feature `scene`).
//!
//! A scene file (TOML, [`schema`]) declares point bodies (one by one, or generated: chains,
//! particles on spheres, grids), holonomic constraints (pins, rods, spheres, planes) and
//! *effects* — each a term of `H` (gravity, springs, pair potentials, traps) or of `M`
//! (viscous damping `R`, a magnetic field in `J`) — plus the integrator and switches
//! (`[flags]`). [`Scene::compile`] assembles only the declared, switched-on terms into a
//! [`SceneModel`] (which implements the library's three model traits) and composes their exact
//! sub-flows — one kick for all potentials, the free flight of the kinetic term under `M` — by
//! Strang splitting, projected with the Zhang & Deng (2004) half-steps when there are
//! constraints, and composed to order 4, 6 or 8 when asked (not with damping: negative
//! sub-steps would run it backwards, and the scene is refused with a message that names the
//! field). An effect that is not declared or is switched off has no term and no sub-flow, so it
//! is never evaluated; [`RunSummary::effects`] counts every term's evaluations to show it.
//!
//! ```
//! use lieflow::scene::{Scene, run};
//!
//! let scene = Scene::from_toml(r#"
//!     version = 1
//!     dim = 2
//!     [[chains]]
//!     name = "arm"
//!     links = 2
//!     length = 1.0
//!     mass = 1.0
//!     [[effects]]
//!     type = "gravity"
//!     g = [0.0, -9.81]
//!     [integrator]
//!     dt = 0.01
//!     t_end = 1.0
//! "#, "arm.toml")?;
//! let mut compiled = scene.compile()?;
//! let summary = run(compiled.simulation.as_mut(), &compiled.plan, &mut |_| {});
//! assert_eq!(summary.steps, 100);
//! assert!(summary.max_abs_g.unwrap() < 1e-12);
//! # Ok::<(), lieflow::scene::SceneError>(())
//! ```

pub(crate) mod bodies;
mod compile;
pub mod constraints;
mod counter;
mod effect_report;
pub mod effects;
mod error;
mod gram;
mod model;
mod names;
pub mod observe;
pub mod path;
pub mod ports;
mod rigid_spec;
mod run;
pub mod schema;
mod shape;
pub(crate) mod simulation;
mod simulation_checkpoint;
pub mod sketch;
pub(crate) mod validate;
mod watch;

#[cfg(test)]
pub(crate) use compile::model_of;
pub use compile::{
    Assembly, Compiled, DENSE_MAX_DIM, MAX_BODIES, MAX_PAIRS, Raise, Splitting, compile,
    compile_reference, heap_splitting, splitting_flow,
};
pub use error::{FieldPath, Location, PathSegment, SceneError, SceneErrorKind};
pub use gram::MassGram;
pub use model::{
    DashpotFlow, EffectKind, FlightCache, FreeFlight, HingeDamperFlow, Kick, KickCache, SceneKick,
    SceneModel, SceneSplitting,
};
pub use run::{
    AdaptiveSummary, Advanced, BUDGET_WARNING_FRACTION, EffectReport, RunFailure, RunPlan,
    RunSummary, Sample, Simulation, SimulationCheckpoint, advance, advance_dense_until,
    advance_own_until, advance_plan, advance_plan_until, advance_until, run, run_until,
};
pub use schema::SceneFile;
pub use watch::EventRecord;

use std::path::Path;

/// Changes the parameter at `path` of a running scene between steps: `scene` is recompiled
/// with the new value and the run moves into it — state, time, energy ledger, warm starts and
/// held inputs, through a checkpoint — so the continuation is exactly the new model's from
/// the current state. The event log starts afresh. A change that alters the model's structure
/// (bodies, constraints, the scheme) is refused and nothing changes; a change that moves the
/// constraint manifold (a rod's length) makes the next step refuse the state until it is
/// re-projected (`Simulation::set_state(x, true)`).
///
/// # Errors
/// The path or value ([`Scene::with_value`]), the new scene's compile errors, or a
/// structural change ([`SceneErrorKind::Unsupported`]).
pub fn set_parameter(
    scene: &mut Scene,
    compiled: &mut Compiled,
    path: &str,
    value: f64,
) -> Result<(), SceneError> {
    let changed = scene.with_value(path, value)?;
    let mut next = changed.compile()?;
    let same_shape = next.simulation.state().len() == compiled.simulation.state().len()
        && next.assembly.constraint_rows == compiled.assembly.constraint_rows
        && next.assembly.scheme == compiled.assembly.scheme;
    let checkpoint = compiled.simulation.save();
    let moved = if same_shape {
        next.simulation.restore(&checkpoint)
    } else {
        Err("the state, constraints or scheme differ".to_owned())
    };
    if let Err(why) = moved {
        return Err(SceneError::new(
            SceneErrorKind::Unsupported,
            FieldPath::root(),
            format!(
                "'{path}' = {value} changes the model's structure ({why}); a running scene takes changes of parameters only"
            ),
        ));
    }
    next.plan = compiled.plan;
    *compiled = next;
    *scene = changed;
    Ok(())
}

/// The default scene (`lieflow scene` prints it; `lieflow run` runs it): a damped,
/// spring-coupled triple pendulum pair under gravity.
pub const DEFAULT_SCENE: &str = include_str!("default.toml");

/// The largest scene file [`Scene::from_path`] reads: 64 MiB (a scene of 10⁵ bodies written out
/// one by one is a few megabytes).
pub const MAX_SCENE_BYTES: u64 = 64 << 20;

/// A parsed scene with its source text, so that errors found while compiling point at the file.
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    /// The parsed file.
    pub file: SceneFile,
    /// `(file name, text)` when parsed from text.
    source: Option<(String, String)>,
    /// The fields set since ([`Scene::with_value`]), in order: the file is the text with them.
    overrides: Vec<(String, f64)>,
}

/// The text of a scene (or sweep) file: a regular file (not a device, FIFO or directory, which
/// could block or never end) of at most [`MAX_SCENE_BYTES`].
///
/// # Errors
/// [`SceneErrorKind::Io`] when the file cannot be read, is not a regular file or is larger
/// than the limit.
pub fn read_scene_file(path: &Path) -> Result<String, SceneError> {
    use std::io::Read as _;
    let name = path.display().to_string();
    let io = |what: String| {
        SceneError::new(
            SceneErrorKind::Io,
            FieldPath::root(),
            format!("cannot read {name}: {what}"),
        )
    };
    let meta = std::fs::metadata(path).map_err(|e| io(e.to_string()))?;
    if !meta.is_file() {
        return Err(io(
            "not a regular file (a scene is read from a file, not from a device, a FIFO or a directory)".to_owned(),
        ));
    }
    let too_large = |len: u64| {
        io(format!(
            "{len} bytes, more than the {MAX_SCENE_BYTES} a scene file may have"
        ))
    };
    if meta.len() > MAX_SCENE_BYTES {
        return Err(too_large(meta.len()));
    }
    // The limit again while reading: the file may have grown since.
    let mut text = String::new();
    std::fs::File::open(path)
        .and_then(|f| f.take(MAX_SCENE_BYTES + 1).read_to_string(&mut text))
        .map_err(|e| io(e.to_string()))?;
    if text.len() as u64 > MAX_SCENE_BYTES {
        return Err(too_large(text.len() as u64));
    }
    Ok(text)
}

impl Scene {
    /// Parses a scene from TOML `text`; `file` names it in error messages.
    pub fn from_toml(text: &str, file: &str) -> Result<Self, SceneError> {
        let parsed: SceneFile =
            toml::from_str(text).map_err(|e| SceneError::from_toml_error(&e, file, text))?;
        Ok(Self {
            file: parsed,
            source: Some((file.to_owned(), text.to_owned())),
            overrides: Vec::new(),
        })
    }

    /// Reads and parses a scene file: a regular file (not a device, FIFO or directory, which
    /// could block or never end) of at most [`MAX_SCENE_BYTES`].
    ///
    /// # Errors
    /// [`SceneErrorKind::Io`] when the file cannot be read, is not a regular file or is larger
    /// than the limit; the parse errors of [`Scene::from_toml`].
    pub fn from_path(path: &Path) -> Result<Self, SceneError> {
        let text = read_scene_file(path)?;
        let mut scene = Self::from_toml(&text, &path.display().to_string())?;
        scene.file.base_dir = path.parent().map(Path::to_path_buf);
        Ok(scene)
    }

    /// The embedded default scene ([`DEFAULT_SCENE`]).
    pub fn default_scene() -> Self {
        Self::from_toml(DEFAULT_SCENE, "<default scene>").expect("the default scene parses")
    }

    /// A scene from an already parsed (or programmatically built) file; its errors have paths
    /// but no line numbers.
    pub fn from_file(file: SceneFile) -> Self {
        Self {
            file,
            source: None,
            overrides: Vec::new(),
        }
    }

    /// The same scene with the field at `path` (`effects[1].coefficient`, `integrator.dt`)
    /// set to `value` (and every field set before it); errors of the new scene are still located
    /// in the original text.
    ///
    /// # Errors
    /// A scene without source text (built from a [`SceneFile`]), a path that names no field,
    /// or a value the field's type refuses.
    pub fn with_value(&self, path: &str, value: f64) -> Result<Self, SceneError> {
        let Some((name, text)) = &self.source else {
            return Err(SceneError::new(
                SceneErrorKind::Unsupported,
                FieldPath::root(),
                "a scene built from a SceneFile has no text to change a parameter in",
            ));
        };
        let mut overrides = self.overrides.clone();
        overrides.push((path.to_owned(), value));
        let table = Self::table_with(name, text, &overrides)?;
        let file: SceneFile =
            toml::Value::Table(table)
                .try_into()
                .map_err(|e: toml::de::Error| {
                    SceneError::new(
                        SceneErrorKind::Value,
                        FieldPath::root(),
                        format!("'{path}' = {value}: {}", e.message().trim_end()),
                    )
                })?;
        Ok(Self {
            file,
            source: self.source.clone(),
            overrides,
        })
    }

    /// The text's TOML table with the `overrides` set in order.
    fn table_with(
        name: &str,
        text: &str,
        overrides: &[(String, f64)],
    ) -> Result<toml::Table, SceneError> {
        let mut table: toml::Table =
            toml::from_str(text).map_err(|e| SceneError::from_toml_error(&e, name, text))?;
        for (path, value) in overrides {
            path::set_path(&mut table, path, *value)?;
        }
        Ok(table)
    }

    /// The declared `[[parameters]]` with their values in this scene: `(name, path, value)`.
    ///
    /// # Errors
    /// A scene without source text, a path that names no number, a name used twice.
    pub fn parameter_values(&self) -> Result<Vec<(String, String, f64)>, SceneError> {
        if self.file.parameters.is_empty() {
            return Ok(Vec::new());
        }
        let Some((name, text)) = &self.source else {
            return Err(SceneError::new(
                SceneErrorKind::Unsupported,
                FieldPath::root(),
                "a scene built from a SceneFile has no text to read its parameters from",
            ));
        };
        let table = Self::table_with(name, text, &self.overrides)?;
        let mut out: Vec<(String, String, f64)> = Vec::new();
        for (i, p) in self.file.parameters.iter().enumerate() {
            let at = FieldPath::root().key("parameters").index(i);
            if out.iter().any(|(n, _, _)| *n == p.name) {
                return Err(SceneError::new(
                    SceneErrorKind::Value,
                    at.key("name"),
                    format!("the parameter name '{}' is used twice", p.name),
                ));
            }
            let value = path::value_at(&table, &p.path).map_err(|e| {
                SceneError::new(SceneErrorKind::Reference, at.key("path"), e.message)
            })?;
            out.push((p.name.clone(), p.path.clone(), value));
        }
        Ok(out)
    }

    /// Compiles the scene (see the module docs); errors are located in the source text.
    pub fn compile(&self) -> Result<Compiled, SceneError> {
        let checked = if self.source.is_some() {
            // The parameters name numbers of the text (a scene from a file has no text).
            self.parameter_values().map(drop)
        } else {
            Ok(())
        };
        checked
            .and_then(|()| compile(&self.file))
            .map_err(|e| match &self.source {
                Some((name, text)) => e.locate(name, text),
                None => e,
            })
    }
}
