//! A scene's ports: `[[inputs]]` (forces and torques driven by signals), `[[outputs]]` (the
//! quantities `lieflow run` writes and draws) and `[[events]]` (stop or record when a body
//! crosses a plane or a quantity crosses a value).
//!
//! An input `j` with unit force `f_j(q)` (on momenta only, so `B(q) = [0; f(q)]`) enters the
//! model as `x' = M(∇H + Gᵀλ) + B(q) u(t)`; its exact sub-flow `p ← p + f(q) ∫u dt` joins the
//! kick of the splitting and carries the time (see [`crate::port`]). The collocated output is
//! `y_j = f_j(q) · v` (the velocity conjugate to the input), the power it supplies `y_j u_j`.

mod event;
mod expr;
mod input;
mod joint_position;
mod output;
mod rigid_reads;
mod rows;
mod signal;

pub use event::{EventAction, EventSpec, PlaneSpec};
pub use input::InputSpec;
pub use output::{OutputSpec, Quantity};
pub use rows::ConstraintRef;
pub use signal::SignalSpec;

pub(crate) use event::{SceneEvents, compile_events};
pub(crate) use input::InputTerm;
pub(crate) use joint_position::{JointTable, joint_table};
pub(crate) use output::{At, CompiledOutput, Read, Scratch, check_joint_reads, compile_outputs};
pub(crate) use rows::ConstraintRows;

use crate::port::{Held, InputMap, Signal};
use crate::real::Real;
use crate::rigid::JointCoordinate;
use crate::scene::bodies::Bodies;
use crate::scene::error::{FieldPath, SceneErrorKind};
use crate::scene::validate::{Result, err};
use crate::vector::Vector;
use num_traits::Zero;
use std::sync::Arc;

/// The compiled inputs of a scene: where each acts, its signal and its name.
#[derive(Debug, Clone)]
pub struct SceneInputs<T> {
    pub(crate) map: SceneInputMap<T>,
    pub(crate) signals: Vec<Signal<T>>,
    pub(crate) names: Vec<String>,
}

impl<T: Real> SceneInputs<T> {
    /// The input names, in file order.
    pub fn names(&self) -> &[String] {
        &self.names
    }
    /// The index of the input called `name`.
    pub fn index(&self, name: &str) -> Option<usize> {
        self.names.iter().position(|n| n == name)
    }
    /// The handle of a `held` input (to set it between steps); `None` for other signals.
    pub fn held(&self, j: usize) -> Option<&Held> {
        match self.signals.get(j) {
            Some(Signal::Held(h)) => Some(h),
            _ => None,
        }
    }
    /// `u_j(t)`.
    pub fn value(&self, j: usize, t: T) -> T {
        self.signals[j].value(t)
    }
    /// The input map `B(q)` (the inputs' unit forces on the momenta).
    pub fn map(&self) -> &SceneInputMap<T> {
        &self.map
    }
    /// The signals, one per input, in file order.
    pub fn signals(&self) -> &[Signal<T>] {
        &self.signals
    }
    /// The same inputs in another scalar (reference runs): expressions are evaluated in `f64`.
    pub(crate) fn with_scalar<S: Real>(&self) -> SceneInputs<S> {
        let signals = self
            .signals
            .iter()
            .map(|s| match s {
                Signal::Constant(c) => Signal::Constant(lit(*c)),
                Signal::Step { at, before, after } => Signal::Step {
                    at: lit(*at),
                    before: lit(*before),
                    after: lit(*after),
                },
                Signal::Ramp {
                    start,
                    end,
                    from,
                    to,
                } => Signal::Ramp {
                    start: lit(*start),
                    end: lit(*end),
                    from: lit(*from),
                    to: lit(*to),
                },
                Signal::Sine {
                    amplitude,
                    omega,
                    phase,
                    offset,
                } => Signal::Sine {
                    amplitude: lit(*amplitude),
                    omega: lit(*omega),
                    phase: lit(*phase),
                    offset: lit(*offset),
                },
                Signal::Table(p) => {
                    Signal::Table(p.iter().map(|&(t, u)| (lit(t), lit(u))).collect())
                }
                Signal::Held(h) => Signal::Held(h.clone()),
                Signal::Function(f) => {
                    let f = f.clone();
                    Signal::Function(Arc::new(move |t: S| {
                        S::lit(f(T::lit(t.to_f64_lossy())).to_f64_lossy())
                    }))
                }
            })
            .collect();
        SceneInputs {
            map: SceneInputMap {
                dim: self.map.dim,
                nq: self.map.nq,
                terms: self
                    .map
                    .terms
                    .iter()
                    .map(|t| t.with_scalar_from())
                    .collect(),
            },
            signals,
            names: self.names.clone(),
        }
    }
}

fn lit<T: Real, S: Real>(v: T) -> S {
    S::lit(v.to_f64_lossy())
}

/// `B(q)` of a scene's inputs: the unit force of each input on the momenta.
#[derive(Debug, Clone)]
pub struct SceneInputMap<T> {
    dim: usize,
    nq: usize,
    terms: Arc<[InputTerm<T>]>,
}

