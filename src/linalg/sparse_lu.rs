use super::{LinearSolver, Sink, SolverKind, check_pivots_of};
use crate::error::LinearSolveError;
use crate::real::Real;
use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::perm::PermRef;
use faer::sparse::linalg::lu::simplicial::{self, SimplicialLu};
use faer::sparse::linalg::lu::{LuSymbolicParams, SymbolicLu, factorize_symbolic_lu};
use faer::sparse::linalg::{LuError, SupernodalThreshold};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMat};
use faer::{Conj, MatMut, Par};

/// faer's sparse LU (left-looking simplicial Gilbert–Peierls with partial pivoting and a COLAMD
/// column ordering) behind the [`LinearSolver`] seam, for large systems with a sparse matrix.
///
/// **Assembly.** Entries arrive through [`Sink::add`]. The first assembly is recorded as the
/// pattern (positions in order; duplicates are summed); the first [`factor`](LinearSolver::factor)
/// sorts it into compressed-column form, runs the symbolic analysis (COLAMD ordering, column
/// elimination tree) once, and allocates the scratch memory. Every later assembly must add the
/// same positions in the same order — each `add` is then a compare and an indexed add. A
/// different order is a bug in the caller: it trips a `debug_assert!`, and in release builds
/// `factor` returns [`LinearSolveError::PatternChanged`].
///
/// **No allocation after warm-up.** Refactorizations reuse the symbolic analysis, the scratch
/// buffer and the capacity of the `L`/`U` storage; they allocate only if pivoting produces more
/// fill than any earlier factorization did (never for a pivot sequence seen before). Solves never
/// allocate. The simplicial kernels are used on purpose: faer's supernodal numeric factorization
/// allocates its fronts on every call.
///
/// **Singularity.** faer reports structural singularity; numerical singularity is detected here
/// from `U`'s pivots (`|u_jj| ≤ k ε max |u_ii|`, as for the dense solvers) and reported with the
/// column of the original matrix, so a redundant constraint is named.
///
/// References: Gilbert & Peierls, SIAM J. Sci. Stat. Comput. 9 (1988); Davis et al., ACM TOMS 30
/// (2004) (COLAMD); Davis, *Direct Methods for Sparse Linear Systems*, SIAM 2006, ch. 6.
pub struct SparseLu<T: Real + faer::traits::RealField> {
    k: usize,
    /// The recorded assembly sequence (positions).
    seq: Vec<(usize, usize)>,
    /// During recording: the values in sequence order.
    rec_values: Vec<T>,
    /// Sequence position → index into `values` (compressed-column order).
    slot: Vec<usize>,
    cursor: usize,
    /// First assembly mismatch: (entry, expected, got).
    mismatch: Option<LinearSolveError>,
    /// This assembly added an entry of the pattern out of the recorded order (found by
    /// search): its count is not checked against the recording.
    unordered: bool,
    /// Compressed-column pattern, after the first factorization.
    pattern: Option<SymbolicSparseColMat<usize>>,
    values: Vec<T>,
    symbolic: Option<SymbolicLu<usize>>,
    lu: SimplicialLu<usize, T>,
    row_perm: Vec<usize>,
    row_perm_inv: Vec<usize>,
    mem: MemBuffer,
    factored: bool,
}

impl<T: Real + faer::traits::RealField> SparseLu<T> {
    /// The number of stored entries after the pattern is fixed (`None` while recording).
    pub fn nnz(&self) -> Option<usize> {
        self.pattern.as_ref().map(|_| self.values.len())
    }

    /// Forgets the recorded pattern: the next assembly records a new one (and the next
    /// factorization repeats the symbolic analysis, which allocates).
    pub fn reset_pattern(&mut self) {
        self.seq.clear();
        self.rec_values.clear();
        self.slot.clear();
        self.cursor = 0;
        self.mismatch = None;
        self.pattern = None;
        self.values.clear();
        self.symbolic = None;
        self.factored = false;
    }

