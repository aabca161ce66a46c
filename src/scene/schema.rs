//! The scene file format, version 1: the serde types a TOML scene deserializes into.
//!
//! Every table rejects unknown keys (`deny_unknown_fields`), so a misspelt key is an error that
//! names it, never a silently ignored setting. Bodies and groups are referred to by name: a body's
//! own `name`, a generator's name (all its bodies), `"<generator>.<i>"` (its `i`-th body,
//! counting from 0), or `"*"` (every body).

pub use super::names::{Controller, Diagnostic, Flag, Method, Redundant};
use serde::Deserialize;

/// The scene format version this library reads.
pub const SCENE_VERSION: u32 = 1;

/// A whole scene file.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    /// The format version; must be [`SCENE_VERSION`].
    pub version: u32,
    /// A title for summaries and plots.
    #[serde(default)]
    pub name: Option<String>,
    /// Free text.
    #[serde(default)]
    pub description: Option<String>,
    /// The space the bodies live in: 2 or 3. Required unless the scene is a [`Builtin`].
    #[serde(default)]
    pub dim: Option<usize>,
    /// One of the library's ready models instead of bodies and effects.
    #[serde(default)]
    pub builtin: Option<Builtin>,
    /// Point particles, one by one.
    #[serde(default)]
    pub bodies: Vec<BodySpec>,
    /// Pendulum chains hanging from a fixed point (bodies and rods).
    #[serde(default)]
    pub chains: Vec<ChainSpec>,
    /// Particles on a sphere (3D) or circle (2D), each held on it by a sphere constraint.
    #[serde(default)]
    pub shells: Vec<ShellSpec>,
    /// Particles on a regular grid.
    #[serde(default)]
    pub grids: Vec<GridSpec>,
    /// Holonomic constraints.
    #[serde(default)]
    pub constraints: Vec<ConstraintSpec>,
    /// Terms of the Hamiltonian or of the structure matrix.
    #[serde(default)]
    pub effects: Vec<EffectSpec>,
    /// Inputs: forces and torques driven by signals of time or held values.
    #[serde(default)]
    pub inputs: Vec<InputSpec>,
    /// Quantities a run writes (CSV columns) and draws.
    #[serde(default)]
    pub outputs: Vec<OutputSpec>,
    /// Crossings that stop the run or are recorded.
    #[serde(default)]
    pub events: Vec<EventSpec>,
    /// Named numbers of the scene an importer may set before a run (an FMU's parameters), each a
    /// field by path (`effects[1].coefficient`).
    #[serde(default)]
    pub parameters: Vec<ParameterSpec>,
    /// The scheme, step and horizon.
    pub integrator: IntegratorSpec,
    /// Switches that turn declared parts off without deleting them.
    #[serde(default)]
    pub flags: Flags,
    /// Named effects and constraints switched off (the command's `--off NAME`), as if they
    /// were not written; listed among the assembly's switched-off parts. Not read from the
    /// file.
    #[serde(skip)]
    pub off: Vec<String>,
    /// The directory of the scene file, when it was read from one ([`Scene::from_path`]): the
    /// files it names (a table signal's `file`) are found relative to it first. Not read from
    /// the file.
    ///
    /// [`Scene::from_path`]: crate::scene::Scene::from_path
    #[serde(skip)]
    pub base_dir: Option<std::path::PathBuf>,
}

/// A ready model of the library, run through the same command and summary as a scene.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Builtin {
    /// `"paper"` (Zhang & Deng §4), `"pendulum-chain"`, `"spherical-pendulum"`, `"rigid-body"`
    /// (Lie–Poisson, implicit midpoint).
    pub model: String,
    /// Links of a `pendulum-chain` (default 10).
    #[serde(default)]
    pub links: Option<usize>,
    /// Dimension of a `pendulum-chain` (2 or 3, default 2).
    #[serde(default)]
    pub dim: Option<usize>,
}

/// One body: a point particle, or with `inertia` a rigid body (its centre of mass and
/// orientation; 3D).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BodySpec {
    /// Unique name.
    pub name: String,
    /// Mass, positive (a rigid body whose `inertia` is a shape with a `density` may leave it
    /// out: the shape's volume times the density).
    #[serde(default)]
    pub mass: Option<f64>,
    /// Initial position (`dim` entries): of the centre of mass for a rigid body.
    pub position: Vec<f64>,
    /// Initial velocity (`dim` entries; default 0).
    #[serde(default)]
    pub velocity: Option<Vec<f64>>,
    /// Electric charge, for a magnetic field (default 0; points only).
    #[serde(default)]
    pub charge: f64,
    /// The inertia about the centre of mass, in the body's frame: makes the body rigid.
    #[serde(default)]
    pub inertia: Option<InertiaSpec>,
    /// The body's frame in the world at the start (rigid bodies; default: the world's axes).
    #[serde(default)]
    pub orientation: Option<OrientationSpec>,
    /// Initial angular velocity in the world frame, rad/s (rigid bodies; default 0).
    #[serde(default)]
    pub angular_velocity: Option<Vec<f64>>,
}

