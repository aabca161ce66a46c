//! What a viewer draws of a compiled scene ([`Sketch`]): its bodies by their slots in the state,
//! the rods, joints, springs and dashpots between them, and the surfaces constraints hold
//! bodies on. It is data only — the slots a drawing reads from a state `x = (q, p)` and the
//! constants of each picture — so a viewer outside the library (the command's animation page,
//! the Python package's) draws any run of the scene from its states alone.
//!
//! Positions: slot `s` of a scene of dimension `d` is at `q[s d .. s d + d]`. A rigid body's
//! directors `Q = [d₁ d₂ d₃]` are slots after its centre (`../shared/docs/METHOD.md` §8; in the
//! plane two, the third being the normal `e_z`); its frame in the world is `R = Q Pᵀ` with `P`
//! its principal axes in the body frame ([`SketchRigid::axes`]), so a point `r` fixed in the
//! body is at `c + R r`.

use crate::scene::bodies::Bodies;
use crate::scene::constraints::Constraint;
use crate::scene::effects::Potential;
use crate::scene::model::SceneModel;
pub use crate::scene::shape::Shape;

/// The orientation of a rigid body in a sketch.
#[derive(Debug, Clone, PartialEq)]
pub struct SketchRigid {
    /// The slots of its directors (two in the plane, three in space).
    pub directors: Vec<usize>,
    /// `P`: its principal axes in its body frame, by columns (`R = Q Pᵀ`).
    pub axes: [[f64; 3]; 3],
    /// What is drawn.
    pub shape: Shape,
}

/// A body of a sketch: a point, or a rigid body's centre with its orientation.
#[derive(Debug, Clone, PartialEq)]
pub struct SketchBody {
    /// Its name in the scene (`"<chain>.<i>"` for a generated one).
    pub name: String,
    /// The slot of its position (of its centre of mass).
    pub slot: usize,
    /// Its mass.
    pub mass: f64,
    /// Its orientation and solid, for a rigid body.
    pub rigid: Option<SketchRigid>,
}

/// An end of a [`Link`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum End {
    /// A point fixed in body `body` (an index into [`Sketch::bodies`]): `offset` in its body
    /// frame (zero for a point body).
    Body {
        /// The body's index in [`Sketch::bodies`].
        body: usize,
        /// The point in the body's frame.
        offset: [f64; 3],
    },
    /// A point fixed in the world.
    World([f64; 3]),
}

/// A line between two ends: a rod, a spring, a dashpot, or a joint (its two ends coincide while
/// the joint holds; its axis, when it has one, in the first end's frame).
#[derive(Debug, Clone, PartialEq)]
pub struct Link {
    /// `"rod"`, `"pin"`, `"spring"`, `"dashpot"`, or the joint's kind (`"hinge"`, `"ball"`,
    /// `"slider"`, `"universal"`).
    pub kind: &'static str,
    /// Its label (`constraints[2] rod 'a'–'b'`).
    pub label: String,
    /// Its first end.
    pub a: End,
    /// Its second end.
    pub b: End,
    /// A joint's axis in the first end's frame (a hinge's, a slider's).
    pub axis: Option<[f64; 3]>,
}

/// A surface a constraint holds bodies on, drawn faintly.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Surface {
    /// `n · q = offset`.
    Plane {
        /// Its unit normal.
        normal: [f64; 3],
        /// Its offset along the normal.
        offset: f64,
    },
    /// `|q − centre| = radius` (a circle in the plane).
    Sphere {
        /// Its centre.
        centre: [f64; 3],
        /// Its radius.
        radius: f64,
    },
}

/// What a viewer draws of a scene of bodies; see the module docs.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Sketch {
    /// The space's dimension, 2 or 3.
    pub dim: usize,
    /// Points and rigid bodies (not the directors, which are part of their bodies).
    pub bodies: Vec<SketchBody>,
    /// Rods, joints, springs, dashpots.
    pub links: Vec<Link>,
    /// Spheres and planes of constraints (each once).
    pub surfaces: Vec<Surface>,
}

