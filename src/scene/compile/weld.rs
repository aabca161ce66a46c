//! Welds merged before the run: the `[[constraints]]` of `type = "weld"` group the bodies
//! declared in `[[bodies]]` (union–find), and each group becomes one rigid body
//! (`crate::rigid::weld`: the group's mass, centre of mass and inertia by parallel axes) named
//! after its first-declared rigid member, in that member's frame. Every member keeps its
//! placement in the merged body, so a joint's anchors and axes given in a member's frame
//! are carried over; effects, outputs and events name the merged body.

use super::Result;
use super::validate::err;
use crate::rigid::Part;
use crate::scene::bodies::Welding;
use crate::scene::constraints::ConstraintSpec;
use crate::scene::error::{FieldPath, SceneErrorKind};
use crate::scene::schema::SceneFile;
use std::collections::HashMap;

/// The groups of welded bodies, by their indices in `[[bodies]]`.
pub(crate) struct WeldGroups {
    /// Each declared body's group, if it is welded.
    pub(crate) member_of: Vec<Option<usize>>,
    /// Each group's members in order of declaration, its frame member (the first rigid one),
    /// and the weld that formed it (for messages).
    pub(crate) groups: Vec<Group>,
}

/// One group of welded bodies.
pub(crate) struct Group {
    pub(crate) members: Vec<usize>,
    /// The first rigid member: the merged body's name and frame.
    pub(crate) frame: usize,
    /// Where the group's first weld is written.
    pub(crate) path: FieldPath,
}

fn find(parent: &mut [usize], mut i: usize) -> usize {
    while parent[i] != i {
        parent[i] = parent[parent[i]];
        i = parent[i];
    }
    i
}

/// Reads the welds that are not switched off and groups the bodies they join.
pub(crate) fn weld_groups(file: &SceneFile) -> Result<WeldGroups> {
    let n = file.bodies.len();
    let index: HashMap<&str, usize> = file
        .bodies
        .iter()
        .enumerate()
        .map(|(i, b)| (b.name.as_str(), i))
        .collect();
    let mut parent: Vec<usize> = (0..n).collect();
    let mut first: HashMap<usize, FieldPath> = HashMap::new();
    let mut welded = vec![false; n];
    let root = FieldPath::root().key("constraints");
    for (i, c) in file.constraints.iter().enumerate() {
        let ConstraintSpec::Weld(w) = c else { continue };
        if w.name.as_ref().is_some_and(|name| file.off.contains(name)) {
            continue;
        }
        let path = root.index(i);
        let bp = path.key("bodies");
        if w.bodies.len() != 2 {
            return Err(err(
                SceneErrorKind::Value,
                bp,
                format!(
                    "a weld joins two bodies, not {} (a body fixed to the world is part of the world: anchor its joints there)",
                    w.bodies.len()
                ),
            ));
        }
        let mut ends = [0; 2];
        for (k, name) in w.bodies.iter().enumerate() {
            ends[k] = *index.get(name.as_str()).ok_or_else(|| {
                err(
                    SceneErrorKind::Reference,
                    bp.index(k),
                    format!(
                        "'{name}' is not a body declared in [[bodies]] (only those are welded)"
                    ),
                )
            })?;
        }
        if ends[0] == ends[1] {
            return Err(err(
                SceneErrorKind::Value,
                bp,
                "a weld joins two different bodies",
            ));
        }
        let (ra, rb) = (find(&mut parent, ends[0]), find(&mut parent, ends[1]));
        let (lo, hi) = (ra.min(rb), ra.max(rb));
        parent[hi] = lo;
        let earliest = [first.remove(&lo), first.remove(&hi)]
            .into_iter()
            .flatten()
            .next()
            .unwrap_or(path);
        first.insert(lo, earliest);
        welded[ends[0]] = true;
        welded[ends[1]] = true;
    }
    let mut member_of = vec![None; n];
    let mut groups: Vec<Group> = Vec::new();
    let mut group_of_root: HashMap<usize, usize> = HashMap::new();
    for b in (0..n).filter(|&b| welded[b]) {
        let r = find(&mut parent, b);
        let g = *group_of_root.entry(r).or_insert_with(|| {
            groups.push(Group {
                members: Vec::new(),
                frame: usize::MAX,
                path: first[&r].clone(),
            });
            groups.len() - 1
        });
        groups[g].members.push(b);
        if groups[g].frame == usize::MAX && file.bodies[b].inertia.is_some() {
            groups[g].frame = b;
        }
        member_of[b] = Some(g);
    }
    for g in &groups {
        if g.frame == usize::MAX {
            return Err(err(
                SceneErrorKind::Value,
                g.path.key("bodies"),
                "welded bodies need a rigid body (an `inertia`) among them: it gives the merged body its frame",
            ));
        }
    }
    Ok(WeldGroups { member_of, groups })
}

