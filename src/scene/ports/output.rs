//! `[[outputs]]`: named quantities of a run, written as CSV columns and drawn.

use super::SceneInputs;
use super::rigid_reads::{JointRead, RigidQuantity, RigidRead};
use super::rows::{ConstraintRef, ConstraintRows};
use crate::scene::bodies::Bodies;
use crate::scene::error::{FieldPath, SceneErrorKind};
use crate::scene::model::SceneModel;
use crate::scene::validate::{Result, err};
use crate::system::Hamiltonian;
use crate::vector::Vector;
use faer::Col;
use serde::Deserialize;
use std::sync::Arc;

/// What an output (or an event's quantity) reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Quantity {
    /// A body's position coordinate (`body`, `component`).
    Position,
    /// A body's velocity coordinate.
    Velocity,
    /// A body's momentum coordinate.
    Momentum,
    /// An input's value `u(t)` (`input`).
    Input,
    /// An input's collocated output `y = Bᵀ∇H` (the velocity conjugate to it).
    PortOutput,
    /// The power an input supplies, `y u`.
    Power,
    /// A constraint multiplier (`constraint`: its name or declared row), the mean of the step's
    /// `λ_k`, `λ_{k+1}`: `λ` of the constraint's internal form (`(|d|² − L²)/2` for a rod), in
    /// newtons per unit of `|∇g|`.
    Multiplier,
    /// The force a constraint row exerts, in newtons: `λ |∇g|` with a sign by kind — a rod's
    /// tension (positive pulls its ends together), a sphere's pull toward its centre, a plane's
    /// push along its normal, a pin's force component.
    ConstraintForce,
    /// A rigid body's orientation as a unit quaternion (`component` 0 … 3: `w, x, y, z`,
    /// `w ≥ 0`).
    Orientation,
    /// A rigid body's angular velocity in the world (rad/s).
    AngularVelocity,
    /// A rigid body's angular velocity in its own frame (rad/s).
    BodyAngularVelocity,
    /// The force a joint (`constraint`: its name) exerts on its first body, world frame, N
    /// (`component` 0/1/2): `−Σ λ_r ∂g_r/∂c` over its rows, the step's mean multipliers.
    JointForce,
    /// The torque a joint exerts on its first body about that body's centre, world frame, N m:
    /// `Σᵢ dᵢ × (−Σ λ_r ∂g_r/∂dᵢ)` over its directors.
    JointTorque,
    /// A joint's coordinate (`constraint`: a named hinge or slider): the hinge's angle (rad),
    /// unwrapped across turns, or the slider's displacement (m), zero at the initial poses.
    JointPosition,
    /// Its rate (rad/s, m/s).
    JointVelocity,
    /// `H`.
    Energy,
    /// The kinetic energy.
    Kinetic,
    /// Energy supplied through the inputs so far.
    Supplied,
    /// Energy dissipated so far.
    Dissipated,
}

/// An output of a run.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutputSpec {
    /// The column's name (default: built from the quantity and its selectors).
    #[serde(default)]
    pub name: Option<String>,
    /// What to read.
    pub quantity: Quantity,
    /// The body (position, velocity, momentum).
    #[serde(default)]
    pub body: Option<String>,
    /// The coordinate (0 = x, 1 = y, 2 = z).
    #[serde(default)]
    pub component: Option<usize>,
    /// The input (input, port-output, power).
    #[serde(default)]
    pub input: Option<String>,
    /// The constraint (multiplier): its `name`, or its row in the scene as declared.
    #[serde(default)]
    pub constraint: Option<ConstraintRef>,
}

/// A compiled output: its name and what it reads.
#[derive(Debug, Clone, PartialEq)]
pub struct CompiledOutput {
    /// The column's name.
    pub name: String,
    pub(crate) read: Read,
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Read {
    Position(usize),
    Velocity(usize, usize),
    Momentum(usize),
    Input(usize),
    PortOutput(usize),
    Power(usize),
    Multiplier(usize),
    /// A row and its term.
    ConstraintForce(usize, usize),
    Rigid(RigidRead),
    Joint(JointRead),
    /// A joint's coordinate (its index in the joint table), or its rate.
    Coordinate(usize, bool),
    Energy,
    Kinetic,
    Supplied,
    Dissipated,
}

/// What an output is evaluated from.
pub(crate) struct At<'a> {
    pub(crate) model: &'a Arc<SceneModel>,
    pub(crate) t: f64,
    pub(crate) x: &'a [f64],
    /// The step's `(λ_k, λ_{k+1})`.
    pub(crate) multipliers: Option<(&'a [f64], &'a [f64])>,
    /// `(supplied, dissipated)` so far.
    pub(crate) energies: (f64, f64),
    /// The joints' coordinates and the run's unwrapping state.
    pub(crate) joints: &'a super::JointTable,
}

