//! State vectors: one API over stack storage (nalgebra `SVector`) and heap storage (faer `Col`).
//!
//! Everything the integrators do to a state goes through [`Vector::as_slice`] /
//! [`Vector::as_mut_slice`] and the slice kernels in this module, so both storages run the same
//! model arithmetic in the same order; only the LU kernels of the multiplier systems differ
//! (nalgebra-storage LU on the stack, faer's on the heap), so trajectories agree to round-off.

use crate::linalg::{AutoLu, LinearSolver, StackLu};
use crate::real::Real;
use core::fmt::Debug;

/// A state (or workspace) vector.
///
/// Implemented for `nalgebra::SVector<T, N>` (stack, fixed size, for small models) and
/// `faer::Col<T>` (heap, any size). Each storage names the dense linear solver used for its
/// multiplier systems: [`StackLu`] on the stack, [`AutoLu`](crate::linalg::AutoLu) on the heap
/// (stack, dense or sparse LU by size and sparsity).
pub trait Vector: Clone + Debug + Send + Sync + 'static {
    /// The scalar type.
    type Real: Real;
    /// The default dense solver for multiplier systems of states stored like this.
    type Solver: LinearSolver<Self::Real>;
    /// `true` when a clone is a plain copy without allocation (stack storage), so that hot
    /// loops may keep a working copy in registers. Default `false`.
    const CLONE_IS_COPY: bool = false;
    /// The most entries a vector of this type can hold: `N` for a fixed-size vector, unbounded
    /// (`usize::MAX`) for heap storage. Lets generic code skip compiling cases a fixed size
    /// rules out (see `Projected`'s small path).
    const MAX_LEN: usize = usize::MAX;

    /// A zero vector with at least `len` entries (fixed-size vectors have exactly `N`; they
    /// panic if `len > N`). Allocates for heap storage: call it at construction, never per step.
    fn zeros(len: usize) -> Self;
    /// Number of entries.
    fn len(&self) -> usize;
    /// `true` if the vector has no entries.
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// The entries, contiguous.
    fn as_slice(&self) -> &[Self::Real];
    /// The entries, contiguous and mutable.
    fn as_mut_slice(&mut self) -> &mut [Self::Real];
    /// A zero vector of the same length.
    fn zeros_like(&self) -> Self {
        Self::zeros(self.len())
    }
    /// Copies `other` into `self` (same length).
    #[inline]
    #[track_caller]
    fn copy_from(&mut self, other: &Self) {
        self.as_mut_slice().copy_from_slice(other.as_slice());
    }
}

/// Stack storage, for small models.
impl<T, const N: usize> Vector for nalgebra::SVector<T, N>
where
    T: Real + nalgebra::Scalar,
{
    type Real = T;
    type Solver = StackLu<T, N>;
    const CLONE_IS_COPY: bool = true;
    const MAX_LEN: usize = N;

    #[track_caller]
    fn zeros(len: usize) -> Self {
        assert!(
            len <= N,
            "a fixed vector of size {N} cannot hold {len} entries"
        );
        nalgebra::SVector::from_element(T::zero())
    }
    #[inline(always)]
    fn len(&self) -> usize {
        N
    }
    #[inline(always)]
    fn as_slice(&self) -> &[T] {
        nalgebra::Matrix::as_slice(self)
    }
    #[inline(always)]
    fn as_mut_slice(&mut self) -> &mut [T] {
        nalgebra::Matrix::as_mut_slice(self)
    }
}

impl<T> Vector for faer::Col<T>
where
    T: Real + faer::traits::RealField + nalgebra::Scalar,
{
    type Real = T;
    type Solver = AutoLu<T>;

    fn zeros(len: usize) -> Self {
        faer::Col::from_fn(len, |_| T::zero())
    }
    #[inline(always)]
    fn len(&self) -> usize {
        self.nrows()
    }
    #[inline(always)]
    fn as_slice(&self) -> &[T] {
        self.try_as_col_major()
            .expect("an owned faer column is contiguous")
            .as_slice()
    }
    #[inline(always)]
    fn as_mut_slice(&mut self) -> &mut [T] {
        self.try_as_col_major_mut()
            .expect("an owned faer column is contiguous")
            .as_slice_mut()
    }
}

/// Heap vectors for any [`Real`] scalar (extended precision included): nalgebra's `DVector`,
/// with the pure-Rust [`BandedLu`](crate::linalg::BandedLu) as its solver (a full band when
/// nothing narrower is known). For scalars faer does not support, e.g. double-double
/// reference runs of scenes; `faer::Col` is the fast heap storage for `f64`.
impl<T> Vector for nalgebra::DVector<T>
where
    T: Real + nalgebra::Scalar,
{
    type Real = T;
    type Solver = crate::linalg::BandedLu<T>;

    fn zeros(len: usize) -> Self {
        nalgebra::DVector::from_element(len, T::zero())
    }
    #[inline(always)]
    fn len(&self) -> usize {
        self.nrows()
    }
    #[inline(always)]
    fn as_slice(&self) -> &[T] {
        nalgebra::Matrix::as_slice(self)
    }
    #[inline(always)]
    fn as_mut_slice(&mut self) -> &mut [T] {
        nalgebra::Matrix::as_mut_slice(self)
    }
}

