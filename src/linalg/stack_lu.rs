use super::{LinearSolver, Sink, SolverKind, check_pivots};
use crate::error::LinearSolveError;
use crate::real::Real;
use nalgebra::SMatrix;

/// LU with partial pivoting of the leading `k × k` block of a stack matrix of capacity `N × N`.
///
/// For tiny multiplier systems (one or a few constraints) the cost that matters is overhead,
/// not flops: nalgebra's `LU` factors the whole fixed-size `N × N` matrix and copies it, so this
/// solver runs the same Doolittle elimination (Golub & Van
/// Loan, *Matrix Computations*, Alg. 3.4.1) on the `k × k` block only, in place, on nalgebra stack
/// storage. No allocation ever. `k ≤ N` is checked at construction.
#[derive(Debug, Clone)]
pub struct StackLu<T: Real + nalgebra::Scalar, const N: usize> {
    k: usize,
    a: SMatrix<T, N, N>,
    lu: SMatrix<T, N, N>,
    piv: [usize; N],
    /// The reciprocals of `U`'s diagonal: the back substitution multiplies (its divisions were
    /// a chain of dependent latencies on every solve).
    inv_diag: [T; N],
    factored: bool,
    /// The first entry added outside the matrix since the last `clear` (reported by `factor`).
    out_of_bounds: Option<(usize, usize)>,
}

impl<T: Real + nalgebra::Scalar, const N: usize> LinearSolver<T> for StackLu<T, N> {
    fn with_dim(k: usize) -> Result<Self, LinearSolveError> {
        if k > N {
            return Err(LinearSolveError::TooLarge {
                requested: k,
                capacity: N,
            });
        }
        Ok(Self {
            k,
            a: SMatrix::from_element(T::zero()),
            lu: SMatrix::from_element(T::zero()),
            piv: [0; N],
            inv_diag: [T::zero(); N],
            out_of_bounds: None,
            factored: false,
        })
    }

    #[inline]
    fn dim(&self) -> usize {
        self.k
    }

    #[inline]
    fn column_mut(&mut self, j: usize) -> Option<&mut [T]> {
        if j < self.k {
            Some(&mut self.a.as_mut_slice()[j * N..j * N + self.k])
        } else {
            None
        }
    }

    fn clear(&mut self) {
        self.factored = false;
        self.out_of_bounds = None;
        // The k × k block only: entries outside it are never written (`add` refuses them).
        let k = self.k;
        for col in self.a.as_mut_slice().chunks_exact_mut(N).take(k) {
            col[..k].iter_mut().for_each(|v| *v = T::zero());
        }
    }

    fn kind(&self) -> SolverKind {
        SolverKind::Stack
    }

    fn factor(&mut self) -> Result<(), LinearSolveError> {
        let k = self.k;
        self.factored = false;
        if let Some((row, col)) = self.out_of_bounds {
            return Err(LinearSolveError::OutOfBounds { row, col, dim: k });
        }
        // Copy the k × k block only, checking finiteness on the way.
        for j in 0..k {
            for i in 0..k {
                let v = self.a[(i, j)];
                if !v.is_finite() {
                    return Err(LinearSolveError::NonFinite { row: i, col: j });
                }
                self.lu[(i, j)] = v;
            }
        }
        // A constant order per arm: the small systems' loops unroll and index without bounds
        // checks (the multiplier systems of a body or two: six to twelve rows).
        let (a, piv) = (self.lu.as_mut_slice(), &mut self.piv);
        match k {
            1 => eliminate::<T, N>(a, piv, 1),
            2 => eliminate::<T, N>(a, piv, 2),
            3 => eliminate::<T, N>(a, piv, 3),
            4 => eliminate::<T, N>(a, piv, 4),
            5 => eliminate::<T, N>(a, piv, 5),
            6 => eliminate::<T, N>(a, piv, 6),
            7 => eliminate::<T, N>(a, piv, 7),
            8 => eliminate::<T, N>(a, piv, 8),
            9 => eliminate::<T, N>(a, piv, 9),
            _ => eliminate::<T, N>(a, piv, k),
        }
        check_pivots(k, |i| self.lu[(i, i)])?;
        for (i, inv) in self.inv_diag.iter_mut().enumerate().take(k) {
            *inv = T::one() / self.lu[(i, i)];
        }
        self.factored = true;
        Ok(())
    }

