use super::ordering::{bandwidth_under, inverse, reverse_cuthill_mckee};
use super::{BandedLu, LinearSolver, Sink, SolverKind, Structure};
use crate::error::LinearSolveError;
use crate::real::Real;

/// A [`BandedLu`] on the unknowns renumbered by the reverse Cuthill–McKee ordering of the
/// matrix's pattern ([`reverse_cuthill_mckee`](super::ordering::reverse_cuthill_mckee)): for a
/// pattern that is narrow only in another order, such as the Newton matrix of a chain's reduced
/// implicit step `[[A, C], [G, 0]]` with all positions before all multipliers (its natural
/// band is as wide as the chain; renumbered body, rod, body, … it is a few entries wide), LU
/// with partial pivoting in `O(k)` instead of a sparse LU whose pivoting fills in.
///
/// Entries are added, and right-hand sides given and solutions returned, in the original
/// numbering; errors name the original rows and columns. No allocation after construction.
#[derive(Debug, Clone)]
pub struct ReorderedBanded<T> {
    lu: BandedLu<T>,
    /// `order[new] = old`, `place[old] = new`.
    order: Vec<usize>,
    place: Vec<usize>,
    work: Vec<T>,
}

impl<T: Real> ReorderedBanded<T> {
    /// The solver for a `k × k` matrix with this `pattern` (duplicates allowed) when its
    /// renumbered band has at most `max_band` diagonals on either side and is narrower than
    /// its natural one; `None` otherwise.
    pub fn for_pattern(k: usize, pattern: &[(usize, usize)], max_band: usize) -> Option<Self> {
        let order = reverse_cuthill_mckee(k, pattern);
        let place = inverse(&order);
        let (lower, upper) = bandwidth_under(pattern, &place);
        let natural = match Structure::of_pattern(pattern) {
            Structure::Banded { lower, upper, .. } => lower.max(upper),
            _ => k,
        };
        (lower.max(upper) <= max_band && lower.max(upper) < natural).then(|| Self {
            lu: BandedLu::new(k, lower, upper),
            order,
            place,
            work: vec![T::zero(); k],
        })
    }

    /// The number of sub- and superdiagonals in the renumbered order.
    pub fn bandwidth(&self) -> (usize, usize) {
        self.lu.bandwidth()
    }
}

impl<T: Real> Sink<T> for ReorderedBanded<T> {
    #[inline]
    fn add(&mut self, row: usize, col: usize, value: T) {
        match (self.place.get(row), self.place.get(col)) {
            (Some(&r), Some(&c)) => self.lu.add(r, c, value),
            // Out of the matrix: the band solver records and reports it.
            _ => self.lu.add(row, col, value),
        }
    }
}

impl<T: Real> LinearSolver<T> for ReorderedBanded<T> {
    /// Without a pattern there is nothing to renumber: the identity order and a full band.
    fn with_dim(k: usize) -> Result<Self, LinearSolveError> {
        let order: Vec<usize> = (0..k).collect();
        Ok(Self {
            lu: BandedLu::new(k, k, k),
            place: order.clone(),
            order,
            work: vec![T::zero(); k],
        })
    }

    fn dim(&self) -> usize {
        self.lu.dim()
    }

    fn column_mut(&mut self, _j: usize) -> Option<&mut [T]> {
        None
    }

    fn clear(&mut self) {
        self.lu.clear();
    }

    fn kind(&self) -> SolverKind {
        SolverKind::Banded
    }

    fn factor(&mut self) -> Result<(), LinearSolveError> {
        let order = &self.order;
        self.lu
            .factor()
            .map_err(|e| e.renumbered(|i| order.get(i).copied().unwrap_or(i)))
    }

    fn solve_in_place(&mut self, rhs: &mut [T]) -> Result<(), LinearSolveError> {
        for (w, &old) in self.work.iter_mut().zip(&self.order) {
            *w = rhs[old];
        }
        self.lu.solve_in_place(&mut self.work)?;
        for (&old, &w) in self.order.iter().zip(&self.work) {
            rhs[old] = w;
        }
        Ok(())
    }
}
