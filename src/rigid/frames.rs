//! A joint's view of a model ([`Frames`]): where a body's points and axes are, as [`Affine`]
//! functions of the positions (a point `c + Σ Xᵢ dᵢ`, an axis `Σ aᵢ dᵢ`), and the initial poses.

use super::pose::{Rotation, dot};
use crate::error::SetupError;

/// One end of a joint: a body of the model, or the world (fixed).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BodyRef {
    /// The fixed world frame.
    World,
    /// The body of this index (as [`Multibody::add_rigid`](super::Multibody::add_rigid) and
    /// [`add_point`](super::Multibody::add_point) returned it).
    Body(usize),
}

/// A 3-vector linear in the positions: `Σ_s α_s q_s + c` over slots `s` (3 positions each).
#[derive(Debug, Clone, PartialEq)]
pub struct Affine {
    /// `(slot, α)`.
    pub terms: Vec<(usize, f64)>,
    /// `c`.
    pub constant: [f64; 3],
}

impl Affine {
    /// The constant vector `c`.
    pub fn constant(c: [f64; 3]) -> Self {
        Self {
            terms: Vec::new(),
            constant: c,
        }
    }

    /// Its value at positions `q`.
    pub fn at(&self, q: &[f64]) -> [f64; 3] {
        let mut v = self.constant;
        for &(s, a) in &self.terms {
            for (k, vk) in v.iter_mut().enumerate() {
                *vk += a * q[3 * s + k];
            }
        }
        v
    }
}

/// A body of the model: its first slot, and for a rigid body its principal axes in its frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Entry {
    Point { slot: usize },
    Rigid { slot: usize, axes: Rotation },
}

/// A joint's view of the model: where body points and axes are, as [`Affine`] functions of the
/// positions, and the initial positions.
#[derive(Debug)]
pub struct Frames<'a> {
    pub(crate) entries: &'a [Entry],
    pub(crate) q0: &'a [f64],
}

impl Frames<'_> {
    /// The model's initial positions.
    pub fn initial_positions(&self) -> &[f64] {
        self.q0
    }

    fn entry(&self, body: usize) -> Result<Entry, SetupError> {
        self.entries
            .get(body)
            .copied()
            .ok_or_else(|| SetupError::Dimension {
                what: format!(
                    "a joint names body {body} of a model of {} bodies",
                    self.entries.len()
                ),
            })
    }

    /// The point `X` of `body`'s frame (about its centre of mass); a world point for the world.
    pub fn point(&self, body: BodyRef, x: [f64; 3]) -> Result<Affine, SetupError> {
        let BodyRef::Body(b) = body else {
            return Ok(Affine::constant(x));
        };
        Ok(match self.entry(b)? {
            Entry::Point { slot } => Affine {
                terms: vec![(slot, 1.0)],
                constant: x,
            },
            Entry::Rigid { slot, axes } => {
                // Principal coordinates X_p = Pᵀ X; r = c + Σ X_p,i dᵢ.
                let xp = axes.transpose().apply(x);
                let mut terms = vec![(slot, 1.0)];
                terms.extend((0..3).map(|i| (slot + 1 + i, xp[i])));
                Affine {
                    terms,
                    constant: [0.0; 3],
                }
            }
        })
    }

    /// The direction `a` of `body`'s frame; a world direction for the world.
    ///
    /// # Errors
    /// [`SetupError::Dimension`] for a point mass (it has no orientation) or an unknown body.
    pub fn axis(&self, body: BodyRef, a: [f64; 3]) -> Result<Affine, SetupError> {
        let BodyRef::Body(b) = body else {
            return Ok(Affine::constant(a));
        };
        match self.entry(b)? {
            Entry::Point { .. } => Err(point_has_no_axes(b)),
            Entry::Rigid { slot, axes } => {
                let ap = axes.transpose().apply(a);
                Ok(Affine {
                    terms: (0..3).map(|i| (slot + 1 + i, ap[i])).collect(),
                    constant: [0.0; 3],
                })
            }
        }
    }

    /// The three directors of `body` (the world's axes for the world).
    ///
    /// # Errors
    /// As [`axis`](Self::axis).
    pub fn directors(&self, body: BodyRef) -> Result<[Affine; 3], SetupError> {
        let BodyRef::Body(b) = body else {
            return Ok(core::array::from_fn(|i| {
                let mut e = [0.0; 3];
                e[i] = 1.0;
                Affine::constant(e)
            }));
        };
        match self.entry(b)? {
            Entry::Point { .. } => Err(point_has_no_axes(b)),
            Entry::Rigid { slot, .. } => Ok(core::array::from_fn(|i| Affine {
                terms: vec![(slot + 1 + i, 1.0)],
                constant: [0.0; 3],
            })),
        }
    }

    /// The world vector `w` (at the initial poses) carried along with `body`:
    /// `Q Q₀ᵀ w`, as a combination of its directors (constant for the world).
    ///
    /// # Errors
    /// As [`axis`](Self::axis).
    pub fn follow(&self, body: BodyRef, w: [f64; 3]) -> Result<Affine, SetupError> {
        let d = self.directors(body)?;
        if body == BodyRef::World {
            return Ok(Affine::constant(w));
        }
        let q0 = self.initial_positions();
        let mut terms = Vec::new();
        for di in &d {
            // Q₀ᵀ w: the components of w along the initial directors.
            let c = dot(di.at(q0), w);
            terms.extend(di.terms.iter().map(|&(s, a)| (s, a * c)));
        }
        Ok(Affine {
            terms,
            constant: [0.0; 3],
        })
    }
}

fn point_has_no_axes(b: usize) -> SetupError {
    SetupError::Dimension {
        what: format!("body {b} is a point mass: a joint that holds an axis needs a rigid body"),
    }
}
