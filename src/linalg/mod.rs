//! Linear solvers for the Newton matrices of the multiplier systems.
//!
//! A solver is sized once ([`LinearSolver::with_dim`], may allocate), then used many times:
//! write the matrix column by column ([`LinearSolver::column_mut`]), [`factor`](LinearSolver::factor),
//! [`solve_in_place`](LinearSolver::solve_in_place) — with no allocation after construction.
//!
//! - [`StackLu`]: nalgebra LU on a fixed `N × N` stack matrix, for small systems (`k ≤ N`).
//! - [`DenseLu`]: faer's low-level partial-pivoting LU with a reused workspace, for larger dense systems.
//! - [`BandedLu`]: LU with partial pivoting in band storage, for a narrow band (a chain's
//!   tridiagonal multiplier systems);
//! - [`SparseLu`]: faer's simplicial sparse LU; symbolic analysis once per pattern, numeric
//!   refactorization without allocation, for large systems with a sparse Jacobian.
//! - [`AutoLu`]: picks one of the above by size and sparsity ([`SolverChoice`]), overridable.
//!
//! Every solver is also a [`Sink`]: a matrix is assembled by [`LinearSolver::clear`] and
//! [`Sink::add`] calls, the same code for dense and sparse storage. A dense solver also exposes
//! its columns ([`LinearSolver::column_mut`]) for column-wise fills and rank-one updates.

mod any_lu;
mod banded_lu;
mod coloring;
mod dense_lu;
mod ordering;
mod reordered_banded;
mod sparse_lu;
mod stack_lu;

pub use any_lu::{AutoLu, BANDED_MAX, SolverChoice, SolverKind};
pub use banded_lu::BandedLu;
pub(crate) use coloring::ColumnGroups;
pub use dense_lu::DenseLu;
pub use reordered_banded::ReorderedBanded;
pub use sparse_lu::SparseLu;
pub use stack_lu::StackLu;

use crate::error::LinearSolveError;
use crate::real::Real;

/// Receives the entries of a matrix one at a time: the single assembly interface through which
/// a model's or a solver's code fills dense and sparse storage alike.
///
/// Entries at the same position are summed. A sparse receiver records the sequence of positions
/// of its first assembly as its pattern; later assemblies add positions of that pattern (values
/// may change, including to zero) — in the same order they cost one comparison an entry, in
/// another a search in the entry's column.
pub trait Sink<T> {
    /// Adds `value` at `(row, col)`.
    fn add(&mut self, row: usize, col: usize, value: T);
    /// The matrix being assembled as dense column-major storage — `(values, leading
    /// dimension, order k)`, entry `(i, j)` at `values[j · ld + i]` for `i, j < k` — when the
    /// sink keeps one; `None` (the default) otherwise. A caller that fills every entry of a
    /// small system writes there instead of one [`add`](Self::add) call per entry; a sink that
    /// returns it must accept such writes as additions would be.
    fn dense_columns(&mut self) -> Option<(&mut [T], usize, usize)> {
        None
    }
}

/// A [`Sink`] that keeps the entries as `(row, col, value)` triplets, in the order added:
/// how a sparsity pattern is learned from the same code that later fills the values.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Triplets<T> {
    /// The entries in the order they were added (duplicates kept).
    pub entries: Vec<(usize, usize, T)>,
}

impl<T> Sink<T> for Triplets<T> {
    fn add(&mut self, row: usize, col: usize, value: T) {
        self.entries.push((row, col, value));
    }
}

/// A [`Sink`] that writes the values of a known pattern in order (`rows`, `cols` as first
/// listed) into `vals`, and notes any entry that is not the one expected: the numeric half of a
/// symbolic/numeric split over a constraint's listed Jacobian entries.
pub(crate) struct PatternFill<'a, T> {
    pub(crate) rows: &'a [usize],
    pub(crate) cols: &'a [usize],
    pub(crate) vals: &'a mut [T],
    /// The entries added so far.
    pub(crate) next: usize,
    /// Every entry so far was the one expected.
    pub(crate) same: bool,
}

impl<T> Sink<T> for PatternFill<'_, T> {
    #[inline]
    fn add(&mut self, row: usize, col: usize, value: T) {
        let e = self.next;
        if e < self.vals.len() && self.rows[e] == row && self.cols[e] == col {
            self.vals[e] = value;
        } else {
            self.same = false;
        }
        self.next += 1;
    }
}

/// What a solver is told about the matrix before it is assembled, so that
/// [`AutoLu`] can choose its backend (other solvers ignore it).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Structure {
    /// Nothing known: every entry may be non-zero.
    Dense,
    /// At most `nnz` entries will be added per assembly.
    Sparse {
        /// The number of structurally non-zero entries.
        nnz: usize,
    },
    /// Sparse with every entry within `lower` diagonals below and `upper` above the main
    /// diagonal (`nnz` entries in all): [`AutoLu`] picks [`BandedLu`] for a narrow band.
    Banded {
        /// Subdiagonals.
        lower: usize,
        /// Superdiagonals.
        upper: usize,
        /// The number of structurally non-zero entries.
        nnz: usize,
    },
}

