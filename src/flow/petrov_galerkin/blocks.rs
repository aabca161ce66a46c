//! The constraint blocks of the reduced Petrov–Galerkin system ([`Stages`](super::reduced)),
//! assembled from the constraint's Jacobian entries at the `s` quadrature points: a symbolic
//! part fixed at construction (the entries' positions, the pairs that meet in the Schur
//! complement) and a numeric part filled once per residual.
//!
//! For an entry `e = (a, d)` of `G_q` with values `g_r(e)` at the quadrature points `x_r`, the
//! multiplier columns and the constraint rows of the reduced Newton matrix are `k × k` blocks
//!
//! ```text
//! C_e[i][j] = Σ_r t_ri ℓ_j(e_r) g_r(e)                (columns of multiplier a at momentum d)
//! G_e[i][l] = h w_d Σ_r t_ri (ℓ(e_r)ᵀÂ)_l g_r(e)      (rows of constraint a at momentum d)
//! ```
//!
//! (`t_ri = b_r ℓ_i(e_r)/β_i` the test weights, `w_d` the inverse mass), and the Schur
//! complement of the iteration (`D_d` its stage blocks) is a sum over the entries that share a
//! column,
//!
//! ```text
//! S_(b,a) = Σ_d G_(b,d) D_d⁻¹ C_(a,d).
//! ```
//!
//! Filling them costs `s` passes of the constraint's entries and `2 s k²` products an entry;
//! the products with `C` and `G` that the iteration then takes cost `k²` an entry and no pass
//! through the model, and `S` is summed directly instead of by `2k` grouped products of `s`
//! constraint passes each.

use super::Tables;
use crate::flow::entry_pairs::EntryPairs;
use crate::linalg::{PatternFill, Sink};
use crate::real::Real;
use crate::system::HolonomicConstraint;
use crate::vector::{Vector, ops};

/// The blocks `C_e`, `G_e` of every Jacobian entry at the last residual's quadrature points.
#[derive(Debug, Clone)]
pub(super) struct ConstraintBlocks<T> {
    k: usize,
    /// The number of constraints.
    m: usize,
    /// The entries and their pairs in a column, grouped by the block `(b, a)` they add to.
    pattern: EntryPairs,
    /// `t_ri ℓ_j(e_r)` and `t_ri (ℓ(e_r)ᵀÂ)_l` (`s × k × k`).
    wc: Vec<T>,
    wg: Vec<T>,
    /// `g_r(e)`, point after point (`r nnz + e`): the order the constraint lists them in.
    vals: Vec<T>,
    /// `C_e[i][j]` and `G_e[i][j]` at `(i k + j) nnz + e`: component after component, so that
    /// filling them is a sum of `s k²` vector updates over the entries.
    c: Vec<T>,
    g: Vec<T>,
    /// Rows that share no column, colour after colour: `colors[color_ptr[c]..color_ptr[c + 1]]`
    /// are the entries of colour `c`, whose values one product `G_rᵀ 1_c` gives at once
    /// (`ones`: `1_c`, `m` entries a colour). Empty when the constraint lists an entry twice
    /// or needs more than [`MAX_COLORS`] colours (its values are then taken through the
    /// listed entries).
    colors: Vec<usize>,
    color_ptr: Vec<usize>,
    ones: Vec<T>,
    /// Whether `c` and `g` are those of the last residual's points.
    fresh: bool,
    /// Whether the constraint listed the same entries at every point so far.
    usable: bool,
    /// Whether `c` and `g` were filled since construction (or a new quadrature).
    filled: bool,
}

impl<T: Real> ConstraintBlocks<T> {
    /// The symbolic part from the constraint's entries at `x0` (`n_q` positions); `None` when
    /// it lists no entries or one on a momentum.
    pub(super) fn new<V, C>(constraint: &C, x0: &V, nq: usize, tables: &Tables<T>) -> Option<Self>
    where
        V: Vector<Real = T>,
        C: HolonomicConstraint<V>,
    {
        let m = constraint.dim();
        let pattern = EntryPairs::new(constraint, x0, nq)?;
        let (k, s) = (tables.k, tables.s);
        let kk = k * k;
        let (wc, wg) = weights(tables);
        let (colors, color_ptr, ones) = color_rows(&pattern.rows, &pattern.of_col, m);
        let nnz = pattern.rows.len();
        Some(Self {
            k,
            m,
            wc,
            wg,
            vals: vec![T::zero(); s * nnz],
            c: vec![T::zero(); kk * nnz],
            g: vec![T::zero(); kk * nnz],
            colors,
            color_ptr,
            ones,
            fresh: false,
            usable: true,
            filled: false,
            pattern,
        })
    }

    /// The same blocks with their values taken through the listed entries, not by colour.
    #[cfg(test)]
    pub(super) fn by_entries(mut self) -> Self {
        (self.colors, self.color_ptr, self.ones) = (Vec::new(), vec![0], Vec::new());
        self
    }

    /// The number of colours (`0`: the values are taken through the listed entries).
    #[cfg(all(test, feature = "scene"))]
    pub(super) fn colors(&self) -> usize {
        self.color_ptr.len() - 1
    }