impl<V: Vector> InputMap<V> for SceneInputMap<V::Real> {
    fn inputs(&self) -> usize {
        self.terms.len()
    }
    /// The splittings' kick: `p ← p + B(q) w`, a joint input's impulse on each rigid body's
    /// directors without its part along the body's own rows ([`consistent_directors`]).
    fn apply(&self, x: &mut V, w: &[V::Real]) {
        let (q, p) = x.as_mut_slice().split_at_mut(self.nq);
        self.push(q, p, w, true);
    }
    /// `B(q)` at `x`'s positions onto `out`'s momenta: exact.
    fn add_product(&self, x: &V, w: &[V::Real], out: &mut V, _scratch: &mut V) {
        let q = &x.as_slice()[..self.nq];
        self.push(q, &mut out.as_mut_slice()[self.nq..], w, false);
    }
    fn transpose_apply(&self, x: &V, e: &V, y: &mut [V::Real]) {
        let d = self.dim;
        let q = &x.as_slice()[..self.nq];
        let v = &e.as_slice()[self.nq..];
        let dot = |f: &[V::Real; 3], b: usize| {
            (0..d).fold(V::Real::zero(), |s, k| s + f[k] * v[b * d + k])
        };
        for (term, yj) in self.terms.iter().zip(y.iter_mut()) {
            let f = term.unit_force(q, d);
            *yj = match term {
                InputTerm::Joint(coordinate, gain, _) => *gain * coordinate.derivative(q, v),
                InputTerm::Force { bodies, .. } => {
                    bodies.iter().fold(V::Real::zero(), |s, &b| s + dot(&f, b))
                }
                InputTerm::Torque { body, pivot, .. } => {
                    let own = dot(&f, *body);
                    match pivot {
                        input::Pivot::Body(a) => own - dot(&f, *a),
                        input::Pivot::Point(_) => own,
                    }
                }
            };
        }
    }
}

impl<T: Real> SceneInputMap<T> {
    /// `p ← p + B(q) w`: each input's unit force at `q`, times its `w`, on the momenta of the
    /// bodies it drives; with `consistent`, a joint input's impulse on each rigid body's
    /// directors without its part along the body's own rows.
    fn push(&self, q: &[T], p: &mut [T], w: &[T], consistent: bool) {
        let d = self.dim;
        for (term, &wj) in self.terms.iter().zip(w) {
            if let InputTerm::Joint(coordinate, gain, rigid) = term {
                if !consistent || rigid.is_empty() {
                    coordinate.gradient_add(q, *gain * wj, p);
                    continue;
                }
                // The directors' momenta before, to take the impulse apart (at most two bodies).
                let mut before = [[T::zero(); 9]; 2];
                for (b, &(c, _)) in before.iter_mut().zip(rigid.iter()) {
                    b[..d * d].copy_from_slice(&p[(c + 1) * d..(c + 1 + d) * d]);
                }
                coordinate.gradient_add(q, *gain * wj, p);
                for (b, &(c, e)) in before.iter().zip(rigid.iter()) {
                    let range = (c + 1) * d..(c + 1 + d) * d;
                    consistent_directors(&q[range.clone()], &b[..d * d], &mut p[range], e, d);
                }
                continue;
            }
            let f = term.unit_force(q, d);
            let mut push = |b: usize, s: T| {
                for k in 0..d {
                    p[b * d + k] = p[b * d + k] + s * wj * f[k];
                }
            };
            match term {
                InputTerm::Joint(..) => {}
                InputTerm::Force { bodies, .. } => bodies.iter().for_each(|&b| push(b, T::one())),
                InputTerm::Torque { body, pivot, .. } => {
                    push(*body, T::one());
                    if let input::Pivot::Body(a) = pivot {
                        push(*a, -T::one());
                    }
                }
            }
        }
    }
}

/// A rigid body's director momenta `after = before + δ` with the impulse `δ` replaced by its
/// part consistent with the body's own rows `QᵀQ = I` in the kinetic metric (`../shared/docs/
/// METHOD.md` §8): `δ − Q S`, `S` symmetric with `S_ik = (P_ik Eᵢ + P_ki E_k)/(Eᵢ + E_k)`,
/// `P = Qᵀδ`, so that `Qᵀ W⁻¹ (δ − Q S)` is skew — a turn of the frame, no stretch of it. The part
/// taken away lies along the rows' gradients `Q S`, which the projection's multipliers absorb
/// whatever it is (RATTLE's step is the same), but its kinetic energy would be booked as
/// supplied by the kick and then removed by the projection. `q`, `before`, `after`: the `n`
/// directors' `n` components each (`n` = 2 in the plane, 3 in space); `e` their masses.
fn consistent_directors<T: Real>(q: &[T], before: &[T], after: &mut [T], e: [T; 3], n: usize) {
    let mut delta = [[T::zero(); 3]; 3];
    for k in 0..n {
        for c in 0..n {
            delta[k][c] = after[k * n + c] - before[k * n + c];
        }
    }
    // P_ik = d_i · δ_k.
    let mut s = [[T::zero(); 3]; 3];
    for i in 0..n {
        for k in 0..n {
            let pik = (0..n).fold(T::zero(), |a, c| a + q[i * n + c] * delta[k][c]);
            s[i][k] = pik;
        }
    }
    let p = s;
    for i in 0..n {
        for k in 0..n {
            s[i][k] = (p[i][k] * e[i] + p[k][i] * e[k]) / (e[i] + e[k]);
        }
    }
    for k in 0..n {
        for c in 0..n {
            let qs = (0..n).fold(T::zero(), |a, i| a + q[i * n + c] * s[i][k]);
            after[k * n + c] = before[k * n + c] + delta[k][c] - qs;
        }
    }
}

