//! `[[events]]`: stop or record when a body crosses a plane or a quantity crosses a value.

use super::SceneInputs;
use super::output::{At, CompiledOutput, OutputSpec, Quantity, Scratch, compile_read};
use crate::scene::bodies::Bodies;
use crate::scene::error::{FieldPath, SceneErrorKind};
use crate::scene::model::SceneModel;
use crate::scene::validate::{Result, err, norm, vector};
use crate::stepper::{Direction, Event};
use crate::vector::Vector;
use serde::Deserialize;
use std::sync::Arc;

/// What the run does at an event.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum EventAction {
    /// Record it and go on (default).
    #[default]
    Record,
    /// Stop the run there.
    Stop,
}

/// The crossing direction, as written.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum DirectionSpec {
    /// From below to above.
    Rising,
    /// From above to below.
    Falling,
    /// Either (default).
    #[default]
    Either,
}

/// A plane `n · q = offset`; a body crosses it from the side `n` points away from
/// (`rising`) or towards it (`falling`).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlaneSpec {
    /// The normal (`dim` entries, non-zero; normalized).
    pub normal: Vec<f64>,
    /// The offset (default 0).
    #[serde(default)]
    pub offset: f64,
}

/// An event: a `body` crossing a `plane`, or a `quantity` (as in `[[outputs]]`) crossing
/// `value`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EventSpec {
    /// Unique name.
    pub name: String,
    /// The body (a plane crossing, or a body's quantity).
    #[serde(default)]
    pub body: Option<String>,
    /// The plane a body crosses.
    #[serde(default)]
    pub plane: Option<PlaneSpec>,
    /// The quantity that crosses `value`.
    #[serde(default)]
    pub quantity: Option<Quantity>,
    /// The coordinate of a body's quantity.
    #[serde(default)]
    pub component: Option<usize>,
    /// The input of an input's quantity.
    #[serde(default)]
    pub input: Option<String>,
    /// The joint of a joint's coordinate (`joint-position`, `joint-velocity`): its name.
    #[serde(default)]
    pub constraint: Option<String>,
    /// The level crossed (default 0).
    #[serde(default)]
    pub value: f64,
    /// `rising`, `falling` or `either` (default).
    #[serde(default)]
    pub direction: DirectionSpec,
    /// `record` (default) or `stop`.
    #[serde(default)]
    pub action: EventAction,
}

/// A scene's compiled events and their names.
pub(crate) type SceneEvents<V> = (Vec<Event<V>>, Vec<String>);

/// Compiles `[[events]]` into the stepper's events over the scene's state (any storage), with
/// their names.
pub(crate) fn compile_events<V: Vector<Real = f64> + 'static>(
    specs: &[EventSpec],
    bodies: &Bodies,
    dim: usize,
    inputs: Option<&SceneInputs<f64>>,
    model: &Arc<SceneModel>,
    joints: &Arc<super::JointTable>,
) -> Result<SceneEvents<V>> {
    let root = FieldPath::root().key("events");
    let mut events = Vec::new();
    let mut names: Vec<String> = Vec::new();
    for (i, spec) in specs.iter().enumerate() {
        let path = root.index(i);
        if spec.name.is_empty() || names.contains(&spec.name) {
            return Err(err(
                SceneErrorKind::Reference,
                path.key("name"),
                format!("event name '{}' is empty or used twice", spec.name),
            ));
        }
        let direction = match spec.direction {
            DirectionSpec::Rising => Direction::Rising,
            DirectionSpec::Falling => Direction::Falling,
            DirectionSpec::Either => Direction::Either,
        };
        let level = crate::scene::validate::finite(spec.value, &path.key("value"))?;
        let event = match (&spec.plane, spec.quantity) {
            (Some(plane), None) => {
                let sel = spec.body.as_deref().ok_or_else(|| {
                    err(
                        SceneErrorKind::Value,
                        path.clone(),
                        "a plane event names a `body`",
                    )
                })?;
                let b = match bodies.select(sel, &path.key("body"))?.as_slice() {
                    [b] => *b,
                    many => {
                        return Err(err(
                            SceneErrorKind::Reference,
                            path.key("body"),
                            format!("'{sel}' names {} bodies; an event watches one", many.len()),
                        ));
                    }
                };
                let n = vector(&plane.normal, dim, &path.key("plane").key("normal"))?;
                let len = norm(n);
                if len == 0.0 {
                    return Err(err(
                        SceneErrorKind::Value,
                        path.key("plane").key("normal"),
                        "the plane's normal is zero",
                    ));
                }
                let n = n.map(|v| v / len);
                let offset = plane.offset + level;
                Event::new(
                    move |_t, x: &V| {
                        let x = x.as_slice();
                        (0..dim).fold(-offset, |s, k| s + n[k] * x[b * dim + k])
                    },
                    direction,
                )
            }
            (None, Some(quantity)) => {
                let out: CompiledOutput = compile_read(
                    &OutputSpec {
                        name: None,
                        quantity,
                        body: spec.body.clone(),
                        component: spec.component,
                        input: spec.input.clone(),
                        constraint: spec.constraint.clone().map(super::ConstraintRef::Name),
                    },
                    bodies,
                    dim,
                    inputs,
                    &super::ConstraintRows::joints_only(joints.clone()),
                    &path,
                    true,
                )?;
                let model = model.clone();
                let joints = joints.clone();
                let mut scratch =
                    Scratch::new(model.state_len(), inputs.map_or(0, |i| i.names.len()));
                Event::new(
                    move |t, x: &V| {
                        let at = At {
                            model: &model,
                            t,
                            x: x.as_slice(),
                            multipliers: None,
                            energies: (0.0, 0.0),
                            joints: &joints,
                        };
                        out.value(&at, &mut scratch) - level
                    },
                    direction,
                )
            }
            _ => {
                return Err(err(
                    SceneErrorKind::Value,
                    path.clone(),
                    "an event watches a `plane` (with a `body`) or a `quantity`, exactly one",
                ));
            }
        };
        names.push(spec.name.clone());
        events.push(match spec.action {
            EventAction::Stop => event.terminal(),
            EventAction::Record => event,
        });
    }
    Ok((events, names))
}