/// Buffers for the outputs that evaluate `H` or `∇H` (allocated once, per watcher).
#[derive(Debug, Clone)]
pub(crate) struct Scratch {
    x: Col<f64>,
    grad: Col<f64>,
    y: Vec<f64>,
}

impl Scratch {
    /// For states of length `n` and `inputs` inputs.
    pub(crate) fn new(n: usize, inputs: usize) -> Self {
        Self {
            x: Col::zeros(n),
            grad: Col::zeros(n),
            y: vec![0.0; inputs],
        }
    }

    /// `x` as the model's state type.
    fn state(&mut self, x: &[f64]) -> &Col<f64> {
        self.x.as_mut_slice().copy_from_slice(x);
        &self.x
    }
}

impl CompiledOutput {
    /// The value at `at` (NaN for a multiplier before the first step); allocates nothing.
    pub(crate) fn value(&self, at: &At<'_>, scratch: &mut Scratch) -> f64 {
        let model = at.model;
        let nq = at.x.len() / 2;
        let port = |j: usize| {
            let inputs = model.inputs.as_ref().expect("compiled with inputs");
            (inputs, j)
        };
        match self.read {
            Read::Position(i) => at.x[i],
            Read::Momentum(i) => at.x[nq + i],
            Read::Velocity(b, i) => at.x[nq + i] * model.inv_masses[b],
            Read::Input(j) => {
                let (inputs, j) = port(j);
                inputs.value(j, at.t)
            }
            Read::PortOutput(j) | Read::Power(j) => {
                let (inputs, j) = port(j);
                let y = port_output(model, inputs, at.x, j, scratch);
                match self.read {
                    Read::Power(_) => y * inputs.value(j, at.t),
                    _ => y,
                }
            }
            Read::Multiplier(row) => at
                .multipliers
                .map_or(f64::NAN, |(a, b)| 0.5 * (a[row] + b[row])),
            Read::ConstraintForce(row, term) => {
                let t = &model.constraints[term];
                let scale = t.kind.info().force_per_multiplier(&at.x[..nq], model.dim);
                at.multipliers
                    .map_or(f64::NAN, |(a, b)| 0.5 * (a[row] + b[row]) * scale)
            }
            Read::Rigid(r) => r.value(at.x, &model.inv_masses),
            Read::Joint(j) => j.value(model, at.x, at.multipliers),
            Read::Coordinate(j, false) => at.joints.position(j, &at.x[..nq]),
            Read::Coordinate(j, true) => {
                // v = W⁻¹ p, written into the scratch (allocates nothing).
                let v = scratch.grad.as_mut_slice();
                let d = model.dim;
                for (i, vi) in v[..nq].iter_mut().enumerate() {
                    *vi = at.x[nq + i] * model.inv_masses[i / d];
                }
                at.joints.velocity(j, &at.x[..nq], &v[..nq])
            }
            Read::Energy => model.energy(scratch.state(at.x)),
            Read::Kinetic => model.kinetic_energy(at.x),
            Read::Supplied => at.energies.0,
            Read::Dissipated => at.energies.1,
        }
    }
}

/// `y_j = B_jᵀ ∇H` at `x`.
fn port_output(
    model: &Arc<SceneModel>,
    inputs: &SceneInputs<f64>,
    x: &[f64],
    j: usize,
    scratch: &mut Scratch,
) -> f64 {
    use crate::port::InputMap;
    scratch.state(x);
    model.gradient(&scratch.x, &mut scratch.grad);
    <super::SceneInputMap<f64> as InputMap<Col<f64>>>::transpose_apply(
        &inputs.map,
        &scratch.x,
        &scratch.grad,
        &mut scratch.y,
    );
    scratch.y[j]
}