pub use super::rigid_spec::{InertiaSpec, OrientationSpec};

/// A chain of `links` bodies joined by rods, the first rod fixed at `anchor`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ChainSpec {
    /// Name; its bodies are `"<name>.0"` (next to the anchor) … `"<name>.<links − 1>"`.
    pub name: String,
    /// Number of links (bodies), at least 1.
    pub links: usize,
    /// The fixed point the first rod hangs from (default: the origin).
    #[serde(default)]
    pub anchor: Option<Vec<f64>>,
    /// Direction the chain initially points in (default: along the first axis).
    #[serde(default)]
    pub direction: Option<Vec<f64>>,
    /// 2D: each link's initial angle from the downward vertical (`−y`), in degrees,
    /// counter-clockwise positive — one value for every link or one per link; instead of
    /// `direction`. A pendulum is a chain of one link.
    #[serde(default)]
    pub angles_deg: Option<Vec<f64>>,
    /// 2D, with `angles_deg`: each link's initial angular velocity in degrees per second (one
    /// value or one per link; default 0). The bodies' velocities follow from them, so they
    /// satisfy the rods' hidden constraints exactly.
    #[serde(default)]
    pub angular_velocities_deg: Option<Vec<f64>>,
    /// Length of every link, positive.
    pub length: f64,
    /// Mass of every body, positive.
    pub mass: f64,
    /// Charge of every body (default 0).
    #[serde(default)]
    pub charge: f64,
}

/// Particles on the sphere `|q − center| = radius` (a circle in 2D).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ShellSpec {
    /// Name; its bodies are `"<name>.0"`, `"<name>.1"`, ….
    pub name: String,
    /// Centre (default: the origin).
    #[serde(default)]
    pub center: Option<Vec<f64>>,
    /// Radius, positive.
    pub radius: f64,
    /// Mass of every particle, positive.
    pub mass: f64,
    /// Charge of every particle (default 0).
    #[serde(default)]
    pub charge: f64,
    /// 3D: particles per ring, rings at polar angles `(k + ½) π / R` for `k = 0 … R − 1`, the
    /// `j`-th of `n` at azimuth `2π (j + k/2) / n`. 2D: one entry, the number of particles
    /// evenly spaced on the circle.
    #[serde(default)]
    pub rings: Option<Vec<usize>>,
    /// Explicit positions instead of rings; each must lie on the sphere (to `1e-12` relative).
    #[serde(default)]
    pub positions: Option<Vec<Vec<f64>>>,
    /// Initial velocities for explicit positions (tangent to the sphere; default 0).
    #[serde(default)]
    pub velocities: Option<Vec<Vec<f64>>>,
}

/// Particles on a grid `origin + spacing · (i, j[, k])`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GridSpec {
    /// Name; its bodies are `"<name>.0"` … in row-major order (last axis fastest).
    pub name: String,
    /// Corner of the grid (default: the origin).
    #[serde(default)]
    pub origin: Option<Vec<f64>>,
    /// Distance between neighbours, positive.
    pub spacing: f64,
    /// Particles along each axis (`dim` entries, each at least 1).
    pub counts: Vec<usize>,
    /// Mass of every particle, positive.
    pub mass: f64,
    /// Charge of every particle (default 0).
    #[serde(default)]
    pub charge: f64,
    /// Initial velocity of every particle (default 0).
    #[serde(default)]
    pub velocity: Option<Vec<f64>>,
}

/// A scene parameter: a name for the number at `path`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ParameterSpec {
    /// Its name (an FMU variable's name).
    pub name: String,
    /// The field it sets, by path: keys and `[indices]`.
    pub path: String,
    /// What it is, in words.
    #[serde(default)]
    pub description: Option<String>,
}

pub use super::constraints::{ConstraintSpec, PinSpec, PlaneSpec, RodSpec, SphereSpec};
pub use super::effects::{
    DampingSpec, DashpotSpec, EffectSpec, GravitySpec, HingeLimitSpec, MagneticSpec, PairSpec,
    SliderSpringSpec, SpringSpec, TorsionSpringSpec, TrapSpec,
};
pub use super::ports::{EventSpec, InputSpec, OutputSpec, SignalSpec};

