//! The multiplier Jacobians of a projection around a model of mechanical form, summed in
//! closed form from the constraint's listed Jacobian entries instead of one product with the
//! whole `G` per colour group of multipliers.
//!
//! For `H = ½ pᵀW⁻¹p + V(q)`, `M = [[0, I], [−I, B]]` and constraints `g(q)` (Hairer, Lubich &
//! Wanner, *Geometric Numerical Integration*, §VII.1.4 — RATTLE's Newton matrices), the two
//! decoupled systems of a step are
//!
//! ```text
//! λ_{k+1}:  φ(y + (h/2) M Gᵀλ) = φ(y) − (h/2) G(y) W⁻¹ G(y)ᵀ λ          (the half-step keeps G),
//! λ_k:      ∂g(y)/∂λ_k = −(h²/2) G(y) W⁻¹ G(x)ᵀ
//! ```
//!
//! the second when the inner flow's lead moves positions by exactly `h W⁻¹ δp` for a momentum
//! change `δp` at its start (a kick, then the drift) — read off the lead's own tangent map at
//! each Jacobian, so that a damping or coupling sub-flow that changes it falls back to the
//! grouped products. Both are `Σ_d G(a)_{i d} w_d G(b)_{j d}`, a sum over the pairs of entries
//! that meet in a column `d`: faer's symbolic/numeric split — the pairs are found once from
//! the pattern at construction, each Jacobian is one or two passes of the constraint's entries
//! and one pass over the pairs ([`EntryPairs`]). For a heavy top (six rows of `QᵀQ = I`
//! and three of its ball joint, in six colour groups) that is 147 products where the grouped
//! path took six products with `G` and `Gᵀ`. The projection uses the sums above three colour
//! groups only: at three or fewer the grouped products cost as little, and their Jacobians
//! kept across steps less.

use crate::flow::Flow;
use crate::flow::entry_pairs::EntryPairs;
use crate::linalg::{PatternFill, Sink};
use crate::real::Real;
use crate::system::HolonomicConstraint;
use crate::vector::Vector;
use num_traits::Float as _;
use num_traits::Zero;

/// The pattern of `G` and the pairs of its entries that meet in a column, with the values of
/// `G` at the step's start `x` and at `y`.
#[derive(Debug, Clone)]
pub(super) struct Gram<T> {
    pattern: EntryPairs,
    at_x: Vec<T>,
    /// `G(y)` times the inverse mass of each entry's column.
    at_y: Vec<T>,
    /// `G(y)` itself (the right factor of `G(y) W⁻¹ G(y)ᵀ`, without a division per pair).
    raw_y: Vec<T>,
    /// The positions `raw_y` was filled at: `G` reads positions only, so a step that starts
    /// where the last `λ_{k+1}` solve's `y` left them (every step after the first: the second
    /// half-step moves momenta only) has its `G(x)` already.
    y_positions: Vec<T>,
    /// `at_x` holds `G` at the present solve's `x`.
    x_fresh: bool,
    /// `at_y` and `raw_y` hold `G` at the present `y` (see [`forget_y`](Self::forget_y)).
    y_fresh: bool,
    /// `raw_y` holds `G` at `y_positions` (from any earlier fill).
    y_filled: bool,
    /// The constraint listed the same entries at every point so far.
    usable: bool,
    /// One more than the largest row or column of a product entry.
    span: usize,
}

/// Which values of `G` the right factor of a product is taken at.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Right {
    /// `G(y) W⁻¹ G(x)ᵀ` (the `λ_k` system).
    AtX,
    /// `G(y) W⁻¹ G(y)ᵀ` (the `λ_{k+1}` system).
    AtY,
}