    #[inline]
    fn solve_in_place(&mut self, b: &mut [T]) -> Result<(), LinearSolveError> {
        if !self.factored {
            return Err(LinearSolveError::NotFactored);
        }
        let (lu, piv, inv, k) = (&self.lu, &self.piv, &self.inv_diag, self.k);
        // Loop bounds known at compile time (the whole matrix, or a small order): the
        // substitutions unroll and index without bounds checks.
        match k {
            _ if k == N && b.len() >= N => substitute::<T, N>(lu, piv, inv, &mut b[..N], N),
            1 if !b.is_empty() => substitute::<T, N>(lu, piv, inv, &mut b[..1], 1),
            2 if b.len() >= 2 => substitute::<T, N>(lu, piv, inv, &mut b[..2], 2),
            3 if b.len() >= 3 => substitute::<T, N>(lu, piv, inv, &mut b[..3], 3),
            4 if b.len() >= 4 => substitute::<T, N>(lu, piv, inv, &mut b[..4], 4),
            5 if b.len() >= 5 => substitute::<T, N>(lu, piv, inv, &mut b[..5], 5),
            6 if b.len() >= 6 => substitute::<T, N>(lu, piv, inv, &mut b[..6], 6),
            7 if b.len() >= 7 => substitute::<T, N>(lu, piv, inv, &mut b[..7], 7),
            8 if b.len() >= 8 => substitute::<T, N>(lu, piv, inv, &mut b[..8], 8),
            9 if b.len() >= 9 => substitute::<T, N>(lu, piv, inv, &mut b[..9], 9),
            _ => substitute::<T, N>(lu, piv, inv, b, k),
        }
        Ok(())
    }
}

/// Doolittle elimination with partial pivoting of the leading `k × k` block of the
/// column-major `N × N` storage `a`, in place: right-looking by columns, so that every inner
/// loop runs down a contiguous column. A zero pivot is left for the caller's check.
#[inline(always)]
fn eliminate<T: Real, const N: usize>(a: &mut [T], piv: &mut [usize; N], k: usize) {
    let a = &mut a[..N * N];
    for c in 0..k {
        let col = c * N;
        let mut p = c;
        let mut best = a[col + c].abs();
        for r in c + 1..k {
            let v = a[col + r].abs();
            if v > best {
                best = v;
                p = r;
            }
        }
        piv[c] = p;
        if p != c {
            for j in 0..k {
                a.swap(j * N + c, j * N + p);
            }
        }
        let d = a[col + c];
        if d == T::zero() {
            continue;
        }
        // Scaled by the reciprocal, as LAPACK's dgetf2 does where it cannot overflow.
        if d.abs() >= T::min_positive_value() {
            let inv = T::one() / d;
            for r in c + 1..k {
                a[col + r] = a[col + r] * inv;
            }
        } else {
            for r in c + 1..k {
                a[col + r] = a[col + r] / d;
            }
        }
        for j in c + 1..k {
            let (left, right) = a.split_at_mut(j * N);
            let multipliers = &left[col + c + 1..col + k];
            let f = right[c];
            for (x, &l) in right[c + 1..k].iter_mut().zip(multipliers) {
                *x = *x - l * f;
            }
        }
    }
}

/// Forward and back substitution with the `k × k` factors in `lu` (unit lower, upper) and the
/// row interchanges `piv`, in place on `b`.
#[inline(always)]
fn substitute<T: Real + nalgebra::Scalar, const N: usize>(
    lu: &SMatrix<T, N, N>,
    piv: &[usize; N],
    inv_diag: &[T; N],
    b: &mut [T],
    k: usize,
) {
    for (i, &p) in piv.iter().enumerate().take(k) {
        b.swap(i, p);
    }
    // By columns (contiguous in the column-major storage).
    let a = lu.as_slice();
    for j in 0..k {
        let bj = b[j];
        for (x, &l) in b[j + 1..k].iter_mut().zip(&a[j * N + j + 1..j * N + k]) {
            *x = *x - l * bj;
        }
    }
    for j in (0..k).rev() {
        let bj = b[j] * inv_diag[j];
        b[j] = bj;
        for (x, &u) in b[..j].iter_mut().zip(&a[j * N..j * N + j]) {
            *x = *x - u * bj;
        }
    }
}

impl<T: Real + nalgebra::Scalar, const N: usize> Sink<T> for StackLu<T, N> {
    /// Adds to entry `(row, col)`. A position outside the `k × k` block is not stored; the
    /// next `factor` reports it as [`LinearSolveError::OutOfBounds`].
    #[inline]
    fn add(&mut self, row: usize, col: usize, value: T) {
        let k = self.k;
        if row < k && col < k {
            let a = &mut self.a[(row, col)];
            *a = *a + value;
        } else if self.out_of_bounds.is_none() {
            self.out_of_bounds = Some((row, col));
        }
    }
    /// The `k × k` block in the stack storage (leading dimension `N`).
    #[inline]
    fn dense_columns(&mut self) -> Option<(&mut [T], usize, usize)> {
        Some((self.a.as_mut_slice(), N, self.k))
    }
}