/// The scheme, step size and horizon.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IntegratorSpec {
    /// `"auto"` (default: the splitting of the declared effects, composed to `order`), a
    /// composition by name: `"strang"`, `"triple-jump"`, `"suzuki4"`, `"yoshida6"`,
    /// `"kahan-li6"`, `"suzuki-umeno8"`, `"kahan-li8"`; `"extrapolation"` (the splitting
    /// extrapolated to `order`, every sub-step forward); `"discrete-gradient"` (Gonzalez,
    /// order 2, implicit: energy exactly conserved, or decreasing with damping, up to the
    /// Newton tolerance); `"petrov-galerkin"` (the energy-consistent scheme of `order` 2 to 8,
    /// default 4, implicit: `H(x_{n+1}) − H(x_n) = −D_n`, `D_n ≥ 0`); `"midpoint"` (the
    /// implicit midpoint rule, projected); `"modified"` (the paper's §2 scheme, built-in paper
    /// model only). The implicit schemes eliminate the momenta and solve for the positions
    /// (and multipliers) with the scene's sparsity, at any size (docs/method.md §5c, §11).
    #[serde(default)]
    pub scheme: Method,
    /// The order for `auto` (the even orders 2 to 16, default 2: compositions up to 8, or with
    /// damping — and always from 10 — the extrapolated splitting) and for `extrapolation` (the
    /// even orders 4 to 16, default 4).
    #[serde(default)]
    pub order: Option<u32>,
    /// Step size, positive; with `tol`, the interval the run reports at (CSV rows, outputs,
    /// progress, an FMU's communication step), inside which the steps are chosen, and the
    /// longest first step (the first is estimated from the scene's derivatives) — optional
    /// then: left out, it is `t_end / 1000`
    /// ([`step`](Self::step)). Read as NaN when the file leaves it out.
    #[serde(default = "missing_step")]
    pub dt: f64,
    /// A tolerance (`rtol = atol = tol`): the steps and orders are chosen to meet it by the
    /// adaptive extrapolation of the splitting (`scheme = "auto"` or `"extrapolation"`; every
    /// sub-step forward, the constraints projected after every accepted step), or the steps of
    /// a named fixed-order scheme by step doubling (its order kept, the error per unit step
    /// controlled); with `controller = "reversible"` it sets the step scale once.
    #[serde(default)]
    pub tol: Option<f64>,
    /// With a tolerance: `"error"` (default: the steps chosen to meet the tolerance) or
    /// `"reversible"` (Hairer–Söderlind: steps along `density` that retrace themselves when
    /// time is reversed — no energy drift on long conservative runs; the splitting without
    /// damping only).
    #[serde(default)]
    pub controller: Option<Controller>,
    /// The reversible controller's step density, `ρ = r^{−power}` with `r` the distance
    /// between two bodies (or of one body from the origin): `density = { distance = ["sun",
    /// "planet"], power = 1.5 }` gives steps `∝ r^{3/2}`, shrinking like the period of a
    /// Kepler orbit at that radius.
    #[serde(default)]
    pub density: Option<DensitySpec>,
    /// The relative tolerance (instead of or beside `tol`).
    #[serde(default)]
    pub rtol: Option<f64>,
    /// The absolute tolerance (instead of or beside `tol`).
    #[serde(default)]
    pub atol: Option<f64>,
    /// With a tolerance: the smallest step (default 0: a run fails only when the step no
    /// longer moves time), below which the run stops with a typed error naming the time.
    #[serde(default)]
    pub h_min: Option<f64>,
    /// With a tolerance: the largest step (default: `dt`).
    #[serde(default)]
    pub h_max: Option<f64>,
    /// With a tolerance: the highest order the controller may choose (even, 4 … 16; default 16).
    #[serde(default)]
    pub max_order: Option<u32>,
    /// With a tolerance (the adaptive extrapolation): report at every `dt` from the
    /// polynomial of the accepted step that holds it (dense output), the steps the
    /// controller's own — not landing on every report time — and `h_max` unbounded by default.
    #[serde(default)]
    pub dense: bool,
    /// Final time, positive (`t_end / dt` steps, rounded to the nearest integer).
    pub t_end: f64,
    /// Diagnostics computed after every step: `"energy"`, `"constraints"` (`|g|`, `|φ|`),
    /// `"profile"` (time per effect). Default: energy and constraints.
    #[serde(default = "default_diagnostics")]
    pub diagnostics: Vec<Diagnostic>,
    /// Project an initial state that is off the constraints onto them (mass-weighted,
    /// positions then velocities) and report by how much, instead of refusing it.
    #[serde(default)]
    pub project_initial: bool,
    /// Make the initial velocities consistent with the constraints — the velocities nearest
    /// the given ones in the kinetic-energy metric with `G v = 0`,
    /// `v ← v − W⁻¹Gᵀ (G W⁻¹ Gᵀ)⁻¹ G v` — and report by how much; the positions must satisfy
    /// the constraints as given (refused otherwise, unless `project_initial`).
    #[serde(default)]
    pub consistent_velocities: bool,
    /// What to do with redundant constraints (gradients that depend on the others at the
    /// initial state): `"refuse"` (default: an error naming one) or `"drop-dependent"` (remove
    /// them one by one, each found as the dependent pivot of `G W⁻¹ Gᵀ`, and report which — the
    /// remaining constraints carry the same forces; over-constrained mechanisms whose redundancy
    /// persists along the motion then run). Only single-row constraints (rods, spheres, planes)
    /// are dropped; a dependent row of a pin is refused.
    #[serde(default)]
    pub redundant: Redundant,
}

