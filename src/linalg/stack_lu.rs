use super::{LinearSolver, check_pivots};
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
    factored: bool,
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
            factored: false,
        })
    }

    #[inline]
    fn dim(&self) -> usize {
        self.k
    }

    #[inline]
    fn column_mut(&mut self, j: usize) -> &mut [T] {
        assert!(
            j < self.k,
            "column {j} out of range for dimension {}",
            self.k
        );
        &mut self.a.as_mut_slice()[j * N..j * N + self.k]
    }

    fn factor(&mut self) -> Result<(), LinearSolveError> {
        let k = self.k;
        self.factored = false;
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
        let a = &mut self.lu;
        for c in 0..k {
            let mut p = c;
            let mut best = a[(c, c)].abs();
            for r in c + 1..k {
                let v = a[(r, c)].abs();
                if v > best {
                    best = v;
                    p = r;
                }
            }
            self.piv[c] = p;
            if p != c {
                for j in 0..k {
                    a.swap((c, j), (p, j));
                }
            }
            let d = a[(c, c)];
            if d == T::zero() {
                continue;
            }
            for r in c + 1..k {
                let f = a[(r, c)] / d;
                a[(r, c)] = f;
                for j in c + 1..k {
                    a[(r, j)] = a[(r, j)] - f * a[(c, j)];
                }
            }
        }
        check_pivots(k, |i| self.lu[(i, i)])?;
        self.factored = true;
        Ok(())
    }

    #[inline]
    fn solve_in_place(&mut self, b: &mut [T]) -> Result<(), LinearSolveError> {
        let k = self.k;
        if !self.factored {
            return Err(LinearSolveError::Singular {
                pivot: 0,
                magnitude: 0.0,
                ratio: 0.0,
            });
        }
        let a = &self.lu;
        for i in 0..k {
            b.swap(i, self.piv[i]);
        }
        for i in 0..k {
            let mut s = b[i];
            for j in 0..i {
                s = s - a[(i, j)] * b[j];
            }
            b[i] = s;
        }
        for i in (0..k).rev() {
            let mut s = b[i];
            for j in i + 1..k {
                s = s - a[(i, j)] * b[j];
            }
            b[i] = s / a[(i, i)];
        }
        Ok(())
    }
}
