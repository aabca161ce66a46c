//! A scene's inputs: forces on bodies and torques about pivots, each driven by one signal.

use super::signal::SignalSpec;
use crate::real::Real;
use crate::rigid::Coordinate;
use crate::scene::bodies::Bodies;
use crate::scene::error::{FieldPath, SceneErrorKind};
use crate::scene::validate::{Result, err, norm, sub, vector};
use serde::Deserialize;

/// An input, by `type`: its name (for the CSV, the embedder's `set_input`, outputs and
/// events), where it acts, and its signal.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(tag = "type", rename_all = "kebab-case", deny_unknown_fields)]
pub enum InputSpec {
    /// The force `u(t) · direction` on each selected body.
    Force {
        /// Unique name.
        name: String,
        /// The bodies pushed (names or groups).
        bodies: Vec<String>,
        /// The force per unit input (`dim` entries, not normalized).
        direction: Vec<f64>,
        /// `u(t)`.
        signal: SignalSpec,
    },
    /// The torque `u(t)` about `axis` (3D; the plane's normal in 2D) turning `body` about a
    /// fixed `pivot` point or about `pivot_body` (which feels the reaction): the force
    /// `u (â × r)/|r⊥|²` on the body, `r` from the pivot to the body (`r⊥` its part across
    /// the axis), whose moment about the axis is exactly `u`.
    Torque {
        /// Unique name.
        name: String,
        /// The body turned.
        body: String,
        /// A fixed pivot point.
        #[serde(default)]
        pivot: Option<Vec<f64>>,
        /// A body as the pivot (it receives the opposite force).
        #[serde(default)]
        pivot_body: Option<String>,
        /// The axis (3D only; default the z axis).
        #[serde(default)]
        axis: Option<Vec<f64>>,
        /// `u(t)`.
        signal: SignalSpec,
    },
    /// A motor on a hinge: the torque `u(t)` about the axis between two rigid bodies (the second
    /// feels the reaction) or a rigid body and the world, `B(q) = ∇θ(q)` on the directors'
    /// momenta (`θ` the hinge's angle): its port output is `θ'` and its power `u θ'` exactly.
    /// Put it beside a `hinge` about the same axis.
    HingeTorque {
        /// Unique name.
        name: String,
        /// One rigid body (turned against the world) or two, the first rigid.
        bodies: Vec<String>,
        /// The axis in the world at the start.
        #[serde(default)]
        axis: Option<Vec<f64>>,
        /// Or: the axis in each body's frame.
        #[serde(default)]
        axes: Option<Vec<Vec<f64>>>,
        /// `u(t)`, N m.
        signal: SignalSpec,
    },
    /// A linear motor on a slider: the force `u(t)` along the slider's axis between two bodies
    /// (the first rigid; the second feels the reaction) or a body and the world,
    /// `B(q) = ∇s(q)` with `s` the slider's displacement: its port output is `s'` and its power
    /// `u s'` exactly. Put it beside a `slider` with the same anchor and axis.
    SliderForce {
        /// Unique name.
        name: String,
        /// One rigid body (pushed against the world) or two, the first rigid.
        bodies: Vec<String>,
        /// A point of the axis in the world at the start (default: the first body's centre).
        #[serde(default)]
        anchor: Option<Vec<f64>>,
        /// Or: that point in each body's frame.
        #[serde(default)]
        anchors: Option<Vec<Vec<f64>>>,
        /// The axis in the world at the start (the force's positive direction on the first
        /// body).
        #[serde(default)]
        axis: Option<Vec<f64>>,
        /// Or: the axis in each body's frame.
        #[serde(default)]
        axes: Option<Vec<Vec<f64>>>,
        /// `u(t)`, N.
        signal: SignalSpec,
    },
    /// A position servo on a hinge: the torque `k_p (θ_ref(t) − θ) − k_d θ'` about the axis (PD
    /// with the derivative on the measured angle), its reference `θ_ref` the signal (rad, from
    /// the initial poses, within half a turn of them). It is compiled as what it is: a torsion
    /// spring `½ k_p θ²` and a hinge damper `k_d` (the run's energy and dissipation) and the
    /// motor torque `k_p θ_ref(t)` (`B = k_p ∇θ`: its port output is `k_p θ'`, its power the
    /// servo's work `k_p θ_ref θ'`, booked as supplied).
    HingeServo {
        /// Unique name.
        name: String,
        /// One rigid body (turned against the world) or two, the first rigid.
        bodies: Vec<String>,
        /// The axis in the world at the start.
        #[serde(default)]
        axis: Option<Vec<f64>>,
        /// Or: the axis in each body's frame.
        #[serde(default)]
        axes: Option<Vec<Vec<f64>>>,
        /// `k_p > 0`, N m per radian.
        stiffness: f64,
        /// `k_d ≥ 0`, N m s per radian (default 0).
        #[serde(default)]
        damping: f64,
        /// `θ_ref(t)`, rad.
        signal: SignalSpec,
    },
}