/// Makes `dst` hold the values of `src`, whose own values are no longer needed: a copy for
/// stack vectors (half the moves of a swap), a swap of the buffers otherwise (O(1) for heap
/// vectors, where a copy of `m = 10⁵` entries per step was measurable).
#[inline(always)]
pub(crate) fn take<V: Vector>(dst: &mut V, src: &mut V) {
    if V::CLONE_IS_COPY {
        dst.copy_from(src);
    } else {
        core::mem::swap(dst, src);
    }
}

/// Slice kernels shared by every storage.
pub mod ops {
    use crate::real::Real;

    /// `y += a x`.
    #[inline(always)]
    pub fn axpy<T: Real>(y: &mut [T], a: T, x: &[T]) {
        for (yi, &xi) in y.iter_mut().zip(x) {
            *yi = *yi + a * xi;
        }
    }

    /// `out = x + a v`.
    #[inline(always)]
    pub fn add_scaled<T: Real>(out: &mut [T], x: &[T], a: T, v: &[T]) {
        for ((oi, &xi), &vi) in out.iter_mut().zip(x).zip(v) {
            *oi = xi + a * vi;
        }
    }

    /// `x · y`.
    #[inline(always)]
    pub fn dot<T: Real>(x: &[T], y: &[T]) -> T {
        x.iter().zip(y).fold(T::zero(), |s, (&a, &b)| s + a * b)
    }

    /// `x ← x + d` with compensated (Kahan) summation: `c` carries the rounding error of the
    /// previous additions and receives this one's, so that a long sequence of small increments
    /// accumulates no more rounding error than one addition (Higham, *Accuracy and Stability of
    /// Numerical Algorithms*, 2nd ed., §4.3; GNI §VIII.5).
    #[inline]
    pub fn add_compensated<T: Real>(x: &mut [T], d: &[T], c: &mut [T]) {
        for ((xi, &di), ci) in x.iter_mut().zip(d).zip(c.iter_mut()) {
            let y = di + *ci;
            let t = *xi + y;
            *ci = (*xi - t) + y;
            *xi = t;
        }
    }

    /// Sets every entry to zero.
    #[inline(always)]
    pub fn fill_zero<T: Real>(x: &mut [T]) {
        x.iter_mut().for_each(|v| *v = T::zero());
    }

    /// Max-norm `max |x_i|` (0 for an empty slice; NaN propagates).
    #[inline(always)]
    pub fn norm_inf<T: Real>(x: &[T]) -> T {
        // A select and a flag rather than a branch on each entry: the loop has no
        // data-dependent jump (the norms of a step's residuals and updates are taken often).
        // Four running maxima, not one: one select chain through every entry waits on each
        // compare in turn; four independent ones overlap (and pair into vector registers).
        let mut m = [T::zero(); 4];
        let mut nan = [false; 4];
        let mut chunks = x.chunks_exact(4);
        for c in &mut chunks {
            for ((ml, nl), &v) in m.iter_mut().zip(&mut nan).zip(c) {
                let a = v.abs();
                *ml = if a > *ml { a } else { *ml };
                *nl |= a.is_nan();
            }
        }
        let (ml, nl) = (&mut m[0], &mut nan[0]);
        for &v in chunks.remainder() {
            let a = v.abs();
            *ml = if a > *ml { a } else { *ml };
            *nl |= a.is_nan();
        }
        if nan.iter().any(|&b| b) {
            return T::nan();
        }
        let (a, b) = (m[0].max(m[1]), m[2].max(m[3]));
        a.max(b)
    }

    /// Max-norm of `x − y`.
    #[inline]
    pub fn dist_inf<T: Real>(x: &[T], y: &[T]) -> T {
        let mut m = T::zero();
        for (&a, &b) in x.iter().zip(y) {
            let d = (a - b).abs();
            if d > m || d.is_nan() {
                m = d;
            }
        }
        m
    }

    /// Index of the first NaN or infinite entry.
    ///
    /// A pass without branches first — `v · 0` is `±0` for a finite `v` and NaN otherwise, so
    /// the sum of those products is zero exactly when every entry is finite; four independent
    /// sums, which the compiler keeps in vector registers — and the search for the index only
    /// when it fails: states are checked every step and are almost always finite.
    #[inline]
    pub fn first_non_finite<T: Real>(x: &[T]) -> Option<usize> {
        let zero = T::zero();
        let mut sums = [zero; 4];
        let mut chunks = x.chunks_exact(4);
        for c in &mut chunks {
            for (s, &v) in sums.iter_mut().zip(c) {
                *s = *s + v * zero;
            }
        }
        let mut total = (sums[0] + sums[1]) + (sums[2] + sums[3]);
        for &v in chunks.remainder() {
            total = total + v * zero;
        }
        if total == zero {
            None
        } else {
            x.iter().position(|v| !v.is_finite())
        }
    }

    /// `x == y` entry by entry as floats (`±0` alike, NaN never equal), without a branch per
    /// entry: an AND of the comparisons, which the compiler vectorizes.
    #[inline]
    pub fn equal<T: Real>(x: &[T], y: &[T]) -> bool {
        x.len() == y.len() && x.iter().zip(y).fold(true, |eq, (&a, &b)| eq & (a == b))
    }
}

#[cfg(test)]
#[path = "vector_tests.rs"]
mod tests;
