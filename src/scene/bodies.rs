//! The body table of a scene: every body with its name, mass, charge and initial state, and
//! selection by name (a body, a generator, `"<generator>.<i>"`, `"*"`).

use crate::scene::error::{FieldPath, SceneErrorKind};
use crate::scene::validate::{Result, err};
use std::collections::HashMap;

/// The most bodies a scene may generate (the state alone is then 2·3·10⁷ doubles, 480 MB).
pub const MAX_BODIES: usize = 10_000_000;

/// A body after generators are expanded: a point, the centre of mass of a rigid body, or one
/// of a rigid body's directors (a slot of the state with its own mass `E_i`, not selectable by
/// name: effects act on points and centres).
pub(crate) struct Body {
    pub(crate) name: String,
    pub(crate) mass: f64,
    pub(crate) q: [f64; 3],
    pub(crate) v: [f64; 3],
    pub(crate) charge: f64,
    pub(crate) director: bool,
}

/// A rigid body of the scene: its centre's index in the body list (its directors follow it)
/// and its orientation and principal axes at the start.
#[derive(Debug, Clone, Copy)]
pub(crate) struct RigidEntry {
    pub(crate) centre: usize,
    /// `R`: the body frame in the world at the start.
    pub(crate) orientation: crate::rigid::Rotation,
    /// `P`: the principal axes in the body frame (`Q = R P`).
    pub(crate) axes: crate::rigid::Rotation,
    /// The solid its inertia was declared as, for drawings (`None`: moments, a tensor, a
    /// welded body).
    pub(crate) shape: Option<crate::scene::shape::Shape>,
}

/// A member of a merged body (`type = "weld"`): the merged body's centre and name, and where
/// the member sits in it.
#[derive(Debug, Clone)]
pub(crate) struct Welding {
    pub(crate) centre: usize,
    pub(crate) into: String,
    pub(crate) place: crate::rigid::Placement,
}

/// Bodies, names and selectors.
pub(crate) struct Bodies {
    pub(crate) dim: usize,
    pub(crate) list: Vec<Body>,
    pub(crate) groups: HashMap<String, Vec<usize>>,
    /// The rigid bodies, by their centres.
    pub(crate) rigid: Vec<RigidEntry>,
    /// The members of welded groups, by name (the merged body keeps its frame member's name).
    pub(crate) welded: HashMap<String, Welding>,
    /// The initial positions of every slot, built once when the joints first ask.
    pub(crate) positions: std::cell::OnceCell<Vec<f64>>,
}

impl Bodies {
    pub(crate) fn add_group(
        &mut self,
        name: &str,
        members: Vec<usize>,
        path: &FieldPath,
    ) -> Result<()> {
        if name.is_empty() || name == "*" || name.contains('.') || name.contains('#') {
            return Err(err(
                SceneErrorKind::Reference,
                path.clone(),
                format!(
                    "the name '{name}' is reserved or empty (no '.' or '#', not '*'; '#' marks a rigid body's directors)"
                ),
            ));
        }
        let welded_elsewhere = self.welded.get(name).is_some_and(|w| w.into != name);
        if welded_elsewhere || self.groups.insert(name.to_owned(), members).is_some() {
            return Err(err(
                SceneErrorKind::Reference,
                path.clone(),
                format!("the name '{name}' is used twice"),
            ));
        }
        Ok(())
    }

    /// Records `name` as a member of a merged body.
    pub(crate) fn add_welded(&mut self, name: &str, w: Welding, path: &FieldPath) -> Result<()> {
        let taken = w.into != name && self.groups.contains_key(name);
        if taken || self.welded.insert(name.to_owned(), w).is_some() {
            return Err(err(
                SceneErrorKind::Reference,
                path.clone(),
                format!("the name '{name}' is used twice"),
            ));
        }
        Ok(())
    }

    /// A joint's end named `sel`: the body, and where the named body sits in it (itself, or a
    /// member of a merged body).
    pub(crate) fn joint_end(
        &self,
        sel: &str,
        path: &FieldPath,
    ) -> Result<(Vec<usize>, crate::rigid::Placement)> {
        match self.welded.get(sel) {
            Some(w) => Ok((vec![w.centre], w.place)),
            None => Ok((self.select(sel, path)?, crate::rigid::Placement::identity())),
        }
    }

    pub(crate) fn push(&mut self, body: Body) -> usize {
        self.positions = std::cell::OnceCell::new();
        self.list.push(body);
        self.list.len() - 1
    }