/// Compiles one selector (outputs and events share it); `events` refuses what an event
/// cannot see (multipliers, the energy ledger).
pub(crate) fn compile_read(
    spec: &OutputSpec,
    bodies: &Bodies,
    dim: usize,
    inputs: Option<&SceneInputs<f64>>,
    rows: &ConstraintRows,
    path: &FieldPath,
    events: bool,
) -> Result<CompiledOutput> {
    let body = |what: &str| -> Result<(usize, usize)> {
        let sel = spec.body.as_deref().ok_or_else(|| {
            err(
                SceneErrorKind::Value,
                path.clone(),
                format!("a {what} output names a `body`"),
            )
        })?;
        let b = match bodies.select(sel, &path.key("body"))?.as_slice() {
            [b] => *b,
            many => {
                return Err(err(
                    SceneErrorKind::Reference,
                    path.key("body"),
                    format!("'{sel}' names {} bodies; an output reads one", many.len()),
                ));
            }
        };
        let k = spec.component.unwrap_or(0);
        if k >= dim {
            return Err(err(
                SceneErrorKind::Dimension,
                path.key("component"),
                format!(
                    "component {k} of a {dim}-dimensional scene (0 … {})",
                    dim - 1
                ),
            ));
        }
        Ok((b, k))
    };
    let input = || -> Result<usize> {
        let name = spec.input.as_deref().ok_or_else(|| {
            err(
                SceneErrorKind::Value,
                path.clone(),
                "this quantity names an `input`",
            )
        })?;
        inputs.and_then(|i| i.index(name)).ok_or_else(|| {
            err(
                SceneErrorKind::Reference,
                path.key("input"),
                format!("'{name}' names no input (the scene's [[inputs]] are named)"),
            )
        })
    };
    let axis = ["x", "y", "z"];
    let bname = |b: usize| bodies.list[b].name.clone();
    let (read, default) = match spec.quantity {
        Quantity::Position => {
            let (b, k) = body("position")?;
            (
                Read::Position(b * dim + k),
                format!("{}.{}", bname(b), axis[k]),
            )
        }
        Quantity::Velocity => {
            let (b, k) = body("velocity")?;
            (
                Read::Velocity(b, b * dim + k),
                format!("{}.v{}", bname(b), axis[k]),
            )
        }
        Quantity::Momentum => {
            let (b, k) = body("momentum")?;
            (
                Read::Momentum(b * dim + k),
                format!("{}.p{}", bname(b), axis[k]),
            )
        }
        Quantity::Input => {
            let j = input()?;
            (
                Read::Input(j),
                format!("u.{}", spec.input.as_deref().unwrap_or("")),
            )
        }
        Quantity::PortOutput => {
            let j = input()?;
            (
                Read::PortOutput(j),
                format!("y.{}", spec.input.as_deref().unwrap_or("")),
            )
        }
        Quantity::Power => {
            let j = input()?;
            (
                Read::Power(j),
                format!("power.{}", spec.input.as_deref().unwrap_or("")),
            )
        }
        Quantity::Multiplier
        | Quantity::ConstraintForce
        | Quantity::JointForce
        | Quantity::JointTorque
        | Quantity::Supplied
        | Quantity::Dissipated
            if events =>
        {
            return Err(err(
                SceneErrorKind::Unsupported,
                path.key("quantity"),
                "an event watches the state and time: positions, velocities, momenta, joint coordinates, inputs, port outputs, powers and energies, not multipliers, constraint forces or the energy ledger",
            ));
        }
        Quantity::Multiplier => {
            let (row, name) = rows.resolve(spec.constraint.as_ref(), spec.component, path)?;
            (Read::Multiplier(row), name)
        }
        Quantity::ConstraintForce => {
            let (row, name) = rows.resolve(spec.constraint.as_ref(), spec.component, path)?;
            let term = rows.term_of(row);
            (
                Read::ConstraintForce(row, term),
                name.replacen("lambda", "force", 1),
            )
        }
        Quantity::Orientation | Quantity::AngularVelocity | Quantity::BodyAngularVelocity => {
            rigid_read(spec, bodies, path)?
        }
        Quantity::JointForce | Quantity::JointTorque => {
            if spec.constraint.is_none() {
                return Err(err(
                    SceneErrorKind::Value,
                    path.clone(),
                    "a joint's force or torque names its joint: `constraint = \"<name>\"`",
                ));
            }
            // The joint's first row names its term; `component` is the vector's.
            let (row, _) = rows.resolve(spec.constraint.as_ref(), Some(0), path)?;
            let k = spec.component.unwrap_or(0);
            if k >= 3 {
                return Err(err(
                    SceneErrorKind::Dimension,
                    path.key("component"),
                    format!("component {k} of a 3-vector (0 … 2)"),
                ));
            }
            let torque = spec.quantity == Quantity::JointTorque;
            let joint = match spec.constraint.as_ref() {
                Some(ConstraintRef::Name(n)) => n.clone(),
                Some(ConstraintRef::Row(r)) => format!("row{r}"),
                None => String::new(),
            };
            let what = if torque { "torque" } else { "force" };
            (
                Read::Joint(JointRead {
                    term: rows.term_of(row),
                    torque,
                    k,
                }),
                format!("{what}_{joint}.{}", axis[k]),
            )
        }
        Quantity::JointPosition | Quantity::JointVelocity => {
            let rate = spec.quantity == Quantity::JointVelocity;
            let at = path.key("constraint");
            let name = match spec.constraint.as_ref() {
                Some(ConstraintRef::Name(n)) => n,
                _ => {
                    return Err(err(
                        SceneErrorKind::Value,
                        at,
                        "a joint's coordinate names its joint: `constraint = \"<name of a hinge or slider>\"`",
                    ));
                }
            };
            let j = rows.joints.find(name).ok_or_else(|| {
                let named = rows.joints.names();
                err(
                    SceneErrorKind::Reference,
                    at.clone(),
                    format!(
                        "'{name}' is not a named hinge or slider (named: {})",
                        if named.is_empty() {
                            "none".to_owned()
                        } else {
                            named.join(", ")
                        }
                    ),
                )
            })?;
            let (what, unit) = match (rows.joints.is_angle(j), rate) {
                (true, false) => ("angle", ""),
                (true, true) => ("angle", "_rate"),
                (false, false) => ("displacement", ""),
                (false, true) => ("displacement", "_rate"),
            };
            (Read::Coordinate(j, rate), format!("{what}{unit}_{name}"))
        }
        Quantity::Energy => (Read::Energy, "H".to_owned()),
        Quantity::Kinetic => (Read::Kinetic, "kinetic".to_owned()),
        Quantity::Supplied => (Read::Supplied, "supplied".to_owned()),
        Quantity::Dissipated => (Read::Dissipated, "dissipated".to_owned()),
    };
    Ok(CompiledOutput {
        name: spec.name.clone().unwrap_or(default),
        read,
    })
}

