//! Constraint rows of degree at most two in the positions: `g_r(q) = ½ qᵀA_r q + b_rᵀq + c_r`
//! with sparse symmetric `A_r`, the form every joint of bodies-as-directors takes
//! (`../shared/docs/METHOD.md` §8): orthonormal directors, ball joints (linear), hinges,
//! universal joints and sliders (bilinear).
//!
//! Each row keeps its gradient as an affine map, `∂g_r/∂q_i = Σ_j A_ij q_j + b_i`, over the
//! columns it touches, and its value as monomials `Σ_{i≤j} c_ij q_i q_j + bᵀq + c_r`; the
//! Hessian is the constant `A_r` (so [`HolonomicConstraint::hessian_form`] is exact and a
//! projection around an affine free flight solves its multipliers from the exact quadratic
//! model), and the sparse entries of `G` are those columns, the same for every state.

use crate::linalg::Sink;
use crate::real::Real;
use crate::system::HolonomicConstraint;
use crate::vector::Vector;
use std::collections::BTreeMap;

/// One entry `∂g_r/∂q_col = b + a q_j + Σ_more c q_k` of a row's gradient: the first term of
/// the affine map inline (every joint row of bodies-as-directors has at most one), the others
/// in `pairs[more]`. A column the row touches only linearly has `a = 0`, `j = col`.
#[derive(Debug, Clone, PartialEq)]
struct Entry<T> {
    col: usize,
    b: T,
    j: usize,
    a: T,
    more: core::ops::Range<usize>,
}

/// One row: its gradient's entries `entries[grad]` (increasing columns) and, for the residual,
/// its monomials `c q_i q_j` (`products[prod]`), `b q_i` (`linear[lin]`) and constant.
#[derive(Debug, Clone, PartialEq)]
struct Row<T> {
    grad: core::ops::Range<usize>,
    prod: core::ops::Range<usize>,
    lin: core::ops::Range<usize>,
    constant: T,
}

/// Rows of degree ≤ 2 on the positions `q` (the first `nq` entries of the state); see the
/// module documentation. Stored flat — every row's entries in one list, every extra pair in
/// another — so that a pass over `G` is one walk of contiguous memory with no per-row
/// allocation to chase.
#[derive(Debug, Clone, PartialEq)]
pub struct QuadraticRows<T> {
    nq: usize,
    rows: Vec<Row<T>>,
    entries: Vec<Entry<T>>,
    pairs: Vec<(usize, T)>,
    products: Vec<(usize, usize, T)>,
    linear: Vec<(usize, T)>,
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
            entries: Vec::new(),
            pairs: Vec::new(),
            products: Vec::new(),
            linear: Vec::new(),
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
        let grad_start = self.entries.len();
        for (i, (b, pairs)) in by_column {
            assert!(i < self.nq, "row column {i} outside {} positions", self.nq);
            let (j, a) = pairs.first().copied().unwrap_or((i, T::zero()));
            let start = self.pairs.len();
            self.pairs.extend(pairs.into_iter().skip(1));
            self.entries.push(Entry {
                col: i,
                b,
                j,
                a,
                more: start..self.pairs.len(),
            });
        }
        // ½ qᵀAq + bᵀq + c as monomials: A_ij q_i q_j once for i < j, ½ A_ii q_i².
        let prod_start = self.products.len();
        let half = T::lit(0.5);
        for (&(i, j), &a) in &row.a {
            self.products
                .push((i, j, if i == j { half * a } else { a }));
        }
        let lin_start = self.linear.len();
        self.linear.extend(row.b.iter().map(|(&i, &b)| (i, b)));
        self.rows.push(Row {
            grad: grad_start..self.entries.len(),
            prod: prod_start..self.products.len(),
            lin: lin_start..self.linear.len(),
            constant: row.constant.unwrap_or_else(T::zero),
        });
        self.rows.len() - 1
    }

    /// `∂g_r/∂q_col` at `q` of the entry `e`.
    #[inline(always)]
    fn partial(&self, q: &[T], e: &Entry<T>) -> T {
        let first = e.b + e.a * q[e.j];
        if e.more.is_empty() {
            return first;
        }
        self.pairs[e.more.clone()]
            .iter()
            .fold(first, |s, &(j, a)| s + a * q[j])
    }

    /// The entries of row `r`'s gradient.
    #[inline(always)]
    fn row_entries(&self, r: usize) -> &[Entry<T>] {
        &self.entries[self.rows[r].grad.clone()]
    }

    /// `g_r(q)` of row `r`: its monomials summed.
    #[inline]
    pub fn row_residual(&self, q: &[T], r: usize) -> T {
        let row = &self.rows[r];
        let quadratic = self.products[row.prod.clone()]
            .iter()
            .fold(row.constant, |s, &(i, j, c)| s + c * q[i] * q[j]);
        self.linear[row.lin.clone()]
            .iter()
            .fold(quadratic, |s, &(i, b)| s + b * q[i])
    }

    /// The number of structurally non-zero entries of `G` (the row's touched columns, summed).
    pub fn entry_count(&self) -> usize {
        self.entries.len()
    }
}

