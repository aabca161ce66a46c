//! Constraint rows of degree at most two in the positions: `g_r(q) = ½ qᵀA_r q + b_rᵀq + c_r`
//! with sparse symmetric `A_r`, the form every joint of bodies-as-directors takes
//! (`../shared/docs/METHOD.md` §8): orthonormal directors, ball joints (linear), hinges,
//! universal joints and sliders (bilinear).
//!
//! Each row keeps its gradient as an affine map, `∂g_r/∂q_i = Σ_j A_ij q_j + b_i`, over the
//! columns it touches; the residual is `Σ_i q_i (∂g_r/∂q_i + b_i)/2 + c_r`, the Hessian the
//! constant `A_r` (so [`HolonomicConstraint::hessian_form`] is exact and a projection around an
//! affine free flight solves its multipliers from the exact quadratic model), and the sparse
//! entries of `G` are those columns, the same for every state.

use crate::linalg::Sink;
use crate::real::Real;
use crate::system::HolonomicConstraint;
use crate::vector::Vector;
use std::collections::BTreeMap;

/// One row: per touched column `i`, `b_i` and the range of its `(j, A_ij)` in `pairs`.
#[derive(Debug, Clone, PartialEq)]
struct Row<T> {
    columns: Vec<(usize, T, core::ops::Range<usize>)>,
    constant: T,
}

/// Rows of degree ≤ 2 on the positions `q` (the first `nq` entries of the state); see the
/// module documentation.
#[derive(Debug, Clone, PartialEq)]
pub struct QuadraticRows<T> {
    nq: usize,
    rows: Vec<Row<T>>,
    pairs: Vec<(usize, T)>,
}

/// A row under construction: `Σ c q_i q_j + Σ b q_i + c₀`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RowBuilder<T> {
    /// `A_ij` for `i ≤ j` stored once (`A` symmetric).
    a: BTreeMap<(usize, usize), T>,
    b: BTreeMap<usize, T>,
    constant: Option<T>,
}

impl<T: Real> RowBuilder<T> {
    /// An empty row (`g = 0`).
    pub fn new() -> Self {
        Self {
            a: BTreeMap::new(),
            b: BTreeMap::new(),
            constant: None,
        }
    }

    /// Adds `c q_i q_j`.
    pub fn product(&mut self, i: usize, j: usize, c: T) -> &mut Self {
        let (lo, hi) = (i.min(j), i.max(j));
        // ½ qᵀAq: c q_i q_j is A_ij = A_ji = c (i ≠ j), A_ii = 2c.
        let add = if i == j { c + c } else { c };
        let e = self.a.entry((lo, hi)).or_insert_with(T::zero);
        *e = *e + add;
        self
    }

    /// Adds `c q_i`.
    pub fn linear(&mut self, i: usize, c: T) -> &mut Self {
        let e = self.b.entry(i).or_insert_with(T::zero);
        *e = *e + c;
        self
    }

    /// Adds the constant `c`.
    pub fn constant(&mut self, c: T) -> &mut Self {
        self.constant = Some(self.constant.unwrap_or_else(T::zero) + c);
        self
    }
}

impl<T: Real> RowBuilder<T> {
    /// Whether the row is `0` everywhere: every coefficient and the constant zero.
    pub fn is_zero(&self) -> bool {
        let zero = |v: &T| *v == T::zero();
        self.a.values().all(zero)
            && self.b.values().all(zero)
            && self.constant.as_ref().is_none_or(zero)
    }
}

impl<T> RowBuilder<T> {
    /// The columns the row touches (linearly or in a product).
    #[cfg_attr(not(feature = "scene"), allow(dead_code))]
    pub(crate) fn columns(&self) -> impl Iterator<Item = usize> + '_ {
        self.b
            .keys()
            .copied()
            .chain(self.a.keys().flat_map(|&(i, j)| [i, j]))
    }
}

impl RowBuilder<f64> {
    /// The same row in the scalar `U`.
    pub fn cast<U: Real>(&self) -> RowBuilder<U> {
        RowBuilder {
            a: self.a.iter().map(|(&k, &v)| (k, U::lit(v))).collect(),
            b: self.b.iter().map(|(&k, &v)| (k, U::lit(v))).collect(),
            constant: self.constant.map(U::lit),
        }
    }
}

impl<T: Real> QuadraticRows<T> {
    /// No rows, on `nq` positions.
    pub fn new(nq: usize) -> Self {
        Self {
            nq,
            rows: Vec::new(),
            pairs: Vec::new(),
        }
    }

    /// The number of rows.
    pub fn count(&self) -> usize {
        self.rows.len()
    }

    /// The number of positions the rows read.
    pub fn positions(&self) -> usize {
        self.nq
    }