    /// The index into `values` of the pattern's entry `(row, col)`, if it has one.
    fn find(&self, row: usize, col: usize) -> Option<usize> {
        let pattern = self.pattern.as_ref()?;
        let (col_ptr, row_idx) = (pattern.col_ptr(), pattern.row_idx());
        let range = *col_ptr.get(col)?..*col_ptr.get(col + 1)?;
        let rows = &row_idx[range.clone()];
        rows.binary_search(&row).ok().map(|i| range.start + i)
    }

    /// Fixes the pattern from the recorded sequence: sorted, duplicate-free compressed columns,
    /// the slot of every sequence entry, the symbolic analysis and the scratch memory.
    fn finalize_pattern(&mut self) -> Result<(), LinearSolveError> {
        let k = self.k;
        if let Some(&(row, col)) = self.seq.iter().find(|&&(r, c)| r >= k || c >= k) {
            return Err(LinearSolveError::OutOfBounds { row, col, dim: k });
        }
        let mut order: Vec<usize> = (0..self.seq.len()).collect();
        order.sort_unstable_by_key(|&e| (self.seq[e].1, self.seq[e].0));
        let mut col_ptr = vec![0usize; k + 1];
        let mut row_idx = Vec::with_capacity(self.seq.len());
        self.slot = vec![0; self.seq.len()];
        let mut last = None;
        for &e in &order {
            let (r, c) = self.seq[e];
            if last != Some((r, c)) {
                row_idx.push(r);
                col_ptr[c + 1] += 1;
                last = Some((r, c));
            }
            self.slot[e] = row_idx.len() - 1;
        }
        for c in 0..k {
            col_ptr[c + 1] += col_ptr[c];
        }
        let nnz = row_idx.len();
        let pattern = SymbolicSparseColMat::new_checked(k, k, col_ptr, None, row_idx);
        let symbolic = factorize_symbolic_lu(
            pattern.as_ref(),
            LuSymbolicParams {
                supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SIMPLICIAL,
                ..Default::default()
            },
        )
        .map_err(|_| LinearSolveError::Backend {
            what: "symbolic LU analysis (out of memory or index overflow)",
        })?;
        let req = StackReq::any_of(&[
            simplicial::factorize_simplicial_numeric_lu_scratch::<usize, T>(k, k),
            simplicial::solve_in_place_scratch::<usize, T>(k, 1, Par::Seq),
        ]);
        self.mem = MemBuffer::try_new(req).map_err(|_| LinearSolveError::Backend {
            what: "LU scratch memory",
        })?;
        self.values = vec![T::zero(); nnz];
        for (e, &v) in self.rec_values.iter().enumerate() {
            let s = self.slot[e];
            self.values[s] += v;
        }
        self.rec_values = Vec::new();
        self.row_perm = vec![0; k];
        self.row_perm_inv = vec![0; k];
        self.pattern = Some(pattern);
        self.symbolic = Some(symbolic);
        self.cursor = self.seq.len();
        Ok(())
    }
}

impl<T: Real + faer::traits::RealField> Sink<T> for SparseLu<T> {
    #[inline]
    fn add(&mut self, row: usize, col: usize, value: T) {
        if self.pattern.is_none() {
            self.seq.push((row, col));
            self.rec_values.push(value);
            return;
        }
        let e = self.cursor;
        self.cursor += 1;
        match self.seq.get(e) {
            Some(&rc) if rc == (row, col) => {
                let s = self.slot[e];
                self.values[s] += value;
            }
            // Another order of the same pattern (a Jacobian summed by its problem one time,
            // grouped by colours another): the entry found by search in its column.
            expected => {
                if let Some(s) = self.find(row, col) {
                    self.values[s] += value;
                    self.unordered = true;
                    return;
                }
                debug_assert!(
                    false,
                    "sparse assembly changed its pattern at entry {e}: expected {expected:?}, got {:?}",
                    (row, col)
                );
                if self.mismatch.is_none() {
                    self.mismatch = Some(LinearSolveError::PatternChanged {
                        entry: e,
                        expected: expected.copied(),
                        got: Some((row, col)),
                    });
                }
            }
        }
    }
}

