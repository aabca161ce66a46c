//! The contraction estimate that lets a simplified Newton iteration stop after its first update
//! without evaluating the residual there.
//!
//! A simplified Newton iteration (a kept or approximate matrix) converges linearly: its
//! residuals fall as `‖F(z₁)‖ ≈ θ ‖F(z₀)‖` with a contraction `θ` that changes slowly from step
//! to step when the step size resolves the motion. A solve whose start `z₀` comes from a good
//! predictor needs a single update to reach round-off, and the residual at `z₁` then only
//! confirms it — at the price of a whole residual, which for a collocation-type step is `s`
//! force evaluations. With `θ` measured on an earlier step, the residual at `z₁` is predicted
//! as `θ ‖F(z₀)‖` and the update `z₁ − z*` as `θ ‖Δz₀‖`; when both pass Newton's own tests
//! (`‖F‖ ≤ ftol`, or the residual within its noise and the update at the round-off of `z`), the
//! solve accepts `z₁` unevaluated. This is the stopping criterion of Hairer & Wanner, *Solving
//! Ordinary Differential Equations II*, §IV.8 (8.10)–(8.11), which carries `θ` across steps in
//! the same way; here the tolerance is Newton's round-off test instead of a fraction of the
//! integration tolerance.
//!
//! `θ` is the ratio of the raw residuals `‖F(z₁)‖∞ / ‖F(z₀)‖∞` of the last first update that was
//! evaluated: a residual at its rounding floor makes it an overestimate, never an
//! underestimate of the contraction. It is measured again at least every [`CONFIRM_EVERY`]
//! solves, and whenever a prediction fails the tests.

use crate::nonlinear::NewtonOptions;
use crate::real::Real;

/// The most solves in a row accepted on a predicted contraction before one is evaluated again.
pub(crate) const CONFIRM_EVERY: usize = 8;

/// `θ` and how many more solves may rely on it (off unless [`enable`](Self::enable)d).
#[derive(Debug, Clone, Copy)]
pub(crate) struct ContractionEstimate<T> {
    on: bool,
    theta: T,
    left: usize,
}

impl<T: Real> ContractionEstimate<T> {
    /// Off: every update is evaluated.
    pub(crate) fn new() -> Self {
        Self {
            on: false,
            theta: T::zero(),
            left: 0,
        }
    }

    /// Lets solves stop on a predicted contraction: for a caller that needs nothing from the
    /// residual at the solution (the problem's scratch then holds the state before the last
    /// update).
    pub(crate) fn enable(&mut self) {
        self.on = true;
    }

    /// Forgets `θ` (a new step size, a failure, a checkpoint).
    pub(crate) fn forget(&mut self) {
        self.theta = T::zero();
        self.left = 0;
    }

    /// Whether the first update of a solve, which started at the raw residual `raw0`, moved
    /// `z` by `step` (max-norm) to `z` of max-norm `z_norm`, is accepted unevaluated: the
    /// predicted residual there when it is.
    pub(crate) fn accepts(
        &mut self,
        raw0: T,
        step: T,
        z_norm: T,
        options: &NewtonOptions<T>,
    ) -> Option<T> {
        if !self.on || self.left == 0 || self.theta <= T::zero() {
            return None;
        }
        let predicted = self.theta * raw0;
        let noise = T::lit(crate::nonlinear::NOISE_FACTOR) * options.ftol;
        let at_round_off = self.theta * step <= options.xtol * (T::one() + z_norm);
        let ok = predicted.is_finite()
            && step.is_finite()
            && (predicted <= options.ftol || (predicted <= noise && at_round_off));
        if !ok {
            return None;
        }
        self.left -= 1;
        Some(predicted)
    }

    /// Records the evaluated first update of a solve: raw residuals `raw0` before, `raw1` after.
    pub(crate) fn measured(&mut self, raw0: T, raw1: T) {
        if !self.on {
            return;
        }
        if raw0 > T::zero() && raw1.is_finite() {
            self.theta = (raw1 / raw0).max(T::epsilon());
            self.left = CONFIRM_EVERY;
        } else {
            self.forget();
        }
    }
}
