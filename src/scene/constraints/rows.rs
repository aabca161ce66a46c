//! Rows of degree at most two on the bodies' slots, `g_r(q) = ½ qᵀA_r q + b_rᵀq + c_r`
//! ([`QuadraticRows`]): a rigid body's `QᵀQ = I` and the joints between bodies
//! (`../shared/docs/METHOD.md` §8, docs/method.md §12c). A rigid body is four slots of the
//! state — its centre and its three directors `dᵢ` — so a row's gradient with respect to a slot
//! is a 3-vector like a point's, and the scene's projection, Gram matrix and sparsity pattern
//! read these rows as they read a rod's.

use super::{ConstraintInfo, ConstraintOps, extent};
use crate::real::Real;
use crate::rigid::{QuadraticRows, RowBuilder};

/// A term of quadratic rows over slots of three positions (3D scenes).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Rows<T = f64> {
    /// Its kind in summaries and CSV columns (`"hinge"`, `"directors"`).
    kind: &'static str,
    /// The bodies it joins (scene body indices), for its CSV columns.
    ends: (usize, Option<usize>),
    /// The first body is rigid (its directors follow its centre's slot).
    rigid_first: bool,
    /// The slots its rows touch, for their scales.
    slots: Vec<usize>,
    /// The rows as built, to change the scalar.
    source: Vec<RowBuilder<f64>>,
    /// Each row's index as declared (rows dropped as dependent leave gaps), for its CSV name.
    declared: Vec<usize>,
    /// A joint's anchor in each end's frame and its axis in the first's, for a drawing (boxed:
    /// a body's own rows, the most common term, carry none).
    drawn: Option<Box<Drawn>>,
    /// Boxed: the flat row storage is the largest part of any constraint term.
    rows: Box<QuadraticRows<T>>,
}

/// A joint's anchors and axis, as [`JointSketch`] has them.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Drawn {
    anchors: [[f64; 3]; 2],
    axis: Option<[f64; 3]>,
}

/// What a drawing shows of a joint (`scene::sketch`): its ends (scene body indices; `None` the
/// world), its anchor in each end's frame (a world point for the world), its axis in the first
/// end's frame.
pub(crate) struct JointSketch {
    pub(crate) ends: (usize, Option<usize>),
    pub(crate) anchors: [[f64; 3]; 2],
    pub(crate) axis: Option<[f64; 3]>,
}

impl Rows<f64> {
    /// The term of `rows` (columns `dim s + k` of slot `s`), of `kind`, between `ends`.
    pub(crate) fn new(
        kind: &'static str,
        ends: (usize, Option<usize>),
        source: Vec<RowBuilder<f64>>,
        positions: usize,
        dim: usize,
    ) -> Self {
        let mut rows = QuadraticRows::new(positions);
        for row in &source {
            rows.push(row);
        }
        let mut slots: Vec<usize> = source
            .iter()
            .flat_map(|r| r.columns().map(|i| i / dim))
            .collect();
        slots.sort_unstable();
        slots.dedup();
        let declared = (0..source.len()).collect();
        Self {
            kind,
            ends,
            rigid_first: false,
            slots,
            source,
            declared,
            drawn: None,
            rows: Box::new(rows),
        }
    }

    /// The same term, a joint with these anchors (one per end, in its frame) and axis (in the
    /// first end's frame).
    pub(crate) fn with_anchors(mut self, anchors: [[f64; 3]; 2], axis: Option<[f64; 3]>) -> Self {
        self.drawn = Some(Box::new(Drawn { anchors, axis }));
        self
    }

    /// Its kind (`"hinge"`, `"directors"`).
    pub(crate) fn kind(&self) -> &'static str {
        self.kind
    }

    /// The same term without its row `r` (dependent on the others: `redundant =
    /// "drop-dependent"`), and that row's index as declared.
    pub(crate) fn without_row(&self, r: usize) -> (Self, usize) {
        let mut source = self.source.clone();
        source.remove(r);
        let mut declared = self.declared.clone();
        let gone = declared.remove(r);
        let mut rows = QuadraticRows::new(self.rows.positions());
        for row in &source {
            rows.push(row);
        }
        let term = Self {
            source,
            declared,
            rows: Box::new(rows),
            ..self.clone()
        };
        (term, gone)
    }

    /// The same term, its first body rigid (a joint's torque on it is then read).
    pub(crate) fn with_rigid_first(mut self, rigid: bool) -> Self {
        self.rigid_first = rigid;
        self
    }

    /// A joint's first body and whether it is rigid (the slots after its centre then hold its
    /// directors); `None` for a body's own orthonormality rows.
    pub(crate) fn first_body(&self) -> Option<(usize, bool)> {
        (self.kind != "directors").then_some((self.ends.0, self.rigid_first))
    }

    pub(crate) fn with_scalar<U: Real>(&self) -> Rows<U> {
        let mut rows = QuadraticRows::new(self.rows.positions());
        for row in &self.source {
            rows.push(&row.cast());
        }
        Rows {
            kind: self.kind,
            ends: self.ends,
            rigid_first: self.rigid_first,
            slots: self.slots.clone(),
            source: self.source.clone(),
            declared: self.declared.clone(),
            drawn: self.drawn.clone(),
            rows: Box::new(rows),
        }
    }
}