/// Merges `parts` (the members of `group`, in order, and their names) into one body; a part
/// that does not move with the others is refused at its `velocity`.
pub(crate) fn merge(group: &Group, parts: &[Part], names: &[&str]) -> Result<crate::rigid::Welded> {
    let frame = group
        .members
        .iter()
        .position(|&m| m == group.frame)
        .unwrap_or(0);
    crate::rigid::weld(parts, frame).map_err(|e| {
        let mut message = e.to_string();
        for (k, name) in names.iter().enumerate().rev() {
            message = message.replace(&format!("welded part {k}"), &format!("'{name}'"));
        }
        let at = names
            .iter()
            .position(|name| message.contains(&format!("velocity of '{name}'")))
            .map_or_else(
                || group.path.key("bodies"),
                |k| {
                    FieldPath::root()
                        .key("bodies")
                        .index(group.members[k])
                        .key("velocity")
                },
            );
        err(
            SceneErrorKind::Value,
            at,
            format!("welding {}: {message}", names.join(", ")),
        )
    })
}

/// Appends `group` as one rigid body (at its frame member's place in the list): its members
/// resolved as parts, merged, pushed under the frame member's name; every member's placement
/// recorded in `bodies.welded`.
pub(crate) fn push_welded(
    bodies: &mut crate::scene::bodies::Bodies,
    file: &SceneFile,
    group: &Group,
    generated: &mut Vec<crate::scene::constraints::Declared>,
) -> Result<()> {
    let root = FieldPath::root().key("bodies");
    let mut parts = Vec::with_capacity(group.members.len());
    for &m in &group.members {
        let (b, path) = (&file.bodies[m], root.index(m));
        parts.push(match &b.inertia {
            Some(inertia) => Part::Rigid(super::rigid::rigid_body(b, inertia, bodies.dim, &path)?),
            None => {
                if super::validate::finite(b.charge, &path.key("charge"))? != 0.0 {
                    return Err(err(
                        SceneErrorKind::Unsupported,
                        path.key("charge"),
                        "a welded body carries no charge (it becomes part of a rigid body)",
                    ));
                }
                let mass = b.mass.ok_or_else(|| {
                    err(
                        SceneErrorKind::Value,
                        path.key("mass"),
                        "a body needs a `mass`",
                    )
                })?;
                Part::Point {
                    mass: super::validate::positive(mass, &path.key("mass"), "mass")?,
                    position: super::validate::vector(
                        &b.position,
                        bodies.dim,
                        &path.key("position"),
                    )?,
                    velocity: super::validate::vector_or(
                        &b.velocity,
                        bodies.dim,
                        &path.key("velocity"),
                        [0.0; 3],
                    )?,
                }
            }
        });
    }
    let names: Vec<&str> = group
        .members
        .iter()
        .map(|&m| file.bodies[m].name.as_str())
        .collect();
    let welded = merge(group, &parts, &names)?;
    let into = file.bodies[group.frame].name.clone();
    let path = root.index(group.frame);
    let centre =
        super::rigid::push_rigid(bodies, &into, &welded.body, group.frame, &path, generated)?;
    for (&m, place) in group.members.iter().zip(welded.placements) {
        bodies.add_welded(
            &file.bodies[m].name,
            Welding {
                centre,
                into: into.clone(),
                place,
            },
            &root.index(m).key("name"),
        )?;
    }
    Ok(())
}
