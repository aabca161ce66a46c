//! Linear solvers for the Newton matrices of the multiplier systems.
//!
//! A solver is sized once ([`LinearSolver::with_dim`], may allocate), then used many times:
//! write the matrix column by column ([`LinearSolver::column_mut`]), [`factor`](LinearSolver::factor),
//! [`solve_in_place`](LinearSolver::solve_in_place) — with no allocation after construction.
//!
//! - [`StackLu`]: nalgebra LU on a fixed `N × N` stack matrix, for small systems (`k ≤ N`).
//! - [`DenseLu`]: faer's low-level partial-pivoting LU with a reused workspace, for larger dense systems.
//!
//! A sparse backend plugs in behind the same trait.

mod dense_lu;
mod stack_lu;

pub use dense_lu::DenseLu;
pub use stack_lu::StackLu;

use crate::error::LinearSolveError;
use crate::real::Real;

/// A reusable solver for `k × k` linear systems `A z = b`.
pub trait LinearSolver<T: Real>: Sized + Send {
    /// Creates a solver for `k × k` systems (allocates what it needs, once).
    fn with_dim(k: usize) -> Result<Self, LinearSolveError>;
    /// The dimension `k`.
    fn dim(&self) -> usize;
    /// Column `j` of the stored matrix (`k` entries). The matrix persists across
    /// [`factor`](Self::factor) calls, so it can be rewritten whole or updated in place.
    fn column_mut(&mut self, j: usize) -> &mut [T];
    /// Factors the matrix written through [`column_mut`](Self::column_mut).
    ///
    /// Fails with [`LinearSolveError::Singular`] when a pivot is below `k · ε` times the
    /// largest pivot (the matrix is singular to working precision).
    fn factor(&mut self) -> Result<(), LinearSolveError>;
    /// Overwrites `rhs` (first `k` entries) with `A⁻¹ rhs`, using the last factorization.
    fn solve_in_place(&mut self, rhs: &mut [T]) -> Result<(), LinearSolveError>;
}

/// Checks the pivots `u_ii` of an LU factorization: returns the first one that is tiny
/// relative to the largest, which signals a singular matrix to working precision.
pub(crate) fn check_pivots<T: Real>(
    k: usize,
    pivot: impl Fn(usize) -> T,
) -> Result<(), LinearSolveError> {
    let mut max = T::zero();
    for i in 0..k {
        let p = pivot(i).abs();
        if !p.is_finite() {
            return Err(LinearSolveError::NonFinite { row: i, col: i });
        }
        max = max.max(p);
    }
    let tol = T::lit(k.max(1) as f64) * T::epsilon() * max;
    for i in 0..k {
        let p = pivot(i).abs();
        if p <= tol || max == T::zero() {
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