/// The reversible controller's step density (`integrator.density`).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DensitySpec {
    /// One body (its distance from the origin) or two (their distance).
    pub distance: Vec<String>,
    /// `ρ = r^{−power}`, positive (1.5: Kepler's period at radius `r`).
    pub power: f64,
}

/// `dt` left out of the file: NaN until [`IntegratorSpec::step`] resolves it.
fn missing_step() -> f64 {
    f64::NAN
}

impl IntegratorSpec {
    /// The number of report intervals a run with a tolerance and no `dt` takes.
    pub const DEFAULT_INTERVALS: f64 = 1000.0;

    /// `true` when the file asks for a tolerance (`tol`, `rtol` or `atol`).
    pub fn has_tolerance(&self) -> bool {
        self.tol.is_some() || self.rtol.is_some() || self.atol.is_some()
    }

    /// The step size: `dt`, or with a tolerance and no `dt`, `t_end / 1000` (the interval the
    /// run reports at and the longest first step); NaN without either (refused when compiled,
    /// naming `integrator.dt`).
    pub fn step(&self) -> f64 {
        if self.dt.is_nan() && self.has_tolerance() {
            self.t_end / Self::DEFAULT_INTERVALS
        } else {
            self.dt
        }
    }
}

fn default_diagnostics() -> Vec<Diagnostic> {
    vec![Diagnostic::Energy, Diagnostic::Constraints]
}

/// Switches (all on by default): `false` removes the declared parts of that kind from the
/// assembled model, as if they were not written — no term, no sub-flow, no evaluation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Flags {
    /// Gravity effects.
    pub gravity: bool,
    /// Spring effects.
    pub springs: bool,
    /// Pair potentials.
    pub pair: bool,
    /// Traps.
    pub trap: bool,
    /// Damping.
    pub damping: bool,
    /// Magnetic fields.
    pub magnetic: bool,
    /// Every constraint (the rods of chains and the spheres of shells too).
    pub constraints: bool,
    /// The energy diagnostic.
    pub energy: bool,
    /// The constraint-residual diagnostic.
    pub residuals: bool,
}

impl Flags {
    /// The switch `flag`.
    pub fn get(&self, flag: Flag) -> bool {
        match flag {
            Flag::Gravity => self.gravity,
            Flag::Springs => self.springs,
            Flag::Pair => self.pair,
            Flag::Trap => self.trap,
            Flag::Damping => self.damping,
            Flag::Magnetic => self.magnetic,
            Flag::Constraints => self.constraints,
            Flag::Energy => self.energy,
            Flag::Residuals => self.residuals,
        }
    }

    /// Sets the switch `flag`.
    pub fn set(&mut self, flag: Flag, on: bool) {
        let slot = match flag {
            Flag::Gravity => &mut self.gravity,
            Flag::Springs => &mut self.springs,
            Flag::Pair => &mut self.pair,
            Flag::Trap => &mut self.trap,
            Flag::Damping => &mut self.damping,
            Flag::Magnetic => &mut self.magnetic,
            Flag::Constraints => &mut self.constraints,
            Flag::Energy => &mut self.energy,
            Flag::Residuals => &mut self.residuals,
        };
        *slot = on;
    }

    /// Sets the switch called `name`; `Err` names the valid ones.
    pub fn set_named(&mut self, name: &str, on: bool) -> Result<(), String> {
        let flag = Flag::from_name(name)
            .ok_or_else(|| format!("unknown flag '{name}' (one of {})", Flag::names()))?;
        self.set(flag, on);
        Ok(())
    }
}

impl Default for Flags {
    fn default() -> Self {
        Self {
            gravity: true,
            springs: true,
            pair: true,
            trap: true,
            damping: true,
            magnetic: true,
            constraints: true,
            energy: true,
            residuals: true,
        }
    }
}