impl InputSpec {
    pub(crate) fn name(&self) -> &str {
        match self {
            Self::Force { name, .. }
            | Self::Torque { name, .. }
            | Self::HingeTorque { name, .. }
            | Self::SliderForce { name, .. }
            | Self::HingeServo { name, .. } => name,
        }
    }
    /// `"force on bob"`, `"torque on bob about (0, 0)"`: for `lieflow check`.
    pub(crate) fn describe(&self) -> String {
        let kind = match self.signal() {
            SignalSpec::Constant { .. } => "constant",
            SignalSpec::Step { .. } => "step",
            SignalSpec::Ramp { .. } => "ramp",
            SignalSpec::Sine { .. } => "sine",
            SignalSpec::Table { .. } => "table",
            SignalSpec::Expression { .. } => "expression",
            SignalSpec::Held { .. } => "held",
        };
        match self {
            Self::Force { bodies, .. } => format!("force on {}, {kind}", bodies.join(", ")),
            Self::Torque {
                body, pivot_body, ..
            } => match pivot_body {
                Some(a) => format!("torque on {body} about {a}, {kind}"),
                None => format!("torque on {body} about a fixed pivot, {kind}"),
            },
            Self::HingeTorque { bodies, .. } => {
                format!("torque on the hinge of {}, {kind}", bodies.join(" and "))
            }
            Self::SliderForce { bodies, .. } => {
                format!("force on the slider of {}, {kind}", bodies.join(" and "))
            }
            Self::HingeServo { bodies, .. } => {
                format!(
                    "servo on the hinge of {}, {kind} reference",
                    bodies.join(" and ")
                )
            }
        }
    }
    /// The input's signal as the file gives it.
    pub fn signal(&self) -> &SignalSpec {
        match self {
            Self::Force { signal, .. }
            | Self::Torque { signal, .. }
            | Self::HingeTorque { signal, .. }
            | Self::SliderForce { signal, .. }
            | Self::HingeServo { signal, .. } => signal,
        }
    }
}

/// Where an input acts.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum InputTerm<T> {
    Force {
        bodies: Vec<usize>,
        direction: [T; 3],
    },
    Torque {
        body: usize,
        pivot: Pivot<T>,
        axis: [T; 3],
    },
    /// `B = g ∇c` of a joint's coordinate `c` (a hinge's angle, a slider's displacement), `g`
    /// the gain (1 for a motor, `k_p` for a servo), and the rigid bodies its gradient reaches:
    /// their centres' slots and directors' masses `Eᵢ` (see [`consistent_directors`]).
    Joint(crate::rigid::Coordinate, T, Vec<(usize, [T; 3])>),
}

/// A torque's pivot.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Pivot<T> {
    Point([T; 3]),
    Body(usize),
}

impl InputTerm<f64> {
    pub(crate) fn compile(
        spec: &InputSpec,
        bodies: &Bodies,
        dim: usize,
        path: &FieldPath,
    ) -> Result<Self> {
        Ok(match spec {
            InputSpec::Force {
                bodies: sel,
                direction,
                ..
            } => Self::Force {
                bodies: bodies.select_all(sel, &path.key("bodies"))?,
                direction: vector(direction, dim, &path.key("direction"))?,
            },
            InputSpec::Torque {
                body,
                pivot,
                pivot_body,
                axis,
                ..
            } => {
                let b = single(bodies, body, &path.key("body"))?;
                let pivot = match (pivot, pivot_body) {
                    (Some(p), None) => Pivot::Point(vector(p, dim, &path.key("pivot"))?),
                    (None, Some(a)) => Pivot::Body(single(bodies, a, &path.key("pivot_body"))?),
                    _ => {
                        return Err(err(
                            SceneErrorKind::Value,
                            path.clone(),
                            "a torque takes `pivot` (a point) or `pivot_body`, exactly one",
                        ));
                    }
                };
                let axis = match (axis, dim) {
                    (None, _) => [0.0, 0.0, 1.0],
                    (Some(_), 2) => {
                        return Err(err(
                            SceneErrorKind::Dimension,
                            path.key("axis"),
                            "in 2D the axis is the plane's normal: leave `axis` out",
                        ));
                    }
                    (Some(a), _) => {
                        let a = vector(a, 3, &path.key("axis"))?;
                        let n = norm(a);
                        if n == 0.0 {
                            return Err(err(
                                SceneErrorKind::Value,
                                path.key("axis"),
                                "the axis is zero",
                            ));
                        }
                        a.map(|v| v / n)
                    }
                };
                // The body must start off the axis through the pivot.
                let from = match pivot {
                    Pivot::Point(p) => p,
                    Pivot::Body(a) => bodies.list[a].q,
                };
                let r = sub(bodies.list[b].q, from);
                let along = r[0] * axis[0] + r[1] * axis[1] + r[2] * axis[2];
                let perp = [
                    r[0] - along * axis[0],
                    r[1] - along * axis[1],
                    r[2] - along * axis[2],
                ];
                if norm(perp) == 0.0 {
                    return Err(err(
                        SceneErrorKind::Value,
                        path.key("body"),
                        "the body starts on the torque's axis through the pivot: no lever arm",
                    ));
                }
                Self::Torque {
                    body: b,
                    pivot,
                    axis,
                }
            }
            InputSpec::HingeTorque {
                bodies: sel,
                axis,
                axes,
                ..
            } => Self::joint(
                Coordinate::Angle(super::hinge_angle(sel, axis, axes, bodies, path)?),
                1.0,
                bodies,
            ),
            InputSpec::SliderForce {
                bodies: sel,
                anchor,
                anchors,
                axis,
                axes,
                ..
            } => Self::joint(
                Coordinate::Displacement(super::slider_displacement(
                    sel, anchor, anchors, axis, axes, bodies, path,
                )?),
                1.0,
                bodies,
            ),
            InputSpec::HingeServo {
                bodies: sel,
                axis,
                axes,
                stiffness,
                ..
            } => Self::joint(
                Coordinate::Angle(super::hinge_angle(sel, axis, axes, bodies, path)?),
                crate::scene::validate::positive(*stiffness, &path.key("stiffness"), "stiffness")?,
                bodies,
            ),
        })
    }
}

