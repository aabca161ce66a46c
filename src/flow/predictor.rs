//! The predictor of an implicit step from its past solutions: extrapolation by backward
//! differences, of the degree that predicted the last step best.
//!
//! For consecutive steps of one size `h`, the solution `z_n` of a step (stage increments and
//! multipliers) is a smooth function of `t_n`, and Newton's backward-difference formula
//! extrapolates it to the next step,
//!
//! ```text
//! z_{n+1} ≈ P_p = Σ_{j<p} ∇ʲ z_n,     z_{n+1} − P_p = ∇ᵖ z_{n+1} = hᵖ z⁽ᵖ⁾ + O(hᵖ⁺¹)
//! ```
//!
//! (`∇z_n = z_n − z_{n−1}`; Hairer, Nørsett & Wanner, *Solving ODEs I*, §III.1). The error of
//! every degree is thus known exactly once the next step is solved — the `p`-th backward
//! difference of the new solution — and each step extrapolates with the `p ≤` [`MAX_POINTS`]
//! whose difference was smallest (in the max-norm, as the solve judges its rows) at the last
//! one. High degrees where the solution is smooth at the scale `h`; low ones where it oscillates at a frequency the steps resolve poorly: the
//! differences of `e^{iωt}` scale as `|2 sin(ωh/2)|ᵖ`, which grows with `p` beyond
//! `ωh = π/3`, and noise as `2ᵖ` (a rounding floor of `2ᵖ ε |z|`).
//!
//! On the damped shell of ten particles (`h = 0.01`, Petrov–Galerkin of order 4) the fixed
//! quadratic started the stages at a residual of `2e-8` (median over 500 steps), 2.15 Schur
//! iterations a step; six points start them at `6e-13` (measured with the degree fixed at
//! five), and the degree chosen here takes 1.02 iterations
//! (docs/method.md §11).

use crate::real::Real;
use crate::vector::ops;

/// The most past solutions an extrapolation uses (degree `MAX_POINTS − 1`).
pub(crate) const MAX_POINTS: usize = 6;

/// The backward differences `∇ʲ z_n`, `j < count`, of the last consecutive solutions, and the
/// number of them the next prediction uses.
#[derive(Debug, Clone)]
pub(crate) struct Predictor<T> {
    /// `∇ʲ z_n` at `j len ..(j + 1) len`: a prediction and a record are passes over whole
    /// differences, each a contiguous loop over the entries (which the compiler vectorizes;
    /// with the differences of an entry side by side, each entry was a serial chain).
    diffs: Vec<T>,
    /// `∇ʲ⁺¹ z_{n+1}` while a record climbs the orders.
    next: Vec<T>,
    /// How many differences are valid (the solutions recorded since the last `forget`, at most
    /// [`MAX_POINTS`]).
    count: usize,
    /// The number of points `p` of the next prediction: that of the degree whose last error was
    /// smallest, or one more while the errors still fall with the degree (`record`).
    points: usize,
}

impl<T: Real> Predictor<T> {
    /// A predictor of solutions of length `len` (allocated here, not per step).
    pub(crate) fn new(len: usize) -> Self {
        Self {
            diffs: vec![T::zero(); len * MAX_POINTS],
            next: vec![T::zero(); len],
            count: 0,
            points: 0,
        }
    }

    /// Forgets the past solutions (a new step size, a step that does not continue the last).
    pub(crate) fn forget(&mut self) {
        self.count = 0;
        self.points = 0;
    }

    /// `z = Σ_{j<p} ∇ʲ z_n` with `p` the chosen number of points; nothing without past solutions.
    pub(crate) fn predict(&self, z: &mut [T]) {
        let (p, len) = (self.points, self.next.len());
        if p == 0 || len == 0 {
            return;
        }
        z.copy_from_slice(&self.diffs[..len]);
        for d in self.diffs[len..p * len].chunks_exact(len) {
            ops::axpy(z, T::one(), d);
        }
    }

    /// Records the solution `z_{n+1}` of the step after the last recorded one: updates the
    /// differences and picks the degree whose error `‖∇ᵖ z_{n+1}‖_∞` was smallest (the lower
    /// one on a tie): the largest entry's, as the solve's stop is judged by its largest row.
    /// While the solutions are fewer than [`MAX_POINTS`] and the errors still fall with the
    /// degree, the next prediction goes one degree higher, through all of them (the linear
    /// extrapolation after two, the quadratic after three, as far as they keep improving);
    /// after the first, there is none (the caller's own start stands).
    pub(crate) fn record(&mut self, z: &[T]) {
        let (c, len) = (self.count, self.next.len());
        if len == 0 {
            return;
        }
        // `max_e |(∇ᵖ z_{n+1})_e|`, NaN if any entry is (`max` would drop it).
        let mut err = [T::zero(); MAX_POINTS + 1];
        self.next.copy_from_slice(z);
        for (j, d) in self.diffs[..c * len].chunks_exact_mut(len).enumerate() {
            // `new = ∇ʲ z_{n+1}` replaces `∇ʲ z_n`, and `∇ʲ⁺¹ z_{n+1} = ∇ʲ z_{n+1} − ∇ʲ z_n`.
            for (old, new) in d.iter_mut().zip(&mut self.next) {
                let o = *old;
                *old = *new;
                *new = *new - o;
            }
            err[j + 1] = ops::norm_inf(&self.next);
        }
        if c < MAX_POINTS {
            self.diffs[c * len..(c + 1) * len].copy_from_slice(&self.next);
        }
        // A non-finite error (an overflowed difference) is never smaller; the lowest degree
        // extrapolates with the last solution alone.
        let mut best = 1;
        for p in 2..=c {
            if err[p] < err[best] {
                best = p;
            }
        }
        self.count = (c + 1).min(MAX_POINTS);
        self.points = if c == 0 {
            0
        } else if best == c && err[c].is_finite() {
            (c + 1).min(MAX_POINTS)
        } else {
            best
        };
    }
}

#[cfg(test)]
#[path = "predictor_tests.rs"]
mod tests;
