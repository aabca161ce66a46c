use super::{BandedLu, DenseLu, LinearSolver, ReorderedBanded, Sink, SparseLu, StackLu, Structure};
use crate::error::LinearSolveError;
use crate::real::Real;

/// Which backend a solver uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SolverKind {
    /// [`StackLu`]: fixed-capacity stack storage, no heap at all.
    Stack,
    /// [`DenseLu`]: faer's dense partial-pivoting LU.
    Dense,
    /// [`SparseLu`]: faer's simplicial sparse LU.
    Sparse,
    /// [`BandedLu`]: LU with partial pivoting in band storage.
    Banded,
}

/// The user's choice of backend for [`AutoLu`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SolverChoice {
    /// By size and sparsity (see [`AutoLu`]).
    #[default]
    Auto,
    /// Force a backend.
    Force(SolverKind),
}

/// A linear solver that picks its backend by size and sparsity, overridable.
///
/// With [`SolverChoice::Auto`]:
/// - `k ≤ STACK_ALWAYS` (8): [`StackLu`] — for a handful of unknowns the cost is overhead, not flops;
/// - a diagonal structure (independent unknowns, such as particles each on its own sphere):
///   [`BandedLu`] with no off-diagonal, `k` divisions;
/// - a banded structure with at most [`BANDED_MAX`] (8) diagonals on either side and
///   `k > SPARSE_MIN_DIM` (64), or a band at most a quarter as wide as `k`: [`BandedLu`] —
///   `O(k)` work with no symbolic phase and no indirection, the cheapest for chains, for
///   block-diagonal systems of a few unknowns a block, and other topologies of small bandwidth;
/// - otherwise `k ≤ STACK_MAX` (16): [`StackLu`] — at a rigid body's six to fifteen rows faer's
///   dense LU is still mostly overhead;
/// - a sparse (or wider banded) structure with `k > SPARSE_MIN_DIM` and at most `k²/10`
///   entries: [`SparseLu`] — dense LU costs `2k³/3` flops, a tree-like sparse LU `O(nnz)`;
/// - otherwise [`DenseLu`].
///
/// Created from a pattern ([`LinearSolver::with_pattern`]) whose natural order would take the
/// sparse or dense backend, it first tries the reverse Cuthill–McKee renumbering: when that
/// puts the pattern in a band of at most [`BANDED_MAX`] diagonals, [`ReorderedBanded`] —
/// a chain's reduced Newton matrix, positions before multipliers, becomes banded.
///
/// [`SolverChoice::Force`] takes the named backend (a stack solver larger than 8 is a
/// [`LinearSolveError::TooLarge`]). Created without structure ([`LinearSolver::with_dim`]) it
/// assumes a dense matrix.
// One solver per Newton instance, built once: the variants' size difference costs nothing,
// and boxing the stack variant would put it on the heap.
#[allow(clippy::large_enum_variant)]
#[derive(Debug)]
pub enum AutoLu<T: Real + faer::traits::RealField + nalgebra::Scalar> {
    /// Stack storage.
    Stack(StackLu<T, STACK_MAX>),
    /// Dense heap storage.
    Dense(DenseLu<T>),
    /// Sparse storage.
    Sparse(SparseLu<T>),
    /// Band storage.
    Banded(BandedLu<T>),
    /// Band storage of the renumbered unknowns.
    Reordered(ReorderedBanded<T>),
}

/// Largest system [`AutoLu`] solves on the stack.
pub const STACK_MAX: usize = 16;
/// Largest system [`AutoLu`] solves on the stack whatever its structure (above it a diagonal
/// or a narrow band takes the band solver).
pub const STACK_ALWAYS: usize = 8;
/// Smallest system [`AutoLu`] solves with the sparse or banded backend.
pub const SPARSE_MIN_DIM: usize = 64;
/// Widest band (diagonals below or above the main one) [`AutoLu`] solves with [`BandedLu`].
pub const BANDED_MAX: usize = 8;