impl<T> Rows<T> {
    /// A joint's ends, anchors and axis for a drawing; `None` for a body's own rows.
    pub(crate) fn joint_sketch(&self) -> Option<JointSketch> {
        self.drawn.as_deref().map(|d| JointSketch {
            ends: self.ends,
            anchors: d.anchors,
            axis: d.axis,
        })
    }
}

impl<T: Real> ConstraintOps<T> for Rows<T> {
    #[inline]
    fn rows(&self, _d: usize) -> usize {
        self.rows.count()
    }
    #[inline]
    fn residual(&self, q: &[T], _d: usize, out: &mut [T]) {
        for (r, o) in out[..self.rows.count()].iter_mut().enumerate() {
            *o = self.rows.row_residual(q, r);
        }
    }
    #[inline]
    fn row_dots(
        &self,
        q: &[T],
        v: &[T],
        d: usize,
        scale: Option<&[T]>,
        mut f: impl FnMut(usize, T),
    ) {
        for r in 0..self.rows.count() {
            let mut s = T::zero();
            self.rows.for_each_partial(q, r, |i, g| {
                let vi = match scale {
                    Some(w) => w[i / d] * v[i],
                    None => v[i],
                };
                s = s + g * vi;
            });
            f(r, s);
        }
    }
    /// Rows whose multiplier is zero add nothing and are skipped
    /// ([`QuadraticRows::transpose_add_positions`]): the projection's Newton probes `Gᵀ e_j`
    /// one group of rows at a time, and a body's rows share its slots, so most groups are one
    /// row.
    #[inline]
    fn gradient_transpose_add(&self, q: &[T], mu: &[T], alpha: T, _d: usize, out: &mut [T]) {
        let n = self.rows.count();
        self.rows.transpose_add_positions(q, &mu[..n], alpha, out);
    }
    /// The columns the rows touch, no other component of their slots.
    #[inline]
    fn entries(&self, q: &[T], _d: usize, mut f: impl FnMut(usize, usize, T)) {
        for r in 0..self.rows.count() {
            self.rows.for_each_partial(q, r, |i, g| f(r, i, g));
        }
    }
    /// One call per slot a row touches: the row's columns come in increasing order, so a
    /// slot's `d` are consecutive.
    #[inline]
    fn gradients(&self, q: &[T], d: usize, mut f: impl FnMut(usize, usize, [T; 3])) {
        for r in 0..self.rows.count() {
            let mut slot = usize::MAX;
            let mut g = [T::zero(); 3];
            self.rows.for_each_partial(q, r, |i, c| {
                if i / d != slot {
                    if slot != usize::MAX {
                        f(r, slot, g);
                    }
                    slot = i / d;
                    g = [T::zero(); 3];
                }
                g[i % d] = c;
            });
            if slot != usize::MAX {
                f(r, slot, g);
            }
        }
    }
    #[inline]
    fn hessian_form(&self, u: &[T], v: &[T], _d: usize, out: &mut [T]) {
        for (r, o) in out[..self.rows.count()].iter_mut().enumerate() {
            *o = self.rows.row_hessian(u, v, r);
        }
    }
    #[inline]
    fn velocity_curvature_add(&self, v: &[T], _d: usize, out: &mut [T]) {
        for (r, o) in out[..self.rows.count()].iter_mut().enumerate() {
            *o = *o + self.rows.row_hessian(v, v, r);
        }
    }
}

impl ConstraintInfo for Rows<f64> {
    fn kind(&self) -> &'static str {
        self.kind
    }
    fn bodies(&self, name: &dyn Fn(usize) -> String) -> String {
        match self.ends.1 {
            Some(b) => format!("{}-{}", name(self.ends.0), name(b)),
            None => name(self.ends.0),
        }
    }
    /// A row of products of unit directors and positions rounds at `ε (1 + |q|)` over the
    /// slots it touches; its length is 1 (directors are unit vectors).
    fn scales(&self, q: &[f64], d: usize, out: &mut [(f64, f64)]) {
        let size = self.slots.iter().fold(1.0f64, |a, &s| a + extent(q, s, d));
        out[..self.rows.count()].fill((size, 1.0));
    }
    /// A joint's point-coincidence rows push with `−λ` along their axis, as a pin's; the
    /// multipliers of orientation rows are torques about axes that turn with the bodies.
    fn force_per_multiplier(&self, _q: &[f64], _d: usize) -> f64 {
        -1.0
    }
    /// The row's index as declared (a row dropped as dependent leaves its number unused).
    fn row_name(&self, r: usize) -> String {
        self.declared.get(r).copied().unwrap_or(r).to_string()
    }
}
