use super::{LinearSolver, Sink, SolverKind, check_finite, check_pivots};
use crate::error::LinearSolveError;
use crate::real::Real;
use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::lu::partial_pivoting::{factor, solve};
use faer::{Mat, MatMut, Par};

/// faer's dense LU with partial pivoting, through the low-level in-place kernels.
///
/// The matrix, its factors, the permutation and the scratch memory are allocated once in
/// [`with_dim`](LinearSolver::with_dim); `factor` and `solve_in_place` allocate nothing
/// (faer's convenient `partial_piv_lu()` would allocate on every call). Sequential (`Par::Seq`):
/// multiplier systems are small enough that threading costs more than it gains.
pub struct DenseLu<T: Real + faer::traits::RealField> {
    a: Mat<T>,
    lu: Mat<T>,
    perm: Vec<usize>,
    perm_inv: Vec<usize>,
    /// The permuted right-hand side of the direct substitutions.
    work: Vec<T>,
    /// `1 / U_jj` (the direct back substitution multiplies: a division's latency would sit on
    /// its critical path once per column).
    inv_pivots: Vec<T>,
    mem: MemBuffer,
    factored: bool,
    /// The first entry added outside the matrix since the last `clear` (reported by `factor`).
    out_of_bounds: Option<(usize, usize)>,
}

impl<T: Real + faer::traits::RealField> LinearSolver<T> for DenseLu<T> {
    fn with_dim(k: usize) -> Result<Self, LinearSolveError> {
        let req = StackReq::any_of(&[
            factor::lu_in_place_scratch::<usize, T>(k, k, Par::Seq, Default::default()),
            solve::solve_in_place_scratch::<usize, T>(k, 1, Par::Seq),
        ]);
        Ok(Self {
            a: Mat::zeros(k, k),
            lu: Mat::zeros(k, k),
            perm: vec![0; k],
            perm_inv: vec![0; k],
            work: vec![T::zero(); k],
            inv_pivots: vec![T::zero(); k],
            out_of_bounds: None,
            mem: MemBuffer::new(req),
            factored: false,
        })
    }

    fn dim(&self) -> usize {
        self.a.nrows()
    }

    #[inline]
    fn column_mut(&mut self, j: usize) -> Option<&mut [T]> {
        (j < self.a.ncols()).then(|| self.a.col_as_slice_mut(j))
    }

    fn clear(&mut self) {
        self.factored = false;
        self.out_of_bounds = None;
        self.a.fill(T::zero());
    }

    fn kind(&self) -> SolverKind {
        SolverKind::Dense
    }

    fn factor(&mut self) -> Result<(), LinearSolveError> {
        let k = self.dim();
        self.factored = false;
        if let Some((row, col)) = self.out_of_bounds {
            return Err(LinearSolveError::OutOfBounds { row, col, dim: k });
        }
        if let Some((row, col)) = check_finite(k, |idx| self.a[(idx % k, idx / k)]) {
            return Err(LinearSolveError::NonFinite { row, col });
        }
        self.lu.copy_from(&self.a);
        let stack = MemStack::new(&mut self.mem);
        factor::lu_in_place(
            self.lu.as_mut(),
            &mut self.perm,
            &mut self.perm_inv,
            Par::Seq,
            stack,
            Default::default(),
        );
        check_pivots(k, |i| self.lu[(i, i)])?;
        for (j, inv) in self.inv_pivots.iter_mut().enumerate() {
            *inv = T::one() / self.lu[(j, j)];
        }
        self.factored = true;
        Ok(())
    }

    fn solve_in_place(&mut self, rhs: &mut [T]) -> Result<(), LinearSolveError> {
        let k = self.dim();
        if !self.factored {
            return Err(LinearSolveError::NotFactored);
        }
        if k <= DIRECT_MAX {
            self.substitute(&mut rhs[..k]);
            return Ok(());
        }
        let perm = faer::perm::PermRef::new_checked(&self.perm, &self.perm_inv, k);
        let b = MatMut::from_column_major_slice_mut(&mut rhs[..k], k, 1);
        let stack = MemStack::new(&mut self.mem);
        solve::solve_in_place(self.lu.as_ref(), self.lu.as_ref(), perm, b, Par::Seq, stack);
        Ok(())
    }
}

/// Up to this dimension a solve runs the two substitutions as plain column loops: faer's
/// blocked, recursive kernels pay off for large matrices and cost several times the
/// arithmetic for small ones (a 40 × 40 solve is 1,600 multiply-adds).
const DIRECT_MAX: usize = 96;

impl<T: Real + faer::traits::RealField> DenseLu<T> {
    /// `x = U⁻¹ L⁻¹ P b` in place, `(P b)ᵢ = b_{perm[i]}`, `L` unit lower and `U` upper
    /// triangular in `lu` (column-major: each inner loop runs down a column).
    fn substitute(&mut self, rhs: &mut [T]) {
        let k = rhs.len();
        let y = &mut self.work[..k];
        for (yi, &p) in y.iter_mut().zip(&self.perm) {
            *yi = rhs[p];
        }
        for j in 0..k {
            let yj = y[j];
            if yj != T::zero() {
                let col = &self.lu.col_as_slice(j)[j + 1..k];
                for (yi, &l) in y[j + 1..].iter_mut().zip(col) {
                    *yi -= l * yj;
                }
            }
        }
        for j in (0..k).rev() {
            let col = &self.lu.col_as_slice(j)[..j];
            let yj = y[j] * self.inv_pivots[j];
            y[j] = yj;
            if yj != T::zero() {
                for (yi, &u) in y[..j].iter_mut().zip(col) {
                    *yi -= u * yj;
                }
            }
        }
        rhs.copy_from_slice(y);
    }
}

impl<T: Real + faer::traits::RealField> Sink<T> for DenseLu<T> {
    /// Adds to entry `(row, col)`. A position outside the matrix is not stored; the next
    /// `factor` reports it as [`LinearSolveError::OutOfBounds`].
    #[inline]
    fn add(&mut self, row: usize, col: usize, value: T) {
        let k = self.a.nrows();
        if row < k && col < k {
            let a = &mut self.a[(row, col)];
            *a += value;
        } else if self.out_of_bounds.is_none() {
            self.out_of_bounds = Some((row, col));
        }
    }
}

impl<T: Real + faer::traits::RealField> core::fmt::Debug for DenseLu<T> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("DenseLu")
            .field("dim", &self.a.nrows())
            .field("factored", &self.factored)
            .finish_non_exhaustive()
    }
}
