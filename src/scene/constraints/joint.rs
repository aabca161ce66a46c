//! What the joints between bodies share: their ends (one or two bodies — one joins a body to
//! the world), their anchors and axes (given in the world at the start, or in each body's
//! frame), and their rows built by the library's joint kinds (`crate::rigid::joints`) on the
//! scene's slots as one [`Rows`] term.

use super::{Constraint, Declared, rows::Rows};
use crate::rigid::{BodyRef, JointKind, Placement, Rotation};
use crate::scene::bodies::Bodies;
use crate::scene::error::{FieldPath, SceneErrorKind};
use crate::scene::validate::{Result, err, vector};

/// A joint's bodies: `a`, and `b` or the world.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Ends {
    pub(crate) a: usize,
    pub(crate) b: Option<usize>,
    /// Where each named body sits in the body the end is (a member of a welded body: its
    /// placement; otherwise the identity).
    pub(crate) place: [Placement; 2],
}

impl Ends {
    /// `[a]` or `[a, b]`: the bodies `BodyRef::Body(0)` and `Body(1)` name.
    pub(crate) fn list(&self) -> Vec<usize> {
        let mut v = vec![self.a];
        v.extend(self.b);
        v
    }
}

/// The one or two bodies `sel` names, each one body, different; ball and universal joints in 3D
/// scenes only.
pub(crate) fn ends(sel: &[String], bodies: &Bodies, path: &FieldPath, kind: &str) -> Result<Ends> {
    if bodies.dim != 3 {
        let why = match kind {
            "ball" => Some("in the plane a ball joint is a pin: use `type = \"hinge\"`"),
            "universal" => Some("a universal joint needs dim = 3"),
            _ => None,
        };
        if let Some(why) = why {
            return Err(err(SceneErrorKind::Dimension, path.clone(), why));
        }
    }
    let bp = path.key("bodies");
    let one = |j: usize, s: &String| -> Result<(usize, Placement)> {
        let (v, place) = bodies.joint_end(s, &bp.index(j))?;
        match v.as_slice() {
            &[b] => Ok((b, place)),
            _ => Err(err(
                SceneErrorKind::Reference,
                bp.index(j),
                format!("'{s}' names {} bodies; a joint's end is one body", v.len()),
            )),
        }
    };
    match sel {
        [a] => {
            let (a, place) = one(0, a)?;
            Ok(Ends {
                a,
                b: None,
                place: [place, Placement::identity()],
            })
        }
        [a, b] => {
            let ((a, pa), (b, pb)) = (one(0, a)?, one(1, b)?);
            if a == b {
                return Err(err(
                    SceneErrorKind::Value,
                    bp,
                    "a joint joins two different bodies (or one body and the world; welded bodies are one)",
                ));
            }
            Ok(Ends {
                a,
                b: Some(b),
                place: [pa, pb],
            })
        }
        _ => Err(err(
            SceneErrorKind::Value,
            bp,
            format!(
                "a {kind} joint names one body (joined to the world) or two, not {}",
                sel.len()
            ),
        )),
    }
}

/// The body frame of end `b` (`None`: the world): its centre and orientation at the start.
fn frame(bodies: &Bodies, b: Option<usize>) -> ([f64; 3], Rotation) {
    match b {
        None => ([0.0; 3], Rotation::identity()),
        Some(b) => (
            bodies.list[b].q,
            bodies
                .rigid_at(b)
                .map_or_else(Rotation::identity, |r| r.orientation),
        ),
    }
}

/// The anchor in each end's frame: from `anchor`, a world point at the start, or `anchors`,
/// one per end in its own frame (a world point for the world).
pub(crate) fn anchors(
    anchor: &Option<Vec<f64>>,
    anchors: &Option<Vec<Vec<f64>>>,
    ends: Ends,
    bodies: &Bodies,
    path: &FieldPath,
) -> Result<[[f64; 3]; 2]> {
    per_end(
        anchor,
        anchors,
        ("anchor", "anchors"),
        ends,
        bodies,
        path,
        true,
    )
}

/// An axis in each end's frame: from `axis`, a world direction at the start, or `axes`, one per
/// end in its own frame.
pub(crate) fn axes(
    axis: &Option<Vec<f64>>,
    axes: &Option<Vec<Vec<f64>>>,
    names: (&str, &str),
    ends: Ends,
    bodies: &Bodies,
    path: &FieldPath,
) -> Result<[[f64; 3]; 2]> {
    per_end(axis, axes, names, ends, bodies, path, false)
}