impl<T: Real> Gram<T> {
    /// The symbolic part from the constraint's entries at `x0` (`nq` positions); `None` when
    /// it lists none, or one on a momentum or outside its rows.
    pub(super) fn new<V, C>(constraint: &C, x0: &V, nq: usize) -> Option<Self>
    where
        V: Vector<Real = T>,
        C: HolonomicConstraint<V>,
    {
        let pattern = EntryPairs::new(constraint, x0, nq)?;
        let nnz = pattern.rows.len();
        let span = pattern.targets.iter().map(|&(i, j)| i.max(j) + 1).max();
        Some(Self {
            span: span.unwrap_or(0),
            pattern,
            at_x: vec![T::zero(); nnz],
            at_y: vec![T::zero(); nnz],
            raw_y: vec![T::zero(); nnz],
            y_positions: vec![T::zero(); nq],
            x_fresh: false,
            y_fresh: false,
            y_filled: false,
            usable: true,
        })
    }

    /// The constraint listed the same entries at every point so far.
    pub(super) fn usable(&self) -> bool {
        self.usable
    }

    /// A new solve starts from another `x`: `G(x)` is filled again at the next product.
    pub(super) fn forget_x(&mut self) {
        self.x_fresh = false;
    }

    /// `y` changed (a new iterate, a new solve): the values at `y` are stale until filled.
    pub(super) fn forget_y(&mut self) {
        self.y_fresh = false;
    }

    /// The values at `y` belong to the present `y`.
    pub(super) fn y_fresh(&self) -> bool {
        self.y_fresh && self.usable
    }

    /// `out = G(y) W⁻¹ p` (`p` the momenta, `m` rows): the hidden constraint of a model of
    /// mechanical form at a point with `y`'s positions, from the values last filled at `y`.
    pub(super) fn velocity(&self, p: &[T], out: &mut [T]) {
        out.iter_mut().for_each(|o| *o = T::zero());
        let pat = &self.pattern;
        for ((&v, &r), &c) in self.at_y.iter().zip(&pat.rows).zip(&pat.cols) {
            out[r] = out[r] + v * p[c];
        }
    }

    /// `out += scale · G(·)ᵀ a` on the positions' columns (`out` as long as the positions),
    /// from the values last filled at `x` or `y`: one pass over the entries.
    pub(super) fn transpose_add(&self, at: Right, a: &[T], scale: T, out: &mut [T]) {
        let vals = match at {
            Right::AtX => &self.at_x,
            Right::AtY => &self.raw_y,
        };
        let p = &self.pattern;
        for ((&v, &r), &c) in vals.iter().zip(&p.rows).zip(&p.cols) {
            out[c] = out[c] + scale * a[r] * v;
        }
    }

    /// Fills the values of `G` at the solve's start `x` (once a solve) or at `y` (`at_y`,
    /// scaled by the inverse masses `w`); `false` — then and from then on — when the
    /// constraint lists other entries than at construction.
    pub(super) fn fill<V, C>(&mut self, constraint: &C, x: &V, at_y: bool, w: &[T]) -> bool
    where
        V: Vector<Real = T>,
        C: HolonomicConstraint<V>,
    {
        if !self.usable {
            return false;
        }
        if (!at_y && self.x_fresh) || (at_y && self.y_fresh) {
            return true;
        }
        let nq = self.y_positions.len();
        if !at_y && self.y_filled && x.as_slice()[..nq] == self.y_positions[..] {
            self.at_x.copy_from_slice(&self.raw_y);
            self.x_fresh = true;
            return true;
        }
        let vals = if at_y { &mut self.at_y } else { &mut self.at_x };
        let nnz = vals.len();
        // The values alone where the constraint offers them (in the order it listed its
        // entries, by contract); else every entry through a sink that checks its position.
        if !constraint.jacobian_values(x, vals) {
            let mut fill = PatternFill {
                rows: &self.pattern.rows,
                cols: &self.pattern.cols,
                vals,
                next: 0,
                same: true,
            };
            self.usable =
                constraint.jacobian_entries(x, &mut fill) && fill.same && fill.next == nnz;
        }
        if at_y {
            for ((v, r), &d) in self
                .at_y
                .iter_mut()
                .zip(&mut self.raw_y)
                .zip(&self.pattern.cols)
            {
                *r = *v;
                *v = *v * w[d];
            }
            self.y_fresh = self.usable;
            self.y_filled = self.usable;
            self.y_positions.copy_from_slice(&x.as_slice()[..nq]);
        } else {
            self.x_fresh = self.usable;
        }
        self.usable
    }