/// The angle of the first of `sel`'s bodies against the second (or the world) about `axis`
/// (world, at the start) or `axes` (each body's frame), zero at the initial poses, positive
/// counter-clockwise about the axis.
pub(crate) fn hinge_angle(
    sel: &[String],
    axis: &Option<Vec<f64>>,
    axes: &Option<Vec<Vec<f64>>>,
    bodies: &Bodies,
    path: &FieldPath,
) -> Result<crate::rigid::HingeAngle> {
    use crate::scene::constraints::joint;
    let ends = joint::ends(sel, bodies, path, "hinge")?;
    let [axis_a, axis_b] = joint::hinge_axes(axis, axes, ends, bodies, path)?;
    let entries = bodies.entries(&ends.list());
    let frames = bodies.frames(&entries);
    // `HingeAngle` measures its second body against its first: the first named body turns
    // against the second (or the world), positive counter-clockwise about the axis.
    let hinge = crate::rigid::Hinge {
        a: joint::body_ref(1, ends.b),
        anchor_a: [0.0; 3],
        axis_a: axis_b,
        b: joint::body_ref(0, Some(ends.a)),
        anchor_b: [0.0; 3],
        axis_b: axis_a,
    };
    crate::rigid::HingeAngle::of(&hinge, &frames)
        .map_err(|e| err(SceneErrorKind::Value, path.clone(), e.to_string()))
}

/// The displacement along a slider's axis of the first of `sel`'s bodies (rigid) from the
/// second (or the world), zero at the initial poses: the anchors and axes as a `slider`
/// constraint reads them (the anchor defaults to the first body's centre).
pub(crate) fn slider_displacement(
    sel: &[String],
    anchor: &Option<Vec<f64>>,
    anchors: &Option<Vec<Vec<f64>>>,
    axis: &Option<Vec<f64>>,
    axes: &Option<Vec<Vec<f64>>>,
    bodies: &Bodies,
    path: &FieldPath,
) -> Result<crate::rigid::SliderDisplacement> {
    use crate::scene::constraints::joint;
    let ends = joint::ends(sel, bodies, path, "slider")?;
    let anchor = match (anchor, anchors) {
        (None, None) => Some(bodies.list[ends.a].q[..bodies.dim].to_vec()),
        (a, _) => a.clone(),
    };
    let [anchor_a, anchor_b] = joint::anchors(&anchor, anchors, ends, bodies, path)?;
    let [axis_a, _] = joint::axes(axis, axes, ("axis", "axes"), ends, bodies, path)?;
    let slider = crate::rigid::Slider {
        a: joint::body_ref(0, Some(ends.a)),
        anchor_a,
        axis_a,
        b: joint::body_ref(1, ends.b),
        anchor_b,
    };
    let entries = bodies.entries(&ends.list());
    let frames = bodies.frames(&entries);
    crate::rigid::SliderDisplacement::of(&slider, &frames)
        .map_err(|e| err(SceneErrorKind::Value, path.clone(), e.to_string()))
}

/// Compiles `[[inputs]]`; `None` when there are none.
pub(crate) fn compile_inputs(
    specs: &[InputSpec],
    bodies: &Bodies,
    dim: usize,
    base_dir: Option<&std::path::Path>,
) -> Result<Option<SceneInputs<f64>>> {
    if specs.is_empty() {
        return Ok(None);
    }
    let root = FieldPath::root().key("inputs");
    let mut names: Vec<String> = Vec::new();
    let mut terms = Vec::new();
    let mut signals = Vec::new();
    for (i, spec) in specs.iter().enumerate() {
        let path = root.index(i);
        let name = spec.name();
        if name.is_empty() || names.iter().any(|n| n == name) {
            return Err(err(
                SceneErrorKind::Reference,
                path.key("name"),
                format!("input name '{name}' is empty or used twice"),
            ));
        }
        names.push(name.to_owned());
        terms.push(InputTerm::compile(spec, bodies, dim, &path)?);
        signals.push(spec.signal().compile(&path.key("signal"), base_dir)?);
    }
    Ok(Some(SceneInputs {
        map: SceneInputMap {
            dim,
            nq: dim * bodies.list.len(),
            terms: terms.into(),
        },
        signals,
        names,
    }))
}