impl<T: Real + faer::traits::RealField + nalgebra::Scalar> AutoLu<T> {
    /// The backend [`SolverChoice::Auto`] picks for a `k × k` matrix of this structure.
    pub fn auto_kind(k: usize, structure: Structure) -> SolverKind {
        match structure {
            _ if k <= STACK_ALWAYS => SolverKind::Stack,
            // A diagonal: k divisions, whatever k (dense LU would cost 2k³/3 and its overhead).
            Structure::Banded {
                lower: 0, upper: 0, ..
            } => SolverKind::Banded,
            // A narrow band: O(k p (p + q)) flops against dense LU's 2k³/3; below 64 unknowns
            // only when the band holds at most a quarter of each row.
            Structure::Banded { lower, upper, .. }
                if lower <= BANDED_MAX
                    && upper <= BANDED_MAX
                    && (k > SPARSE_MIN_DIM || 4 * (lower + upper + 1) <= k) =>
            {
                SolverKind::Banded
            }
            _ if k <= STACK_MAX => SolverKind::Stack,
            Structure::Sparse { nnz } | Structure::Banded { nnz, .. }
                if k > SPARSE_MIN_DIM && nnz.saturating_mul(10) <= k * k =>
            {
                SolverKind::Sparse
            }
            _ => SolverKind::Dense,
        }
    }
}

macro_rules! each {
    ($self:expr, $s:ident => $e:expr) => {
        match $self {
            AutoLu::Stack($s) => $e,
            AutoLu::Dense($s) => $e,
            AutoLu::Sparse($s) => $e,
            AutoLu::Banded($s) => $e,
            AutoLu::Reordered($s) => $e,
        }
    };
}

impl<T: Real + faer::traits::RealField + nalgebra::Scalar> Sink<T> for AutoLu<T> {
    #[inline]
    fn add(&mut self, row: usize, col: usize, value: T) {
        each!(self, s => s.add(row, col, value))
    }
    #[inline]
    fn dense_columns(&mut self) -> Option<(&mut [T], usize, usize)> {
        match self {
            AutoLu::Stack(s) => s.dense_columns(),
            _ => None,
        }
    }
}

impl<T: Real + faer::traits::RealField + nalgebra::Scalar> LinearSolver<T> for AutoLu<T> {
    fn with_dim(k: usize) -> Result<Self, LinearSolveError> {
        Self::with_structure(k, Structure::Dense, SolverChoice::Auto)
    }

    fn with_structure(
        k: usize,
        structure: Structure,
        choice: SolverChoice,
    ) -> Result<Self, LinearSolveError> {
        let kind = match choice {
            SolverChoice::Auto => Self::auto_kind(k, structure),
            SolverChoice::Force(kind) => kind,
        };
        Ok(match kind {
            SolverKind::Stack => AutoLu::Stack(StackLu::with_dim(k)?),
            SolverKind::Dense => AutoLu::Dense(DenseLu::with_dim(k)?),
            SolverKind::Sparse => AutoLu::Sparse(SparseLu::with_dim(k)?),
            SolverKind::Banded => AutoLu::Banded(BandedLu::with_structure(k, structure, choice)?),
        })
    }

    fn with_pattern(
        k: usize,
        pattern: &[(usize, usize)],
        choice: SolverChoice,
    ) -> Result<Self, LinearSolveError> {
        let structure = Structure::of_pattern(pattern);
        if choice == SolverChoice::Auto
            && matches!(
                Self::auto_kind(k, structure),
                SolverKind::Sparse | SolverKind::Dense
            )
            && k > SPARSE_MIN_DIM
            && let Some(solver) = ReorderedBanded::for_pattern(k, pattern, BANDED_MAX)
        {
            return Ok(AutoLu::Reordered(solver));
        }
        Self::with_structure(k, structure, choice)
    }

    fn dim(&self) -> usize {
        each!(self, s => s.dim())
    }

    #[inline]
    fn column_mut(&mut self, j: usize) -> Option<&mut [T]> {
        each!(self, s => s.column_mut(j))
    }

    fn clear(&mut self) {
        each!(self, s => s.clear())
    }

    fn kind(&self) -> SolverKind {
        each!(self, s => s.kind())
    }

    fn factor(&mut self) -> Result<(), LinearSolveError> {
        each!(self, s => s.factor())
    }

    #[inline]
    fn solve_in_place(&mut self, rhs: &mut [T]) -> Result<(), LinearSolveError> {
        each!(self, s => s.solve_in_place(rhs))
    }
}
