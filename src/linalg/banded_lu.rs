use super::{LinearSolver, Sink, SolverChoice, SolverKind, Structure, check_pivots};
use crate::error::LinearSolveError;
use crate::real::Real;

/// LU with partial pivoting of a band matrix (`lower` sub- and `upper` superdiagonals), in
/// LAPACK's band storage: the unblocked `gbtf2`/`gbtrs` algorithms (Anderson et al.,
/// *LAPACK Users' Guide*, 3rd ed., SIAM 1999, §5.3.2; Golub & Van Loan, *Matrix Computations*,
/// 4th ed., §4.3).
///
/// Row interchanges widen `U` to `lower + upper` superdiagonals, so the storage holds
/// `2·lower + upper + 1` entries per column; factorization costs `O(k · lower · (lower + upper))`
/// flops and a solve `O(k · (2·lower + upper))`, with no symbolic phase, no fill beyond the band
/// and no allocation after construction. For a tridiagonal matrix (`lower = upper = 1`: the
/// multiplier systems of a pendulum chain) that is a few flops per row — the Thomas algorithm
/// with pivoting.
///
/// **Assembly** through [`Sink::add`] after [`clear`](LinearSolver::clear); duplicates are
/// summed. An entry outside the band is reported by the next [`factor`](LinearSolver::factor)
/// as [`LinearSolveError::PatternIncomplete`] (and one outside the matrix as
/// [`LinearSolveError::OutOfBounds`]); nothing is silently dropped.
///
/// **Singularity**: a zero pivot column, or a pivot of `U` at most `k ε` times the largest,
/// is [`LinearSolveError::Singular`] naming it, as for the other backends.
#[derive(Debug, Clone)]
pub struct BandedLu<T> {
    k: usize,
    lower: usize,
    upper: usize,
    /// Column-major band storage: entry `(r, c)` at `ab[c * ld + kv + r − c]`, `kv = lower +
    /// upper`, `ld = 2·lower + upper + 1`.
    ab: Vec<T>,
    ipiv: Vec<usize>,
    /// `1 / u_jj`: the back substitution multiplies by it, which takes a division (about
    /// 13–20 cycles of latency against 4 for a multiplication) off its chain of dependent
    /// rows — on a tridiagonal system the division is most of that chain.
    inv_pivot: Vec<T>,
    /// The first entry added outside the band or the matrix, reported by `factor`.
    bad: Option<LinearSolveError>,
    factored: bool,
}

impl<T: Real> BandedLu<T> {
    /// A `k × k` solver for a band of `lower` sub- and `upper` superdiagonals.
    pub fn new(k: usize, lower: usize, upper: usize) -> Self {
        let (lower, upper) = (
            lower.min(k.saturating_sub(1)),
            upper.min(k.saturating_sub(1)),
        );
        let ld = 2 * lower + upper + 1;
        Self {
            k,
            lower,
            upper,
            ab: vec![T::zero(); ld * k],
            ipiv: vec![0; k],
            inv_pivot: vec![T::zero(); k],
            bad: None,
            factored: false,
        }
    }

    /// The number of sub- and superdiagonals.
    pub fn bandwidth(&self) -> (usize, usize) {
        (self.lower, self.upper)
    }

    #[inline(always)]
    fn ld(&self) -> usize {
        2 * self.lower + self.upper + 1
    }

    /// The solve of a factored tridiagonal matrix (`lower = upper = 1`, `k ≥ 2`): the same
    /// operations in the same order as the general loops (the same result to the bit), with the
    /// row just computed carried in a register instead of stored and loaded again, which took a
    /// store-to-load forwarding off the chain of dependent rows in both sweeps.
    fn solve_tridiagonal(&self, b: &mut [T]) {
        // ld = 4, kv = 2: L's multiplier of row j at ab[4j + 3], U[j, j+1] at ab[4(j+1) + 1],
        // U[j, j+2] (the fill of an interchange) at ab[4(j+2)].
        let k = b.len();
        let ab = &self.ab;
        let mut cur = b[0];
        for j in 0..k - 1 {
            let mut next = b[j + 1];
            if self.ipiv[j] != j {
                core::mem::swap(&mut cur, &mut next);
            }
            b[j] = cur;
            cur = next - ab[4 * j + 3] * cur;
        }
        b[k - 1] = cur;
        let (mut x1, mut x2) = (T::zero(), T::zero());
        for j in (0..k).rev() {
            let mut s = b[j];
            if j + 2 < k {
                s = s - ab[4 * (j + 2)] * x2;
            }
            if j + 1 < k {
                s = s - ab[4 * (j + 1) + 1] * x1;
            }
            let x = s * self.inv_pivot[j];
            b[j] = x;
            x2 = x1;
            x1 = x;
        }
    }
}