/// The sketch of an assembled scene: `bodies` as expanded, `model` with the constraints and
/// effects that are switched on.
pub(crate) fn sketch(bodies: &Bodies, model: &SceneModel) -> Sketch {
    let d = bodies.dim;
    // Scene body index (slot) → sketch body index.
    let mut index = vec![usize::MAX; bodies.list.len()];
    let mut out = Sketch {
        dim: d,
        ..Sketch::default()
    };
    for (slot, b) in bodies.list.iter().enumerate() {
        if b.director {
            continue;
        }
        index[slot] = out.bodies.len();
        let rigid = bodies.rigid_at(slot).map(|r| {
            let directors: Vec<usize> = (1..=d).map(|k| slot + k).collect();
            let shape = r.shape.unwrap_or_else(|| {
                let side = |k: usize| {
                    directors
                        .get(k)
                        .map_or(0.0, |&s| (12.0 * bodies.list[s].mass / b.mass).sqrt())
                };
                Shape::InertiaBox {
                    size: [side(0), side(1), side(2)],
                }
            });
            SketchRigid {
                directors,
                axes: std::array::from_fn(|k| r.axes.column(k)),
                shape,
            }
        });
        out.bodies.push(SketchBody {
            name: b.name.clone(),
            slot,
            mass: b.mass,
            rigid,
        });
    }
    let at = |slot: usize| End::Body {
        body: index[slot],
        offset: [0.0; 3],
    };
    let surface = |s: Surface, out: &mut Sketch| {
        if !out.surfaces.contains(&s) {
            out.surfaces.push(s);
        }
    };
    for t in &model.constraints {
        let label = t.label.clone();
        let link = |kind, a, b| Link {
            kind,
            label: label.clone(),
            a,
            b,
            axis: None,
        };
        match &t.kind {
            Constraint::Rod(r) => {
                out.links
                    .push(link("rod", at(r.a), r.b.map_or(End::World(r.point), at)))
            }
            Constraint::Pin(p) => out.links.push(link("pin", at(p.body), End::World(p.point))),
            Constraint::Sphere(s) => surface(
                Surface::Sphere {
                    centre: s.center,
                    radius: s.radius,
                },
                &mut out,
            ),
            Constraint::Plane(p) => surface(
                Surface::Plane {
                    normal: p.normal,
                    offset: p.offset,
                },
                &mut out,
            ),
            Constraint::Rows(rows) => {
                if let Some(j) = rows.joint_sketch() {
                    let end = |b: Option<usize>, offset| match b {
                        Some(b) => End::Body {
                            body: index[b],
                            offset,
                        },
                        None => End::World(offset),
                    };
                    out.links.push(Link {
                        axis: j.axis,
                        ..link(
                            rows.kind(),
                            end(Some(j.ends.0), j.anchors[0]),
                            end(j.ends.1, j.anchors[1]),
                        )
                    });
                }
            }
        }
    }
    for term in &model.potentials {
        match &term.potential {
            Potential::Pairs(p) => {
                for (a, b) in p.springs() {
                    out.links.push(Link {
                        kind: "spring",
                        label: term.label.clone(),
                        a: at(a),
                        b: at(b),
                        axis: None,
                    });
                }
            }
            // A spring to a fixed point (not a trap's pull on many bodies).
            Potential::Trap(t) if term.kind.name() == "spring" => {
                let (centre, list) = t.ends();
                for &b in list {
                    out.links.push(Link {
                        kind: "spring",
                        label: term.label.clone(),
                        a: at(b),
                        b: End::World(centre),
                        axis: None,
                    });
                }
            }
            _ => {}
        }
    }
    if let Some(dashpots) = &model.dashpots {
        for &(a, b, _) in &dashpots.pairs {
            out.links.push(Link {
                kind: "dashpot",
                label: dashpots.label.clone(),
                a: at(a),
                b: at(b),
                axis: None,
            });
        }
    }
    out
}