    /// The same entries for the tables of another quadrature (`s` points, the same `k`).
    pub(super) fn for_quadrature(&mut self, tables: &Tables<T>) {
        debug_assert_eq!(tables.k, self.k, "the stage count is fixed");
        (self.wc, self.wg) = weights(tables);
        self.vals = vec![T::zero(); tables.s * self.pattern.rows.len()];
        self.fresh = false;
        self.filled = false;
    }

    /// Whether the blocks hold values from a fill that succeeded (at whatever points it was).
    pub(super) fn filled(&self) -> bool {
        self.usable && self.filled
    }

    /// The points moved: the blocks are filled again when next asked for.
    pub(super) fn stale(&mut self) {
        self.fresh = false;
    }

    /// Fills the blocks at the quadrature points `xs` (step `h`, inverse masses `w`; `scratch`
    /// a state-sized vector) unless they are fresh; `false` when the constraint lists other
    /// entries than at construction (then and from then on: its products must be taken
    /// through the model).
    pub(super) fn refresh<V, C>(
        &mut self,
        constraint: &C,
        xs: &[V],
        h: T,
        w: &[T],
        scratch: &mut V,
    ) -> bool
    where
        V: Vector<Real = T>,
        C: HolonomicConstraint<V>,
    {
        if self.fresh || !self.usable {
            return self.usable;
        }
        let nnz = self.pattern.rows.len();
        let kk = self.k * self.k;
        debug_assert_eq!(xs.len() * nnz, self.vals.len(), "one point of values per x");
        let m = self.m;
        for (x, vals) in xs.iter().zip(self.vals.chunks_exact_mut(nnz)) {
            if self.colors.is_empty() {
                let mut fill = PatternFill {
                    rows: &self.pattern.rows,
                    cols: &self.pattern.cols,
                    vals,
                    next: 0,
                    same: true,
                };
                if !constraint.jacobian_entries(x, &mut fill) || !fill.same || fill.next != nnz {
                    self.usable = false;
                    return false;
                }
                continue;
            }
            // One product `G(x)ᵀ 1_c` a colour: its rows share no column, so each of their
            // entries is alone in its component.
            for (c, ones) in self.ones.chunks_exact(m).enumerate() {
                ops::fill_zero(scratch.as_mut_slice());
                constraint.jacobian_transpose_apply_add(x, ones, T::one(), scratch);
                let gq = scratch.as_slice();
                for &e in &self.colors[self.color_ptr[c]..self.color_ptr[c + 1]] {
                    vals[e] = gq[self.pattern.cols[e]];
                }
            }
        }
        ops::fill_zero(&mut self.c);
        ops::fill_zero(&mut self.g);
        for ((v, wc), wg) in self
            .vals
            .chunks_exact(nnz)
            .zip(self.wc.chunks_exact(kk))
            .zip(self.wg.chunks_exact(kk))
        {
            for ((c, &a), (g, &b)) in self
                .c
                .chunks_exact_mut(nnz)
                .zip(wc)
                .zip(self.g.chunks_exact_mut(nnz).zip(wg))
            {
                ops::axpy(c, a, v);
                ops::axpy(g, b, v);
            }
        }
        for g in self.g.chunks_exact_mut(nnz) {
            for (g, &d) in g.iter_mut().zip(&self.pattern.cols) {
                *g = *g * (h * w[d]);
            }
        }
        self.fresh = true;
        self.filled = true;
        true
    }

    /// `out_(d,·) += Σ_(a,d) C_(a,d) v_(a,·)`: the multiplier columns applied to `v`.
    pub(super) fn columns_add(&self, v: &[T], out: &mut [T]) {
        let (k, nnz) = (self.k, self.pattern.rows.len());
        for (ij, c) in self.c.chunks_exact(nnz).enumerate() {
            let (i, j) = (ij / k, ij % k);
            for ((&c, &a), &d) in c.iter().zip(&self.pattern.rows).zip(&self.pattern.cols) {
                out[d * k + i] = out[d * k + i] + c * v[a * k + j];
            }
        }
    }

    /// `out_(a,·) = Σ_(a,d) G_(a,d) v_(d,·)`: the constraint rows applied to momenta `v`.
    pub(super) fn rows_apply(&self, v: &[T], out: &mut [T]) {
        let (k, nnz) = (self.k, self.pattern.rows.len());
        ops::fill_zero(out);
        for (il, g) in self.g.chunks_exact(nnz).enumerate() {
            let (i, l) = (il / k, il % k);
            for ((&g, &a), &d) in g.iter().zip(&self.pattern.rows).zip(&self.pattern.cols) {
                out[a * k + i] = out[a * k + i] + g * v[d * k + l];
            }
        }
    }