/// A rigid body's orientation or angular velocity: the body must be rigid, the component in
/// range.
fn rigid_read(spec: &OutputSpec, bodies: &Bodies, path: &FieldPath) -> Result<(Read, String)> {
    let sel = spec.body.as_deref().ok_or_else(|| {
        err(
            SceneErrorKind::Value,
            path.clone(),
            "a rigid body's output names a `body`",
        )
    })?;
    let list = bodies.select(sel, &path.key("body"))?;
    let Some(r) = list
        .as_slice()
        .first()
        .filter(|_| list.len() == 1)
        .and_then(|&b| bodies.rigid_at(b))
    else {
        return Err(err(
            SceneErrorKind::Reference,
            path.key("body"),
            format!("'{sel}' is not one rigid body (a body with an `inertia`)"),
        ));
    };
    let k = spec.component.unwrap_or(0);
    let (what, count, name) = match spec.quantity {
        Quantity::Orientation => (RigidQuantity::Orientation(k), 4, ["qw", "qx", "qy", "qz"]),
        Quantity::AngularVelocity => (RigidQuantity::AngularVelocity(k), 3, ["wx", "wy", "wz", ""]),
        _ => (
            RigidQuantity::BodyAngularVelocity(k),
            3,
            ["Wx", "Wy", "Wz", ""],
        ),
    };
    if k >= count {
        return Err(err(
            SceneErrorKind::Dimension,
            path.key("component"),
            format!("component {k} of {count} (0 … {})", count - 1),
        ));
    }
    let read = Read::Rigid(RigidRead {
        centre: r.centre,
        axes: r.axes,
        dim: bodies.dim,
        what,
    });
    Ok((read, format!("{}.{}", bodies.list[r.centre].name, name[k])))
}

/// Refuses a joint's force or torque output on a term that is not a joint between bodies, or a
/// torque on a joint whose first body is a point (read in the compiled model, which knows the
/// terms' kinds).
pub(crate) fn check_joint_reads(outputs: &[CompiledOutput], model: &SceneModel) -> Result<()> {
    let root = FieldPath::root().key("outputs");
    for (i, o) in outputs.iter().enumerate() {
        let Read::Joint(j) = o.read else {
            continue;
        };
        let first = match &model.constraints[j.term].kind {
            crate::scene::constraints::Constraint::Rows(r) => r.first_body(),
            _ => None,
        };
        let at = root.index(i).key("constraint");
        match first {
            None => {
                return Err(err(
                    SceneErrorKind::Reference,
                    at,
                    "not a joint between bodies (ball, hinge, universal, slider): a rod's, a pin's, a sphere's or a plane's force is `constraint-force`",
                ));
            }
            Some((_, false)) if j.torque => {
                return Err(err(
                    SceneErrorKind::Value,
                    at,
                    "the joint's first body is a point mass: it takes no torque (name the rigid body first)",
                ));
            }
            _ => {}
        }
    }
    Ok(())
}

/// Compiles `[[outputs]]`.
pub(crate) fn compile_outputs(
    specs: &[OutputSpec],
    bodies: &Bodies,
    dim: usize,
    inputs: Option<&SceneInputs<f64>>,
    rows: &ConstraintRows,
) -> Result<Vec<CompiledOutput>> {
    let root = FieldPath::root().key("outputs");
    specs
        .iter()
        .enumerate()
        .map(|(i, s)| compile_read(s, bodies, dim, inputs, rows, &root.index(i), false))
        .collect()
}