/// A hinge's axis in each end's frame: as [`axes`]; in a planar scene the plane's normal `e_z`,
/// which the scene may not name otherwise (a planar hinge turns in the plane).
pub(crate) fn hinge_axes(
    axis: &Option<Vec<f64>>,
    axes: &Option<Vec<Vec<f64>>>,
    ends: Ends,
    bodies: &Bodies,
    path: &FieldPath,
) -> Result<[[f64; 3]; 2]> {
    if bodies.dim == 2 {
        if let Some(key) = [("axis", axis.is_some()), ("axes", axes.is_some())]
            .into_iter()
            .find_map(|(k, set)| set.then_some(k))
        {
            return Err(err(
                SceneErrorKind::Value,
                path.key(key),
                "a planar hinge turns about the plane's normal: give no axis",
            ));
        }
        return Ok([[0.0, 0.0, 1.0]; 2]);
    }
    self::axes(axis, axes, ("axis", "axes"), ends, bodies, path)
}

/// A point (`point`) or direction in both ends' frames, from a world value or per-end values.
fn per_end(
    world: &Option<Vec<f64>>,
    each: &Option<Vec<Vec<f64>>>,
    (one, two): (&str, &str),
    ends: Ends,
    bodies: &Bodies,
    path: &FieldPath,
    point: bool,
) -> Result<[[f64; 3]; 2]> {
    match (world, each) {
        (Some(w), None) => {
            let w = vector(w, bodies.dim, &path.key(one))?;
            let local = |b: Option<usize>| {
                let (c, r) = frame(bodies, b);
                let rel = if point {
                    core::array::from_fn(|k| w[k] - c[k])
                } else {
                    w
                };
                r.transpose().apply(rel)
            };
            Ok([local(Some(ends.a)), local(ends.b)])
        }
        (None, Some(v)) => {
            let p = path.key(two);
            if v.len() != 2 {
                return Err(err(
                    SceneErrorKind::Dimension,
                    p,
                    format!(
                        "one per end, in its frame (a world value for the world): two, not {}",
                        v.len()
                    ),
                ));
            }
            // A member of a welded body gives its values in its own frame.
            let carry = |k: usize, x: [f64; 3]| {
                let place = &ends.place[k];
                if point {
                    place.point(x)
                } else {
                    place.direction(x)
                }
            };
            Ok([
                carry(0, vector(&v[0], bodies.dim, &p.index(0))?),
                carry(1, vector(&v[1], bodies.dim, &p.index(1))?),
            ])
        }
        _ => Err(err(
            SceneErrorKind::Value,
            path.clone(),
            format!(
                "give `{one}` (in the world, at the start) or `{two}` (one per end, in its frame), exactly one"
            ),
        )),
    }
}

/// The library's `joint` (with ends `BodyRef::Body(0)` = `a`, `Body(1)` = `b`, or the world)
/// built on the scene's slots and appended to `out` as one term; its anchors (one per end, in
/// its frame) and axis (in the first end's frame) are kept for drawings.
pub(super) fn declare(
    joint: &dyn JointKind,
    ends: Ends,
    (anchors, axis): ([[f64; 3]; 2], Option<[f64; 3]>),
    bodies: &Bodies,
    i: usize,
    path: &FieldPath,
    out: &mut Vec<Declared>,
) -> Result<()> {
    let entries = bodies.entries(&ends.list());
    let q0 = bodies.positions();
    let frames = bodies.frames(&entries);
    let rows = crate::rigid::joints::joint_rows(joint, &frames)
        .map_err(|e| err(SceneErrorKind::Value, path.clone(), e.to_string()))?;
    let name = |b: usize| format!("'{}'", bodies.list[b].name);
    let label = match ends.b {
        Some(b) => format!(
            "constraints[{i}] {} {}–{}",
            joint.name(),
            name(ends.a),
            name(b)
        ),
        None => format!("constraints[{i}] {} {}–world", joint.name(), name(ends.a)),
    };
    out.push((
        Constraint::Rows(
            Rows::new(joint.name(), (ends.a, ends.b), rows, q0.len(), bodies.dim)
                .with_rigid_first(bodies.rigid_at(ends.a).is_some())
                .with_anchors(anchors, axis),
        ),
        label,
        path.clone(),
    ));
    Ok(())
}

/// The library's reference to end `b` (`None`: the world).
pub(crate) fn body_ref(index: usize, b: Option<usize>) -> BodyRef {
    b.map_or(BodyRef::World, |_| BodyRef::Body(index))
}