impl<T: Real + faer::traits::RealField> LinearSolver<T> for SparseLu<T> {
    fn with_dim(k: usize) -> Result<Self, LinearSolveError> {
        Ok(Self {
            k,
            seq: Vec::new(),
            rec_values: Vec::new(),
            slot: Vec::new(),
            cursor: 0,
            mismatch: None,
            unordered: false,
            pattern: None,
            values: Vec::new(),
            symbolic: None,
            lu: SimplicialLu::new(),
            row_perm: Vec::new(),
            row_perm_inv: Vec::new(),
            mem: MemBuffer::new(StackReq::EMPTY),
            factored: false,
        })
    }

    fn dim(&self) -> usize {
        self.k
    }

    fn column_mut(&mut self, _j: usize) -> Option<&mut [T]> {
        None
    }

    fn clear(&mut self) {
        self.factored = false;
        self.mismatch = None;
        self.unordered = false;
        if self.pattern.is_none() {
            self.seq.clear();
            self.rec_values.clear();
        } else {
            self.cursor = 0;
            self.values.iter_mut().for_each(|v| *v = T::zero());
        }
    }

    fn kind(&self) -> SolverKind {
        SolverKind::Sparse
    }

    fn factor(&mut self) -> Result<(), LinearSolveError> {
        self.factored = false;
        if let Some(e) = self.mismatch.take() {
            return Err(e);
        }
        if self.pattern.is_none() {
            self.finalize_pattern()?;
        } else if self.cursor != self.seq.len() && !self.unordered {
            return Err(LinearSolveError::PatternChanged {
                entry: self.cursor,
                expected: self.seq.get(self.cursor).copied(),
                got: None,
            });
        }
        let k = self.k;
        let (Some(pattern), Some(symbolic)) = (&self.pattern, &self.symbolic) else {
            unreachable!("the pattern is fixed above");
        };
        if let Some(s) = self.values.iter().position(|v| !v.is_finite()) {
            let (col_ptr, row_idx) = (pattern.col_ptr(), pattern.row_idx());
            let col = col_ptr.partition_point(|&p| p <= s) - 1;
            return Err(LinearSolveError::NonFinite {
                row: row_idx[s],
                col,
            });
        }
        let a = SparseColMatRef::new(pattern.as_ref(), &self.values);
        simplicial::factorize_simplicial_numeric_lu(
            &mut self.row_perm,
            &mut self.row_perm_inv,
            &mut self.lu,
            a,
            symbolic.col_perm(),
            MemStack::new(&mut self.mem),
        )
        .map_err(|e| match e {
            LuError::SymbolicSingular { index } => LinearSolveError::StructurallySingular {
                column: symbolic.col_perm().arrays().0[index.min(k.saturating_sub(1))],
            },
            LuError::Generic(_) => LinearSolveError::Backend {
                what: "numeric LU (out of memory or index overflow)",
            },
        })?;
        let u = self.lu.u_factor_unsorted();
        // U's pivot is the last entry of each (permuted) column, formed from the others.
        let terms = (0..k).map(|j| u.val_of_col(j).len()).max().unwrap_or(1);
        check_pivots_of(k, terms, |j| {
            u.val_of_col(j).last().copied().unwrap_or(T::zero())
        })
        .map_err(|e| e.renumbered(|j| symbolic.col_perm().arrays().0[j]))?;
        self.factored = true;
        Ok(())
    }

    fn solve_in_place(&mut self, rhs: &mut [T]) -> Result<(), LinearSolveError> {
        let k = self.k;
        let (true, Some(symbolic)) = (self.factored, &self.symbolic) else {
            return Err(LinearSolveError::NotFactored);
        };
        let row_perm = PermRef::new_checked(&self.row_perm, &self.row_perm_inv, k);
        let b = MatMut::from_column_major_slice_mut(&mut rhs[..k], k, 1);
        self.lu.solve_in_place_with_conj(
            row_perm,
            symbolic.col_perm(),
            Conj::No,
            b,
            Par::Seq,
            MemStack::new(&mut self.mem),
        );
        Ok(())
    }
}

impl<T: Real + faer::traits::RealField> core::fmt::Debug for SparseLu<T> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("SparseLu")
            .field("dim", &self.k)
            .field("nnz", &self.nnz())
            .field("factored", &self.factored)
            .finish_non_exhaustive()
    }
}
