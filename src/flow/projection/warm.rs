//! Warm starts of the decoupled multiplier systems, double-buffered: a step reads the state of
//! the last successful step and writes the next one into separate buffers, which are swapped in
//! ([`WarmStart::commit`]) only when the step succeeds. A failed step leaves nothing to restore,
//! and no per-step copy of `m`-sized vectors is needed (at `m = 10⁵` those copies were a
//! measurable share of the step).
//!
//! The predictions (see [`Projected`](super::Projected)):
//! - `λ_k ≈ λ_{k+1}^{prev} + h · offset`, `offset = (λ_k − λ_{k+1}^{prev})/h` of the last step —
//!   `λ_k` and the previous `λ_{k+1}` approximate the force at the same time but differ by
//!   `O(h)`, kept per unit step so that it follows sub-steps of other sizes and signs;
//! - `λ_{k+1} ≈ S + s · S' − λ_k` with `S = λ_k + λ_{k+1}` of the last step, `S'` its change per
//!   unit step and `s = (h_prev + h)/2` the spacing of consecutive sums. `S` sets the step's total
//!   impulse and varies smoothly even when `λ_k` alone does not: when `g` cannot resolve part of
//!   `λ_k` at working precision (the smooth tension mode of a long chain at small `h`), `λ_k` is
//!   accepted wherever the warm start put it and `λ_{k+1}` compensates, so the two alternate
//!   from step to step while `S` stays smooth.
//!
//! When the `λ_{k+1}` system is affine and solved by one linear solve (the small path with a
//! quadratic `H` and a constant `M`), any start gives the same root: the solve starts from
//! zero — the closed form `λ_{k+1} = −J⁻¹ φ(y)` — and no prediction, sum or trend is kept.

use crate::real::Real;
use crate::vector::{Vector, take};
use num_traits::Zero;

/// The warm-start state of a decoupled projection (`m` multipliers each).
#[derive(Debug, Clone)]
pub(super) struct WarmStart<V: Vector> {
    /// `(λ_k, λ_{k+1})` of the last successful step.
    last: V,
    offset: V,
    sum: V,
    trend: V,
    offset_next: V,
    sum_next: V,
    trend_next: V,
    /// The last successful step size, and how many steps succeeded.
    last_h: V::Real,
    steps: u64,
    /// `λ_{k+1}` is solved exactly from any start (affine, one linear solve): no prediction.
    k1_exact: bool,
}

impl<V: Vector> WarmStart<V> {
    /// Zero multipliers and trends for `m` constraints; `k_z` entries for the multipliers.
    /// `k1_exact`: the `λ_{k+1}` system is solved exactly from any start (see the module
    /// documentation), so it is not predicted.
    pub(super) fn new(m: usize, k_z: usize, k1_exact: bool) -> Self {
        Self {
            last: V::zeros(k_z),
            offset: V::zeros(m),
            sum: V::zeros(m),
            trend: V::zeros(m),
            offset_next: V::zeros(m),
            sum_next: V::zeros(m),
            trend_next: V::zeros(m),
            last_h: V::Real::zero(),
            steps: 0,
            k1_exact,
        }
    }

    /// The multipliers of the last successful step.
    pub(super) fn last(&self) -> &V {
        &self.last
    }

    /// `λ_k ≈ λ_{k+1}^{prev} + h · offset` into `z[..m]`.
    #[inline(always)]
    pub(super) fn predict_lambda_k(&self, m: usize, h: V::Real, z: &mut [V::Real]) {
        let (last, off) = (self.last.as_slice(), self.offset.as_slice());
        for j in 0..m {
            z[j] = last[m + j] + h * off[j];
        }
    }

    /// Records the offset of the solved `λ_k` (`z[..m]`); nothing before the first step (there
    /// is no previous `λ_{k+1}` to measure it from).
    #[inline(always)]
    pub(super) fn record_lambda_k(&mut self, m: usize, h: V::Real, z: &[V::Real]) {
        if self.steps == 0 {
            return;
        }
        let (last, off) = (self.last.as_slice(), self.offset_next.as_mut_slice());
        for j in 0..m {
            off[j] = (z[j] - last[m + j]) / h;
        }
    }