impl Structure {
    /// The structure of a pattern of `(row, col)` positions (duplicates allowed): always
    /// [`Structure::Banded`], with the pattern's bandwidth and number of distinct entries.
    pub fn of_pattern(pattern: &[(usize, usize)]) -> Self {
        let (mut lower, mut upper) = (0, 0);
        for &(r, c) in pattern {
            lower = lower.max(r.saturating_sub(c));
            upper = upper.max(c.saturating_sub(r));
        }
        Structure::Banded {
            lower,
            upper,
            nnz: pattern.len(),
        }
    }
}

/// A reusable solver for `k × k` linear systems `A z = b`.
///
/// Assembly: [`clear`](Self::clear), then [`Sink::add`] for every entry (or, for dense storage,
/// writes through [`column_mut`](Self::column_mut)), then [`factor`](Self::factor).
pub trait LinearSolver<T: Real>: Sized + Send + Sink<T> {
    /// Creates a solver for `k × k` systems (allocates what it needs, once).
    fn with_dim(k: usize) -> Result<Self, LinearSolveError>;
    /// Creates a solver for `k × k` systems whose structure is known; `choice` overrides the
    /// backend of solvers that have several ([`AutoLu`]). Solvers with one backend ignore both
    /// hints (the type is the choice). Default: [`with_dim`](Self::with_dim).
    fn with_structure(
        k: usize,
        structure: Structure,
        choice: SolverChoice,
    ) -> Result<Self, LinearSolveError> {
        let _ = (structure, choice);
        Self::with_dim(k)
    }
    /// Creates a solver for `k × k` systems with this sparsity `pattern` of `(row, col)`
    /// positions (duplicates allowed), which a solver may renumber ([`AutoLu`] does, to put a
    /// pattern that is narrow only in another order into a band). Default:
    /// [`with_structure`](Self::with_structure) of [`Structure::of_pattern`].
    fn with_pattern(
        k: usize,
        pattern: &[(usize, usize)],
        choice: SolverChoice,
    ) -> Result<Self, LinearSolveError> {
        Self::with_structure(k, Structure::of_pattern(pattern), choice)
    }
    /// The dimension `k`.
    fn dim(&self) -> usize;
    /// Column `j` of the stored matrix (`k` entries) for dense storage; `None` for sparse
    /// storage (assemble through [`Sink::add`] instead) or `j ≥ k`. The matrix persists across
    /// [`factor`](Self::factor) calls, so it can be rewritten whole or updated in place.
    fn column_mut(&mut self, j: usize) -> Option<&mut [T]>;
    /// Starts an assembly: every stored entry becomes zero.
    fn clear(&mut self);
    /// The backend in use.
    fn kind(&self) -> SolverKind;
    /// Factors the matrix written through [`column_mut`](Self::column_mut).
    ///
    /// Fails with [`LinearSolveError::Singular`] when a pivot is below `k · ε` times the
    /// largest pivot (the matrix is singular to working precision).
    fn factor(&mut self) -> Result<(), LinearSolveError>;
    /// Overwrites `rhs` (first `k` entries) with `A⁻¹ rhs`, using the last factorization.
    fn solve_in_place(&mut self, rhs: &mut [T]) -> Result<(), LinearSolveError>;
}

/// Checks the pivots `u_ii` of an LU factorization of a finite matrix (every solver checks its
/// entries first): returns the first pivot, in elimination order, that is tiny relative to the
/// largest finite pivot — or not finite, which after an exactly zero pivot is what elimination
/// produces — as [`LinearSolveError::Singular`].
pub(crate) fn check_pivots<T: Real>(
    k: usize,
    pivot: impl Fn(usize) -> T,
) -> Result<(), LinearSolveError> {
    check_pivots_of(k, k, pivot)
}

/// [`check_pivots`] for a factorization whose pivots are each formed from at most `terms`
/// products (a sparse LU's longest column of `U`): the rounding of a pivot is bounded by
/// `γ_terms` times the sizes it is formed from (Higham, *Accuracy and Stability of Numerical
/// Algorithms*, 2nd ed., Thm 9.3, with the inner products' lengths those of the nonzeros), so
/// a pivot below `terms · ε` times the largest is singular to working precision. A dense
/// factorization's `terms` is `k`.
pub(crate) fn check_pivots_of<T: Real>(
    k: usize,
    terms: usize,
    pivot: impl Fn(usize) -> T,
) -> Result<(), LinearSolveError> {
    let mut max = T::zero();
    for i in 0..k {
        let p = pivot(i).abs();
        if p.is_finite() {
            max = max.max(p);
        }
    }
    let tol = T::lit(terms.clamp(1, k.max(1)) as f64) * T::epsilon() * max;
    for i in 0..k {
        let p = pivot(i).abs();
        if !p.is_finite() || p <= tol || max == T::zero() {
            return Err(LinearSolveError::Singular {
                pivot: i,
                magnitude: p.to_f64_lossy(),
                ratio: if max > T::zero() {
                    (p / max).to_f64_lossy()
                } else {
                    0.0
                },
            });
        }
    }
    Ok(())
}

/// Returns the position of the first non-finite entry of a column-major `k × k` matrix.
pub(crate) fn check_finite<T: Real>(k: usize, col: impl Fn(usize) -> T) -> Option<(usize, usize)> {
    (0..k * k)
        .find(|&idx| !col(idx).is_finite())
        .map(|idx| (idx % k, idx / k))
}