    /// Refuses `more` bodies at `path` if they would take the scene past [`MAX_BODIES`].
    pub(crate) fn reserve(&mut self, more: usize, path: &FieldPath) -> Result<()> {
        if more > MAX_BODIES - self.list.len().min(MAX_BODIES) {
            return Err(err(
                SceneErrorKind::Unsupported,
                path.clone(),
                format!("the scene would have more than {MAX_BODIES} bodies"),
            ));
        }
        self.list.reserve(more);
        Ok(())
    }

    /// The rigid body whose centre is body `b`, if it is one.
    pub(crate) fn rigid_at(&self, b: usize) -> Option<&RigidEntry> {
        self.rigid.iter().find(|r| r.centre == b)
    }

    /// The library's view of bodies `list` for joints and joint elements
    /// ([`Frames`](crate::rigid::Frames)): entry `i` is body `list[i]`, a point or a rigid body
    /// with its principal axes, its slot the body's index.
    pub(crate) fn entries(&self, list: &[usize]) -> Vec<crate::rigid::Entry> {
        list.iter()
            .map(|&b| match self.rigid_at(b) {
                Some(r) => crate::rigid::Entry::Rigid {
                    slot: b,
                    axes: r.axes,
                },
                None => crate::rigid::Entry::Point { slot: b },
            })
            .collect()
    }

    /// The initial positions of every slot, `dim` each.
    pub(crate) fn positions(&self) -> &[f64] {
        self.positions.get_or_init(|| {
            self.list
                .iter()
                .flat_map(|b| b.q.into_iter().take(self.dim))
                .collect()
        })
    }

    /// The library's view ([`Frames`](crate::rigid::Frames)) of the bodies `entries` lists
    /// ([`entries`](Self::entries)), at the initial positions.
    pub(crate) fn frames<'a>(
        &'a self,
        entries: &'a [crate::rigid::Entry],
    ) -> crate::rigid::Frames<'a> {
        crate::rigid::Frames {
            entries,
            q0: self.positions(),
            dim: self.dim,
        }
    }

    /// Every body a selector may name: points and rigid bodies' centres, not their directors.
    pub(crate) fn all(&self) -> Vec<usize> {
        (0..self.list.len())
            .filter(|&b| !self.list[b].director)
            .collect()
    }

    /// The bodies a selector names.
    pub(crate) fn select(&self, sel: &str, path: &FieldPath) -> Result<Vec<usize>> {
        if sel == "*" {
            return Ok(self.all());
        }
        if let Some(w) = self.welded.get(sel)
            && w.into != sel
        {
            return Err(err(
                SceneErrorKind::Reference,
                path.clone(),
                format!(
                    "'{sel}' is welded into '{}' (one body since the scene was compiled): name '{}' here; joints may still name '{sel}' with anchors in its frame",
                    w.into, w.into
                ),
            ));
        }
        if let Some(g) = self.groups.get(sel) {
            return Ok(g.clone());
        }
        if let Some((group, index)) = sel.rsplit_once('.')
            && let (Some(g), Ok(i)) = (self.groups.get(group), index.parse::<usize>())
        {
            return g.get(i).map(|&b| vec![b]).ok_or_else(|| {
                err(
                    SceneErrorKind::Reference,
                    path.clone(),
                    format!(
                        "'{sel}': '{group}' has {} bodies (0 … {})",
                        g.len(),
                        g.len().saturating_sub(1)
                    ),
                )
            });
        }
        Err(err(
            SceneErrorKind::Reference,
            path.clone(),
            format!(
                "'{sel}' names no body or group (bodies, chains, shells and grids are named; '*' is all)"
            ),
        ))
    }

    /// The bodies the selectors name, each once, in order of first mention (`O(N)` with a mask).
    pub(crate) fn select_all(&self, sels: &[String], path: &FieldPath) -> Result<Vec<usize>> {
        let mut seen = vec![false; self.list.len()];
        let mut out = Vec::new();
        for (i, s) in sels.iter().enumerate() {
            for b in self.select(s, &path.index(i))? {
                if !std::mem::replace(&mut seen[b], true) {
                    out.push(b);
                }
            }
        }
        Ok(out)
    }

    /// `None` → all bodies.
    pub(crate) fn select_opt(
        &self,
        sels: &Option<Vec<String>>,
        path: &FieldPath,
    ) -> Result<Vec<usize>> {
        match sels {
            None => Ok(self.all()),
            Some(s) => self.select_all(s, path),
        }
    }
}