    /// Appends `row`; returns its index. Columns at or above [`positions`](Self::positions) are
    /// a programming error of the caller (the joints build their rows from checked slots).
    pub fn push(&mut self, row: &RowBuilder<T>) -> usize {
        let mut by_column: BTreeMap<usize, (T, Vec<(usize, T)>)> = BTreeMap::new();
        for (&i, &b) in &row.b {
            by_column.entry(i).or_insert((T::zero(), Vec::new())).0 = b;
        }
        for (&(i, j), &a) in &row.a {
            by_column
                .entry(i)
                .or_insert((T::zero(), Vec::new()))
                .1
                .push((j, a));
            if i != j {
                by_column
                    .entry(j)
                    .or_insert((T::zero(), Vec::new()))
                    .1
                    .push((i, a));
            }
        }
        let mut columns = Vec::with_capacity(by_column.len());
        for (i, (b, pairs)) in by_column {
            assert!(i < self.nq, "row column {i} outside {} positions", self.nq);
            let start = self.pairs.len();
            self.pairs.extend(pairs);
            columns.push((i, b, start..self.pairs.len()));
        }
        self.rows.push(Row {
            columns,
            constant: row.constant.unwrap_or_else(T::zero),
        });
        self.rows.len() - 1
    }

    /// `∂g_r/∂q_i` at `q` of the column entry `(i, b, range)`.
    #[inline(always)]
    fn partial(&self, q: &[T], b: T, range: &core::ops::Range<usize>) -> T {
        self.pairs[range.clone()]
            .iter()
            .fold(b, |s, &(j, a)| s + a * q[j])
    }

    /// `g_r(q)` of row `r`.
    pub fn row_residual(&self, q: &[T], r: usize) -> T {
        let row = &self.rows[r];
        let half = T::lit(0.5);
        row.columns.iter().fold(row.constant, |s, (i, b, range)| {
            s + q[*i] * half * (self.partial(q, *b, range) + *b)
        })
    }
}

impl<T: Real> QuadraticRows<T> {
    /// Calls `f(i, ∂g_r/∂q_i)` for every column `i` row `r` touches, in increasing `i`.
    #[inline]
    #[cfg_attr(not(feature = "scene"), allow(dead_code))]
    pub(crate) fn for_each_partial(&self, q: &[T], r: usize, mut f: impl FnMut(usize, T)) {
        for (i, b, range) in &self.rows[r].columns {
            f(*i, self.partial(q, *b, range));
        }
    }

    /// `uᵀ A_r v` of row `r` (its Hessian is the constant `A_r`).
    #[inline]
    #[cfg_attr(not(feature = "scene"), allow(dead_code))]
    pub(crate) fn row_hessian(&self, u: &[T], v: &[T], r: usize) -> T {
        self.rows[r]
            .columns
            .iter()
            .fold(T::zero(), |s, (i, _, range)| {
                let av = self.pairs[range.clone()]
                    .iter()
                    .fold(T::zero(), |s, &(j, a)| s + a * v[j]);
                s + u[*i] * av
            })
    }

    /// `out = G(q) v` on position slices.
    pub fn apply_positions(&self, q: &[T], v: &[T], out: &mut [T]) {
        for (row, o) in self.rows.iter().zip(out.iter_mut()) {
            *o = row.columns.iter().fold(T::zero(), |s, (i, b, range)| {
                s + self.partial(q, *b, range) * v[*i]
            });
        }
    }

    /// `out += α G(q)ᵀ μ` on position slices (rows with `μ_r = 0` skipped).
    pub fn transpose_add_positions(&self, q: &[T], mu: &[T], alpha: T, out: &mut [T]) {
        for (row, &m) in self.rows.iter().zip(mu) {
            // A zero multiplier adds nothing (a Newton probing Gᵀ e_j sets one row at a time).
            if m == T::zero() {
                continue;
            }
            let c = alpha * m;
            for (i, b, range) in &row.columns {
                out[*i] = out[*i] + c * self.partial(q, *b, range);
            }
        }
    }
}

impl<T: Real, V: Vector<Real = T>> HolonomicConstraint<V> for QuadraticRows<T> {
    fn dim(&self) -> usize {
        self.rows.len()
    }
    fn residual(&self, x: &V, out: &mut [T]) {
        let q = x.as_slice();
        for (r, o) in out.iter_mut().enumerate() {
            *o = self.row_residual(q, r);
        }
    }
    fn jacobian_apply(&self, x: &V, v: &V, out: &mut [T]) {
        let (q, v) = (x.as_slice(), v.as_slice());
        for (row, o) in self.rows.iter().zip(out.iter_mut()) {
            *o = row.columns.iter().fold(T::zero(), |s, (i, b, range)| {
                s + self.partial(q, *b, range) * v[*i]
            });
        }
    }
    fn jacobian_transpose_apply_add(&self, x: &V, mu: &[T], alpha: T, out: &mut V) {
        self.transpose_add_positions(x.as_slice(), mu, alpha, out.as_mut_slice());
    }
    /// `uᵀA_r v`: the rows are quadratic, their Hessians constant.
    fn hessian_form(&self, _x: &V, u: &V, v: &V, out: &mut [T]) -> bool {
        let (u, v) = (u.as_slice(), v.as_slice());
        for (row, o) in self.rows.iter().zip(out.iter_mut()) {
            *o = row.columns.iter().fold(T::zero(), |s, (i, _, range)| {
                let av = self.pairs[range.clone()]
                    .iter()
                    .fold(T::zero(), |s, &(j, a)| s + a * v[j]);
                s + u[*i] * av
            });
        }
        true
    }
    fn jacobian_entries(&self, x: &V, sink: &mut dyn Sink<T>) -> bool {
        let q = x.as_slice();
        for (r, row) in self.rows.iter().enumerate() {
            for (i, b, range) in &row.columns {
                sink.add(r, *i, self.partial(q, *b, range));
            }
        }
        true
    }
}