impl<T: Real> Sink<T> for BandedLu<T> {
    #[inline]
    fn add(&mut self, row: usize, col: usize, value: T) {
        if row >= self.k || col >= self.k {
            self.bad.get_or_insert(LinearSolveError::OutOfBounds {
                row,
                col,
                dim: self.k,
            });
            return;
        }
        if row > col + self.lower || col > row + self.upper {
            self.bad
                .get_or_insert(LinearSolveError::PatternIncomplete { row, column: col });
            return;
        }
        let kv = self.lower + self.upper;
        let i = col * self.ld() + kv + row - col;
        self.ab[i] = self.ab[i] + value;
        self.factored = false;
    }
}

impl<T: Real> LinearSolver<T> for BandedLu<T> {
    /// Without a structure: the full band (`k − 1` diagonals each side), correct but dense.
    fn with_dim(k: usize) -> Result<Self, LinearSolveError> {
        Ok(Self::new(k, k.saturating_sub(1), k.saturating_sub(1)))
    }

    fn with_structure(
        k: usize,
        structure: Structure,
        _choice: SolverChoice,
    ) -> Result<Self, LinearSolveError> {
        Ok(match structure {
            Structure::Banded { lower, upper, .. } => Self::new(k, lower, upper),
            _ => Self::new(k, k.saturating_sub(1), k.saturating_sub(1)),
        })
    }

    fn dim(&self) -> usize {
        self.k
    }

    fn column_mut(&mut self, _j: usize) -> Option<&mut [T]> {
        None
    }

    fn clear(&mut self) {
        self.ab.iter_mut().for_each(|v| *v = T::zero());
        self.bad = None;
        self.factored = false;
    }

    fn kind(&self) -> SolverKind {
        SolverKind::Banded
    }

    /// `P A = L U` in place (LAPACK `gbtf2`).
    fn factor(&mut self) -> Result<(), LinearSolveError> {
        self.factored = false;
        if let Some(e) = self.bad.take() {
            return Err(e);
        }
        let (k, kl) = (self.k, self.lower);
        let kv = kl + self.upper;
        let ld = self.ld();
        if let Some(i) = crate::vector::ops::first_non_finite(&self.ab) {
            let (c, r) = (i / ld, i % ld);
            return Err(LinearSolveError::NonFinite {
                row: (c + r).saturating_sub(kv),
                col: c,
            });
        }
        let ab = &mut self.ab;
        // The last column that the eliminations so far have reached.
        let mut ju = 0;
        for j in 0..k {
            let km = kl.min(k - 1 - j);
            let col = j * ld + kv;
            let mut jp = 0;
            let mut best = ab[col].abs();
            for i in 1..=km {
                let v = ab[col + i].abs();
                if v > best {
                    best = v;
                    jp = i;
                }
            }
            self.ipiv[j] = j + jp;
            if best == T::zero() {
                return Err(LinearSolveError::Singular {
                    pivot: j,
                    magnitude: 0.0,
                    ratio: 0.0,
                });
            }
            ju = ju.max((j + self.upper + jp).min(k - 1));
            if jp != 0 {
                // Swap rows j and j + jp in columns j..=ju.
                for c in j..=ju {
                    let base = c * ld + kv + j - c;
                    ab.swap(base, base + jp);
                }
            }
            // The pivot is final: its reciprocal scales the column and is kept for the solves.
            let inv = T::one() / ab[col];
            self.inv_pivot[j] = inv;
            if km > 0 {
                for i in 1..=km {
                    ab[col + i] = ab[col + i] * inv;
                }
                for c in j + 1..=ju {
                    let base = c * ld + kv + j - c;
                    let u = ab[base];
                    if u != T::zero() {
                        for i in 1..=km {
                            ab[base + i] = ab[base + i] - ab[col + i] * u;
                        }
                    }
                }
            }
        }
        check_pivots(k, |j| self.ab[j * ld + kv])?;
        self.factored = true;
        Ok(())
    }

    /// `x = U⁻¹ L⁻¹ P b` in place (LAPACK `gbtrs`, no transpose; multiplying by the stored
    /// reciprocals of the pivots where `gbtrs` divides).
    fn solve_in_place(&mut self, b: &mut [T]) -> Result<(), LinearSolveError> {
        if !self.factored {
            return Err(LinearSolveError::NotFactored);
        }
        let (k, kl) = (self.k, self.lower);
        let b = &mut b[..k];
        if kl == 1 && self.upper == 1 {
            self.solve_tridiagonal(b);
            return Ok(());
        }
        let kv = kl + self.upper;
        let ld = self.ld();
        for j in 0..k.saturating_sub(1) {
            let km = kl.min(k - 1 - j);
            let l = self.ipiv[j];
            if l != j {
                b.swap(l, j);
            }
            let bj = b[j];
            let col = j * ld + kv;
            for i in 1..=km {
                b[j + i] = b[j + i] - self.ab[col + i] * bj;
            }
        }
        for j in (0..k).rev() {
            let col = j * ld + kv;
            let t = b[j] * self.inv_pivot[j];
            b[j] = t;
            for i in 1..=kv.min(j) {
                b[j - i] = b[j - i] - self.ab[col - i] * t;
            }
        }
        Ok(())
    }
}
