//! A joint's view of a model ([`Frames`]): where a body's points and axes are, as [`Affine`]
//! functions of the positions (a point `c + Σ Xᵢ dᵢ`, an axis `Σ aᵢ dᵢ`), and the initial poses.
//!
//! In a planar model (`dim = 2`) a slot holds two positions, a body has two directors
//! `d₁, d₂` in the plane, and its third is the plane's normal `e_z`, constant: every point and
//! axis is still an [`Affine`] (its `z` part a constant), so the joints' rows are built as in 3D
//! and the rows that the plane makes identically zero are dropped
//! ([`joint_rows`](super::joints::joint_rows)).

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

/// A 3-vector linear in the positions: `Σ_s α_s q_s + c` over slots `s` of `dim` positions
/// each (`dim = 2`: the slots lie in the plane, `z` is the constant's alone).
#[derive(Debug, Clone, PartialEq)]
pub struct Affine {
    /// `(slot, α)`.
    pub terms: Vec<(usize, f64)>,
    /// `c`.
    pub constant: [f64; 3],
    /// The positions per slot: 3, or 2 in a planar model.
    pub dim: usize,
}

impl Affine {
    /// The constant vector `c` (of a 3D model).
    pub fn constant(c: [f64; 3]) -> Self {
        Self::constant_in(c, 3)
    }

    /// The constant vector `c` of a model with `dim` positions per slot.
    pub fn constant_in(c: [f64; 3], dim: usize) -> Self {
        Self {
            terms: Vec::new(),
            constant: c,
            dim,
        }
    }

    /// Its value at positions `q`.
    pub fn at(&self, q: &[f64]) -> [f64; 3] {
        let mut v = self.constant;
        for &(s, a) in &self.terms {
            for (k, vk) in v.iter_mut().take(self.dim).enumerate() {
                *vk += a * q[self.dim * s + k];
            }
        }
        v
    }

    /// `Σ_{i<dim} c_i d_i + c_z e_z` over the directors `slot + 1 …` (`c_z` only in a planar
    /// model, where the third director is the constant normal), skipping zero coefficients.
    fn on_directors(slot: usize, c: [f64; 3], dim: usize) -> Self {
        let mut constant = [0.0; 3];
        if dim == 2 {
            constant[2] = c[2];
        }
        Self {
            terms: (0..dim)
                .filter(|&i| c[i] != 0.0)
                .map(|i| (slot + 1 + i, c[i]))
                .collect(),
            constant,
            dim,
        }
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
    /// Positions per slot: 3, or 2 for a planar model.
    pub(crate) dim: usize,
}

impl Frames<'_> {
    /// The model's initial positions.
    pub fn initial_positions(&self) -> &[f64] {
        self.q0
    }

    /// The positions per slot: 3, or 2 for a planar model.
    pub fn dim(&self) -> usize {
        self.dim
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
            return Ok(Affine::constant_in(x, self.dim));
        };
        Ok(match self.entry(b)? {
            Entry::Point { slot } => Affine {
                terms: vec![(slot, 1.0)],
                constant: x,
                dim: self.dim,
            },
            Entry::Rigid { slot, axes } => {
                // Principal coordinates X_p = Pᵀ X; r = c + Σ X_p,i dᵢ.
                let xp = axes.transpose().apply(x);
                let mut a = Affine::on_directors(slot, xp, self.dim);
                a.terms.insert(0, (slot, 1.0));
                a
            }
        })
    }

    /// The direction `a` of `body`'s frame; a world direction for the world.
    ///
    /// # Errors
    /// [`SetupError::Dimension`] for a point mass (it has no orientation) or an unknown body.
    pub fn axis(&self, body: BodyRef, a: [f64; 3]) -> Result<Affine, SetupError> {
        let BodyRef::Body(b) = body else {
            return Ok(Affine::constant_in(a, self.dim));
        };
        match self.entry(b)? {
            Entry::Point { .. } => Err(point_has_no_axes(b)),
            Entry::Rigid { slot, axes } => Ok(Affine::on_directors(
                slot,
                axes.transpose().apply(a),
                self.dim,
            )),
        }
    }

    /// The three directors of `body` (the world's axes for the world; in a planar model the
    /// third is the constant normal `e_z`).
    ///
    /// # Errors
    /// As [`axis`](Self::axis).
    pub fn directors(&self, body: BodyRef) -> Result<[Affine; 3], SetupError> {
        let unit = |i: usize| {
            let mut e = [0.0; 3];
            e[i] = 1.0;
            e
        };
        let BodyRef::Body(b) = body else {
            return Ok(core::array::from_fn(|i| {
                Affine::constant_in(unit(i), self.dim)
            }));
        };
        match self.entry(b)? {
            Entry::Point { .. } => Err(point_has_no_axes(b)),
            Entry::Rigid { slot, .. } => Ok(core::array::from_fn(|i| {
                Affine::on_directors(slot, unit(i), self.dim)
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
            return Ok(Affine::constant_in(w, self.dim));
        }
        let q0 = self.initial_positions();
        let mut out = Affine::constant_in([0.0; 3], self.dim);
        for di in &d {
            // Q₀ᵀ w: the components of w along the initial directors (a planar model's normal
            // is a constant director).
            let c = dot(di.at(q0), w);
            out.terms.extend(
                di.terms
                    .iter()
                    .filter(|_| c != 0.0)
                    .map(|&(s, a)| (s, a * c)),
            );
            for (o, &k) in out.constant.iter_mut().zip(&di.constant) {
                *o += c * k;
            }
        }
        Ok(out)
    }
}

fn point_has_no_axes(b: usize) -> SetupError {
    SetupError::Dimension {
        what: format!("body {b} is a point mass: a joint that holds an axis needs a rigid body"),
    }
}
