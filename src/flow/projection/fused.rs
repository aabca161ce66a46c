//! A composition's stages, or an extrapolation row's equal steps, run by the projection itself:
//! the second half-step of each stage fused with the first of the next, one multiplier solve
//! per stage (method §4).

use super::{Base, Projected, SmallFits};
use crate::error::StepError;
use crate::flow::{CompositionTable, Flow, FlowStats, Ledger};
use crate::linalg::LinearSolver;
use crate::nonlinear::SMALL_MAX;
use crate::real::Real;
use crate::system::Model;
use crate::vector::Vector;
use num_traits::Float as _;
use num_traits::One;

impl<V, F, Sys, L> Projected<V, F, Sys, L>
where
    V: Vector,
    F: Flow<V>,
    Sys: Model<V>,
    L: LinearSolver<V::Real>,
{
    /// A composition's stages as one fused step (decoupled scheme); with
    /// [`StageSizes::Single`], the decoupled step itself (RATTLE-like: `λ_k` from
    /// `g(x_{k+1}) = 0`, then `λ_{k+1}` from `φ(x_{k+1}) = 0`, each from its own warm start), so
    /// that a flow compiles one step for both. `K = m` on the small path (every loop over the
    /// multipliers unrolls), `K = 0` on the general one. Stage `i`'s second
    /// half-step `y_i + (h_i/2) M Gᵀ(y_i) λ_{k+1}` and stage `i+1`'s first half-step act along
    /// the same direction `M Gᵀ(y_i)` (which the second half-step does not change), so together
    /// they are one shift `y_i + (h_{i+1}/2) M Gᵀ λ̃` with `λ̃ = λ_k + (h_i/h_{i+1}) λ_{k+1}`, and
    /// `g(y_{i+1}) = 0` determines `λ̃` alone: the interior `λ_{k+1}` (fixed by `φ = 0` at a
    /// point the composition never returns) does not change the result. One multiplier solve
    /// per stage, plus the last stage's `λ_{k+1}` so that the result is on `g = 0`, `φ = 0`:
    /// the same map as the stage-by-stage composition, up to the Newton tolerance.
    ///
    /// The small path's work and the interior stages are counted in `tally` (see
    /// [`Self::tallied`]).
    pub(super) fn step_fused<const K: usize>(
        &mut self,
        stages: usize,
        size: StageSizes<'_, V::Real>,
        x: &V,
        tally: &mut FlowStats,
    ) -> Result<V::Real, StepError> {
        let m = if K == 0 { self.m } else { K };
        let one = V::Real::one();
        let mut h_prev = size.at(0);
        self.w
            .warm
            .predict_lambda_k(m, h_prev, self.w.z.as_mut_slice());
        let mut base = Base::Given(x);
        let mut hi = h_prev;
        // The λ_k solve has one call site, inlined once: stage 0 from `x`, the others from the
        // previous stage's `y` with the force estimate carried over.
        for i in 0..stages {
            self.solve_lambda_k::<K>(hi, base, tally)?;
            if i == 0 {
                self.w.warm.record_lambda_k(m, hi, self.w.z.as_slice());
            } else {
                // λ̃ = λ_k + (h_prev/h_i) λ_{k+1} ≈ (1 + h_prev/h_i) λ: the force estimate
                // (the previous one when the stages nearly cancel, h_prev ≈ −h_i).
                let grow = one + h_prev / hi;
                let (z, force) = (self.w.z.as_mut_slice(), self.w.r.as_slice());
                if grow.abs() >= V::Real::lit(1e-3) {
                    let inv_grow = one / grow;
                    z[..m].iter_mut().for_each(|v| *v = *v * inv_grow);
                } else {
                    z[..m].copy_from_slice(&force[..m]);
                }
                tally.projected_steps += 1;
            }
            if i + 1 == stages {
                break;
            }
            h_prev = hi;
            hi = size.at(i + 1);
            // The previous stage's λ̃ split evenly between its own λ_k and λ_{k+1} estimates
            // the force per unit time; λ̃ of this stage is that force times (1 + h_prev/h_i).
            let w = &mut self.w;
            core::mem::swap(&mut w.y, &mut w.prev);
            w.y_valid = false;
            let grow = one + h_prev / hi;
            let (z, force) = (w.z.as_mut_slice(), w.r.as_mut_slice());
            for (v, f) in z[..m].iter_mut().zip(force.iter_mut()) {
                *f = *v;
                *v = *v * grow;
            }
            // This stage's inner sub-step starts where the previous one ended.
            w.ledger_in = w.ledger_y;
            base = Base::Prev;
        }
        let h_prev = hi;
        // λ_{k+1}: one step from its own warm start (which it then records), the last stage of
        // a composition from the force estimate. One call site of the solve, which is inlined.
        let single = size.is_single();
        if single {
            self.w
                .warm
                .predict_lambda_k1(m, h_prev, self.w.z.as_mut_slice());
        } else {
            let z = self.w.z.as_mut_slice();
            let (a, b) = z.split_at_mut(m);
            b[..m].copy_from_slice(a);
        }
        self.solve_lambda_k1::<K>(h_prev, x, tally)?;
        if single {
            self.w.warm.record_lambda_k1(m, h_prev, self.w.z.as_slice());
        }
        self.decoupling_guard::<K>(m)?;
        Ok(h_prev)
    }

    /// `stages` fused stages of sizes `size(i)` as one atomic step from `ledger` (`h` the
    /// whole step, for the size check): on success `x` and `ledger` hold the end and the warm
    /// starts are committed; on failure both are as passed in.
    pub(super) fn run_fused(
        &mut self,
        ledger: &mut Ledger<V::Real>,
        h: V::Real,
        x: &mut V,
        stages: usize,
        size: StageSizes<'_, V::Real>,
    ) -> Result<(), StepError> {
        self.w.ledger_in = *ledger;
        let fused = self.run_atomic(h, x, |flow, x| flow.fused_stages(stages, size, x))?;
        if let Some(h_last) = fused {
            self.w.warm.commit_fused(&mut self.w.z, h_last);
            self.stats.projected_steps += 1;
            *ledger = self.w.ledger_y;
        }
        Ok(())
    }

    /// `stages` fused stages of sizes `size(i)`, dispatched on the multiplier count.
    pub(super) fn fused_stages(
        &mut self,
        stages: usize,
        size: StageSizes<'_, V::Real>,
        x: &V,
    ) -> Result<V::Real, StepError> {
        self.w.y_valid = false;
        self.tallied(|flow, t| match (flow.small.is_some(), flow.m) {
            (true, 1) => flow.step_fused::<1>(stages, size, x, t),
            (true, 2) if SmallFits::<V, 2>::OK => flow.step_fused::<2>(stages, size, x, t),
            (true, 3) if SmallFits::<V, 3>::OK => flow.step_fused::<3>(stages, size, x, t),
            (true, _) if SmallFits::<V, SMALL_MAX>::OK => {
                flow.step_fused::<SMALL_MAX>(stages, size, x, t)
            }
            _ => flow.step_fused::<0>(stages, size, x, t),
        })
    }
}

/// The sizes of fused stages: a composition's `γ_i h`, or `n` equal steps `h`. A value, not a
/// closure, so that the fused step is compiled once per flow, not once per caller.
#[derive(Clone, Copy)]
pub(super) enum StageSizes<'a, T> {
    /// Stage `i` of `table` on a step `h`.
    Table(&'a CompositionTable, T),
    /// Every stage `h`.
    Equal(T),
    /// One step `h`, not part of a composition: its `λ_{k+1}` has a warm start of its own.
    Single(T),
}

impl<T: Real> StageSizes<'_, T> {
    #[inline]
    fn at(self, i: usize) -> T {
        match self {
            StageSizes::Table(table, h) => table.gamma_in::<T>(i) * h,
            StageSizes::Equal(h) | StageSizes::Single(h) => h,
        }
    }

    #[inline]
    fn is_single(self) -> bool {
        matches!(self, StageSizes::Single(_))
    }
}