impl<T: Real> QuadraticRows<T> {
    /// Calls `f(i, ∂g_r/∂q_i)` for every column `i` row `r` touches, in increasing `i`.
    #[inline]
    #[cfg_attr(not(feature = "scene"), allow(dead_code))]
    pub(crate) fn for_each_partial(&self, q: &[T], r: usize, mut f: impl FnMut(usize, T)) {
        for e in self.row_entries(r) {
            f(e.col, self.partial(q, e));
        }
    }

    /// `uᵀ A_r v` of row `r` (its Hessian is the constant `A_r`).
    #[inline]
    #[cfg_attr(not(feature = "scene"), allow(dead_code))]
    pub(crate) fn row_hessian(&self, u: &[T], v: &[T], r: usize) -> T {
        self.row_entries(r).iter().fold(T::zero(), |s, e| {
            let av = self.pairs[e.more.clone()]
                .iter()
                .fold(e.a * v[e.j], |s, &(j, a)| s + a * v[j]);
            s + u[e.col] * av
        })
    }

    /// `out = G(q) v` on position slices.
    pub fn apply_positions(&self, q: &[T], v: &[T], out: &mut [T]) {
        for (r, o) in out.iter_mut().enumerate().take(self.rows.len()) {
            *o = self
                .row_entries(r)
                .iter()
                .fold(T::zero(), |s, e| s + self.partial(q, e) * v[e.col]);
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
            for e in &self.entries[row.grad.clone()] {
                out[e.col] = out[e.col] + c * self.partial(q, e);
            }
        }
    }

    /// Writes the entries of `G(q)` in the order [`HolonomicConstraint::jacobian_entries`]
    /// lists them (by rows, increasing columns); `false` when `out` does not hold exactly
    /// [`entry_count`](Self::entry_count) of them.
    pub fn entry_values(&self, q: &[T], out: &mut [T]) -> bool {
        if out.len() != self.entries.len() {
            return false;
        }
        for (o, e) in out.iter_mut().zip(&self.entries) {
            *o = self.partial(q, e);
        }
        true
    }
}

impl<T: Real, V: Vector<Real = T>> HolonomicConstraint<V> for QuadraticRows<T> {
    fn dim(&self) -> usize {
        self.rows.len()
    }
    fn residual(&self, x: &V, out: &mut [T]) {
        let q = x.as_slice();
        for (r, o) in out.iter_mut().enumerate().take(self.rows.len()) {
            *o = self.row_residual(q, r);
        }
    }
    fn jacobian_apply(&self, x: &V, v: &V, out: &mut [T]) {
        self.apply_positions(x.as_slice(), v.as_slice(), out);
    }
    fn jacobian_transpose_apply_add(&self, x: &V, mu: &[T], alpha: T, out: &mut V) {
        self.transpose_add_positions(x.as_slice(), mu, alpha, out.as_mut_slice());
    }
    /// `uᵀA_r v`: the rows are quadratic, their Hessians constant.
    fn hessian_form(&self, _x: &V, u: &V, v: &V, out: &mut [T]) -> bool {
        let (u, v) = (u.as_slice(), v.as_slice());
        for (r, o) in out.iter_mut().enumerate().take(self.rows.len()) {
            *o = self.row_hessian(u, v, r);
        }
        true
    }
    fn jacobian_entries(&self, x: &V, sink: &mut dyn Sink<T>) -> bool {
        let q = x.as_slice();
        for (r, row) in self.rows.iter().enumerate() {
            for e in &self.entries[row.grad.clone()] {
                sink.add(r, e.col, self.partial(q, e));
            }
        }
        true
    }
    fn jacobian_values(&self, x: &V, out: &mut [T]) -> bool {
        self.entry_values(x.as_slice(), out)
    }
}

#[cfg(test)]
#[path = "rows_tests.rs"]
mod tests;