    /// The working multipliers start from the last successful ones (the coupled and symmetric
    /// schemes warm-start from the last solution as it is).
    #[inline(always)]
    pub(super) fn start_from_last(&self, z: &mut V) {
        z.copy_from(&self.last);
    }

    /// `λ_{k+1} ≈ S + s S' − λ_k` into `z[m..2m]` (the last `λ_{k+1}` before the first step;
    /// nothing when it is solved exactly from any start).
    #[inline(always)]
    pub(super) fn predict_lambda_k1(&self, m: usize, h: V::Real, z: &mut [V::Real]) {
        if self.k1_exact {
            return;
        }
        if self.steps == 0 {
            z[m..2 * m].copy_from_slice(&self.last.as_slice()[m..2 * m]);
            return;
        }
        let spacing = self.spacing(h);
        let (sum, trend) = (self.sum.as_slice(), self.trend.as_slice());
        for j in 0..m {
            z[m + j] = sum[j] + spacing * trend[j] - z[j];
        }
    }

    /// Records `S = λ_k + λ_{k+1}` of the solved step and its change per unit step (nothing
    /// when `λ_{k+1}` is not predicted).
    #[inline(always)]
    pub(super) fn record_lambda_k1(&mut self, m: usize, h: V::Real, z: &[V::Real]) {
        if self.k1_exact {
            return;
        }
        let spacing = self.spacing(h);
        let first = self.steps == 0 || spacing == V::Real::zero();
        let sum = self.sum.as_slice();
        let (sum_next, trend_next) = (self.sum_next.as_mut_slice(), self.trend_next.as_mut_slice());
        for j in 0..m {
            let s_new = z[j] + z[m + j];
            trend_next[j] = if first {
                V::Real::zero()
            } else {
                (s_new - sum[j]) / spacing
            };
            sum_next[j] = s_new;
        }
    }

    /// The spacing `(h_prev + h)/2` of consecutive sums (each belongs to the middle of its
    /// step), whatever the sizes and signs of a composition's sub-steps.
    #[inline(always)]
    fn spacing(&self, h: V::Real) -> V::Real {
        (self.last_h + h) * V::Real::lit(0.5)
    }

    /// The step succeeded with multipliers `z` (the working vector, swapped in) and the
    /// recorded trends (swapped in when `decoupled`; the other schemes record none).
    #[inline(always)]
    pub(super) fn commit(&mut self, z: &mut V, h: V::Real, decoupled: bool) {
        take(&mut self.last, z);
        if decoupled {
            if self.steps > 0 {
                take(&mut self.offset, &mut self.offset_next);
            }
            if !self.k1_exact {
                take(&mut self.sum, &mut self.sum_next);
                take(&mut self.trend, &mut self.trend_next);
            }
        }
        self.last_h = h;
        self.steps += 1;
    }

    /// A fused composition step succeeded (see `Projected::step_fused`): the multipliers and
    /// the first stage's offset are swapped in; the sum and its trend, which belong to single
    /// steps, stay as they were.
    #[inline(always)]
    pub(super) fn commit_fused(&mut self, z: &mut V, h_last: V::Real) {
        take(&mut self.last, z);
        if self.steps > 0 {
            take(&mut self.offset, &mut self.offset_next);
        }
        self.last_h = h_last;
        self.steps += 1;
    }

    /// Appends the warm-start state (multipliers, offsets, sums, trends, last step, count).
    pub(super) fn save(&self, out: &mut Vec<V::Real>) {
        for v in [&self.last, &self.offset, &self.sum, &self.trend] {
            out.extend_from_slice(v.as_slice());
        }
        out.push(self.last_h);
        out.push(V::Real::lit(self.steps as f64));
    }

    /// Reads back what [`save`](Self::save) appended.
    pub(super) fn restore(&mut self, from: &mut &[V::Real]) {
        for v in [
            &mut self.last,
            &mut self.offset,
            &mut self.sum,
            &mut self.trend,
        ] {
            let dst = v.as_mut_slice();
            let src = crate::flow::take_memory(from, dst.len());
            dst[..src.len()].copy_from_slice(src);
        }
        if let [h, steps] = crate::flow::take_memory(from, 2) {
            self.last_h = *h;
            self.steps = steps.to_f64_lossy() as u64;
        }
    }
}