impl InputTerm<f64> {
    /// The input on `coordinate` with `gain`, and the rigid bodies among its slots.
    fn joint(coordinate: Coordinate, gain: f64, bodies: &Bodies) -> Self {
        use crate::rigid::JointCoordinate;
        let slots = coordinate.slots();
        let rigid = bodies
            .rigid
            .iter()
            .map(|r| r.centre)
            .filter(|&c| slots.iter().any(|&s| (c..=c + bodies.dim).contains(&s)))
            .map(|s| {
                // A planar body's third "director" is the fixed normal: its mass unused.
                let e = |k: usize| {
                    if k < bodies.dim {
                        bodies.list[s + 1 + k].mass
                    } else {
                        1.0
                    }
                };
                (s, [e(0), e(1), e(2)])
            })
            .collect();
        Self::Joint(coordinate, gain, rigid)
    }
}

impl<S: Real> InputTerm<S> {
    /// The same term in another scalar.
    pub(crate) fn with_scalar_from<T: Real>(&self) -> InputTerm<T> {
        let c3 = |v: [S; 3]| v.map(|x| T::lit(x.to_f64_lossy()));
        match self {
            Self::Force { bodies, direction } => InputTerm::Force {
                bodies: bodies.clone(),
                direction: c3(*direction),
            },
            Self::Torque { body, pivot, axis } => InputTerm::Torque {
                body: *body,
                pivot: match pivot {
                    Pivot::Point(p) => Pivot::Point(c3(*p)),
                    Pivot::Body(a) => Pivot::Body(*a),
                },
                axis: c3(*axis),
            },
            Self::Joint(coordinate, gain, rigid) => InputTerm::Joint(
                coordinate.clone(),
                T::lit(gain.to_f64_lossy()),
                rigid.iter().map(|&(s, e)| (s, c3(e))).collect(),
            ),
        }
    }
}

fn single(bodies: &Bodies, sel: &str, path: &FieldPath) -> Result<usize> {
    match bodies.select(sel, path)?.as_slice() {
        [b] => Ok(*b),
        many => Err(err(
            SceneErrorKind::Reference,
            path.clone(),
            format!("'{sel}' names {} bodies; a torque turns one", many.len()),
        )),
    }
}

impl<T: Real> InputTerm<T> {
    /// The force per unit input on the body it turns (torque) or on each body (force), from
    /// positions `q` (`d` per body).
    #[inline]
    pub(crate) fn unit_force(&self, q: &[T], d: usize) -> [T; 3] {
        match self {
            Self::Force { direction, .. } => *direction,
            Self::Joint(..) => [T::zero(); 3],
            Self::Torque { body, pivot, axis } => {
                let from = match pivot {
                    Pivot::Point(p) => *p,
                    Pivot::Body(a) => position(q, *a, d),
                };
                let qb = position(q, *body, d);
                let r = [qb[0] - from[0], qb[1] - from[1], qb[2] - from[2]];
                let along = r[0] * axis[0] + r[1] * axis[1] + r[2] * axis[2];
                let perp = [
                    r[0] - along * axis[0],
                    r[1] - along * axis[1],
                    r[2] - along * axis[2],
                ];
                let r2 = perp[0] * perp[0] + perp[1] * perp[1] + perp[2] * perp[2];
                let f = [
                    axis[1] * r[2] - axis[2] * r[1],
                    axis[2] * r[0] - axis[0] * r[2],
                    axis[0] * r[1] - axis[1] * r[0],
                ];
                f.map(|v| v / r2)
            }
        }
    }
}

fn position<T: Real>(q: &[T], b: usize, d: usize) -> [T; 3] {
    let mut out = [T::zero(); 3];
    out[..d].copy_from_slice(&q[b * d..b * d + d]);
    out
}