    /// Adds `S = G D⁻¹ C` to `sink` (`inv_d`: the `k × k` blocks `D_d⁻¹`, position after
    /// position), block `(b, a)` at rows `b k …`, columns `a k …`.
    pub(super) fn schur_add(&self, inv_d: &[T], sink: &mut dyn Sink<T>) {
        match self.k {
            1 => self.schur_add_k::<1>(inv_d, sink),
            2 => self.schur_add_k::<2>(inv_d, sink),
            3 => self.schur_add_k::<3>(inv_d, sink),
            4 => self.schur_add_k::<4>(inv_d, sink),
            k => unreachable!("a Petrov–Galerkin step has at most 4 stages, not {k}"),
        }
    }

    /// [`schur_add`](Self::schur_add) with `k = K` known to the compiler.
    fn schur_add_k<const K: usize>(&self, inv_d: &[T], sink: &mut dyn Sink<T>) {
        let nnz = self.pattern.rows.len();
        let block_of = |m: &[T], e: usize| -> [[T; K]; K] {
            core::array::from_fn(|i| core::array::from_fn(|j| m[(i * K + j) * nnz + e]))
        };
        for (c, &(b, a)) in self.pattern.targets.iter().enumerate() {
            let mut block = [[T::zero(); K]; K];
            for &(e1, e2) in self.pattern.group(c) {
                let d = self.pattern.cols[e1];
                let inv = &inv_d[d * K * K..(d + 1) * K * K];
                let (g, cm) = (block_of(&self.g, e1), block_of(&self.c, e2));
                // block += G_e1 D_d⁻¹ C_e2.
                for (row, g) in block.iter_mut().zip(&g) {
                    let gd: [T; K] = core::array::from_fn(|m| {
                        (0..K).fold(T::zero(), |s, l| s + g[l] * inv[l * K + m])
                    });
                    for (j, o) in row.iter_mut().enumerate() {
                        *o = (0..K).fold(*o, |s, m| s + gd[m] * cm[m][j]);
                    }
                }
            }
            for (i, row) in block.iter().enumerate() {
                for (j, &v) in row.iter().enumerate() {
                    sink.add(b * K + i, a * K + j, v);
                }
            }
        }
    }
}

/// `t_ri ℓ_j(e_r)` and `t_ri (ℓ(e_r)ᵀÂ)_l` (`s × k × k`) from the tables.
fn weights<T: Real>(tables: &Tables<T>) -> (Vec<T>, Vec<T>) {
    let (k, s) = (tables.k, tables.s);
    let kk = k * k;
    let mut wc = vec![T::zero(); s * kk];
    let mut wg = vec![T::zero(); s * kk];
    for r in 0..s {
        for i in 0..k {
            let t = tables.test[r * k + i];
            for j in 0..k {
                wc[r * kk + i * k + j] = t * tables.ell[r * k + j];
                wg[r * kk + i * k + j] = t * tables.ell_ahat[r * k + j];
            }
        }
    }
    (wc, wg)
}

/// The most colours whose products fill the values; beyond them the listed entries do.
const MAX_COLORS: usize = 4;

// `schur_add` has a kernel for each stage count up to four.
const _: () = assert!(super::MAX_STAGES <= 4);

/// A colouring of the constraint rows such that rows of one colour share no column (greedy,
/// in row order): the entries of each colour (`colors`, `color_ptr`) and its indicator vector
/// over the `m` rows (`ones`). All empty when an entry is listed twice or more than
/// [`MAX_COLORS`] colours are needed.
fn color_rows<T: Real>(
    rows: &[usize],
    of_col: &[Vec<usize>],
    m: usize,
) -> (Vec<usize>, Vec<usize>, Vec<T>) {
    let mut neighbours: Vec<Vec<usize>> = vec![Vec::new(); m];
    for es in of_col {
        let mut rs: Vec<usize> = es.iter().map(|&e| rows[e]).collect();
        let listed = rs.len();
        rs.sort_unstable();
        rs.dedup();
        if rs.len() != listed {
            // A row lists this column twice: take the entries.
            return (Vec::new(), vec![0], Vec::new());
        }
        for &a in &rs {
            neighbours[a].extend(rs.iter().filter(|&&b| b != a));
        }
    }
    for n in &mut neighbours {
        n.sort_unstable();
        n.dedup();
    }
    let mut color = vec![usize::MAX; m];
    let mut taken = Vec::new();
    for a in 0..m {
        taken.clear();
        taken.extend(neighbours[a].iter().map(|&b| color[b]));
        color[a] = (0..).find(|c| !taken.contains(c)).unwrap_or(0);
    }
    let count = color.iter().map(|&c| c + 1).max().unwrap_or(0);
    if count > MAX_COLORS {
        // A body many constraints share (a hub): a product per colour at every point would
        // cost more than the one pass of the listed entries.
        return (Vec::new(), vec![0], Vec::new());
    }
    let mut ones = vec![T::zero(); count * m];
    for (a, &c) in color.iter().enumerate() {
        ones[c * m + a] = T::one();
    }
    let mut colors = Vec::with_capacity(rows.len());
    let mut color_ptr = vec![0];
    for c in 0..count {
        colors.extend((0..rows.len()).filter(|&e| color[rows[e]] == c));
        color_ptr.push(colors.len());
    }
    (colors, color_ptr, ones)
}

#[cfg(test)]
#[path = "blocks_tests.rs"]
mod tests;