    /// `Σ at_y[a] other[b]` over the pairs of entries that meet in a column for target `t`.
    #[inline(always)]
    fn pair_sum(&self, t: usize, other: &[T]) -> T {
        self.pattern
            .group(t)
            .iter()
            .fold(T::zero(), |s, &(a, b)| s + self.at_y[a] * other[b])
    }

    /// Adds `scale · G(y) W⁻¹ G(·)ᵀ` into `sink`, from the values last filled: into its dense
    /// storage when it keeps one ([`Sink::dense_columns`]), else one addition per entry.
    pub(super) fn add_to(&self, scale: T, right: Right, sink: &mut dyn Sink<T>) {
        let p = &self.pattern;
        // `G(y)` on the right is `raw_y` (`at_y` carries W⁻¹ already).
        let other = match right {
            Right::AtX => &self.at_x,
            Right::AtY => &self.raw_y,
        };
        // Dense storage: no call per entry.
        if let Some((values, ld, k)) = sink.dense_columns()
            && self.span <= k
        {
            for (t, &(i, j)) in p.targets.iter().enumerate() {
                // Symmetric at `y`: each entry above the diagonal summed once, put twice.
                if right == Right::AtY && i > j {
                    continue;
                }
                let v = scale * self.pair_sum(t, other);
                values[j * ld + i] = values[j * ld + i] + v;
                if right == Right::AtY && i != j {
                    values[i * ld + j] = values[i * ld + j] + v;
                }
            }
            return;
        }
        for (t, &(i, j)) in p.targets.iter().enumerate() {
            // Symmetric at `y`: each entry above the diagonal summed once and added twice.
            if right == Right::AtY && i > j {
                continue;
            }
            let v = scale * self.pair_sum(t, other);
            sink.add(i, j, v);
            if right == Right::AtY && i != j {
                sink.add(j, i, v);
            }
        }
    }
}

/// Whether the lead of `inner` (last stepped at the current iterate) moves positions by
/// exactly `h W⁻¹ δp` for the momentum change `δp` that `v` holds (its positions zero): a
/// constraint impulse `G(x)ᵀμ`, for which the summed `λ_k` Jacobian `G(y) W⁻¹ G(x)ᵀ` is exact.
/// A free drift after a kick passes for every `δp`; so does a kick holding dampers that act
/// along directions `W⁻¹`-orthogonal to every constraint force (the scene's joint dampers,
/// `D Gᵀμ = Gᵀμ`); exact damping of the momenta themselves does not. Compared in the
/// max-norm, to `64 ε` of the expected change. `out` is state-sized scratch.
pub(super) fn lead_drifts_freely<V, F>(
    inner: &mut F,
    h: V::Real,
    w: &[V::Real],
    v: &V,
    out: &mut V,
) -> bool
where
    V: Vector,
    F: Flow<V>,
{
    let nq = w.len();
    if !inner.lead_tangent_apply(v, out) {
        return false;
    }
    let p = &v.as_slice()[nq..];
    let (mut worst, mut size) = (V::Real::zero(), V::Real::zero());
    for ((&o, &u), &wi) in out.as_slice()[..nq].iter().zip(p).zip(w) {
        let expected = h * wi * u;
        worst = worst.max((o - expected).abs());
        size = size.max(expected.abs());
    }
    size > V::Real::zero() && worst <= V::Real::lit(64.0) * V::Real::epsilon() * size
}

#[cfg(test)]
#[path = "gram_tests.rs"]
mod tests;
