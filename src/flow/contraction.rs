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
//! evaluated (a residual at its rounding floor makes it an overestimate). It is trusted for at
//! most [`CONFIRM_EVERY`] solves in a row (the next one is evaluated and measures it again),
//! only from start residuals within `START_GROWTH` of the one it was measured from (the linear
//! model holds near that size), and it is measured again whenever a prediction fails the
//! tests; a step that does not continue the last one, a new step size and a failure forget it.

use crate::nonlinear::NewtonOptions;
use crate::real::Real;

/// The most solves in a row accepted on a predicted contraction; the next one is evaluated.
pub(crate) const CONFIRM_EVERY: usize = 8;

/// How much larger than the one `θ` was measured from a start residual may be for `θ` to be
/// trusted: the linear model `‖F(z₁)‖ ≈ θ‖F(z₀)‖` holds near that size, and from a much worse
/// start the quadratic terms take over.
const START_GROWTH: f64 = 10.0;

/// `θ` and how many more solves may rely on it (off unless [`enable`](Self::enable)d).
#[derive(Debug, Clone, Copy)]
pub(crate) struct ContractionEstimate<T> {
    on: bool,
    theta: T,
    /// The raw start residual `θ` was measured from.
    start: T,
    left: usize,
}

impl<T: Real> ContractionEstimate<T> {
    /// Off: every update is evaluated.
    pub(crate) fn new() -> Self {
        Self {
            on: false,
            theta: T::zero(),
            start: T::zero(),
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
        if !self.on
            || self.left == 0
            || self.theta <= T::zero()
            || raw0 > T::lit(START_GROWTH) * self.start
        {
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

    /// Records the evaluated first update of a solve: raw residuals `raw0` before, `raw1` after
    /// (not finite when the evaluation failed). An update that did not reduce the residual
    /// (the lenient first update of a solve from a poor start) leaves nothing to trust.
    pub(crate) fn measured(&mut self, raw0: T, raw1: T) {
        if !self.on {
            return;
        }
        if raw0 > T::zero() && raw1.is_finite() && raw1 < raw0 {
            self.theta = (raw1 / raw0).max(T::epsilon());
            self.start = raw0;
            self.left = CONFIRM_EVERY;
        } else {
            self.forget();
        }
    }
}
