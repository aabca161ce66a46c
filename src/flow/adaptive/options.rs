//! What an adaptive flow is asked for ([`AdaptiveOptions`]) and what it reports
//! ([`AdaptiveStats`]).

use super::Tolerances;
use crate::error::SetupError;
use crate::flow::MAX_ROWS;
use crate::real::Real;

/// What an adaptive flow is asked for: the tolerances, the first step, the smallest and the
/// largest step, the highest order, and a time the sub-steps must resolve.
#[derive(Debug, Clone, PartialEq)]
pub struct AdaptiveOptions<T> {
    /// The accuracy asked for, per macro step, in the weighted norm ([`Tolerances`]).
    pub tolerances: Tolerances<T>,
    /// The first step to try (default: the first interval asked for, clipped to `h_max`).
    pub first_step: Option<T>,
    /// The smallest step: a step that would have to be smaller fails with
    /// [`StepError::StepSizeTooSmall`](crate::error::StepError::StepSizeTooSmall) (default `0`: only a step that no longer moves time).
    pub h_min: T,
    /// The largest step (default: unbounded).
    pub h_max: Option<T>,
    /// The highest order, even, 4 … `2·MAX_ROWS` (default 16): the table has `max_order / 2`
    /// rows at most.
    pub max_order: u32,
    /// A time every sub-step of the extrapolation table must resolve (default: none): a macro
    /// step aimed at column `k` is at most `k · resolve` long, so that the sub-steps of the
    /// row it aims at are at most `resolve` (at most `1.5 · resolve` when it is accepted a row
    /// early). For a base step whose exact sub-flow damps at rates up
    /// to `γ` (a splitting's damped free flight), with constraints or kicks acting on the damped
    /// momenta, `resolve = 1/γ`: over sub-steps much longer than the relaxation time the
    /// base step's error is no longer an expansion in `h²` with moderate coefficients — the
    /// damping swallows the impulses a symmetric step balances, and the error behaves as first
    /// order in `h` — and the table's estimate does not see it (docs/method.md §12d).
    ///
    /// Under [`StepDoubling`](super::StepDoubling) it bounds the estimated first step (a given
    /// [`first_step`](Self::first_step) is taken as it is): a first step many relaxation times
    /// long steps over the transient from the initial state, and a scheme whose stability
    /// function tends to `+1` at infinity (Petrov–Galerkin of orders 4 and 8, Gauss-like with
    /// an even number of stages) keeps the stiff mode's deviation undamped in the whole step
    /// and in its halves alike, so the estimate does not see it. From a first step within the
    /// relaxation time the controller grows by at most 5× a step, and over a few relaxation
    /// times the whole step and its halves differ where the deviation remains.
    pub resolve: Option<T>,
    /// Times no step crosses (default: none): each step ends on the next one ahead, as
    /// DifferentialEquations.jl's `d_discontinuities` and SUNDIALS' stop time do — where the
    /// forcing jumps or kinks ([`Signal::breakpoints`](crate::port::Signal::breakpoints)). A
    /// step across one is not the smooth expansion its error estimate assumes: the estimate
    /// can be small while the error is not (a step input inside a macro step of the adaptive
    /// extrapolation: 500–60 000 × tol, docs/method.md §12d). Any order; a time within
    /// rounding of the current one counts as passed.
    pub breakpoints: Vec<T>,
    /// Keep an interpolant of each accepted step ([`AdaptiveExtrapolation`](super::AdaptiveExtrapolation)
    /// only; default `false`): dense output — [`Stepper::dense`](crate::Stepper::dense),
    /// events, report times inside a step — from a polynomial instead of a partial step. The
    /// table then runs the even sequence `n_j = 2j` (every row's midpoint one of its points;
    /// the same work per unit time as `n_j = j` at each order, its steps twice as long) and
    /// keeps each row's points around the midpoint (docs/method.md §12d, "Dense output").
    pub dense_output: bool,
}

impl<T: Real> AdaptiveOptions<T> {
    /// `tolerances` with the defaults above.
    pub fn new(tolerances: Tolerances<T>) -> Self {
        Self {
            tolerances,
            first_step: None,
            h_min: T::zero(),
            h_max: None,
            max_order: 2 * MAX_ROWS as u32,
            resolve: None,
            breakpoints: Vec::new(),
            dense_output: false,
        }
    }

    /// Checks the step bounds: `0 ≤ h_min < h_max`, `h_min` finite, a first step positive and
    /// finite.
    ///
    /// # Errors
    /// [`SetupError::InvalidParameter`] naming the bound.
    pub fn check(&self) -> Result<(), SetupError> {
        let h_min = self.h_min.to_f64_lossy();
        let h_max = self.h_max.map_or(f64::INFINITY, |h| h.to_f64_lossy());
        if !(h_min >= 0.0 && h_min.is_finite() && h_max > h_min && !h_max.is_nan()) {
            return Err(SetupError::InvalidParameter {
                name: "h_min, h_max".to_owned(),
                value: h_min,
                requirement: "0 ≤ h_min < h_max, both finite (h_max may be unbounded)",
            });
        }
        if let Some(t) = self.breakpoints.iter().find(|t| !t.is_finite()) {
            return Err(SetupError::InvalidParameter {
                name: "breakpoints".to_owned(),
                value: t.to_f64_lossy(),
                requirement: "finite",
            });
        }
        for (name, h) in [("first_step", self.first_step), ("resolve", self.resolve)] {
            if let Some(h) = h.map(|h| h.to_f64_lossy())
                && !(h > 0.0 && h.is_finite())
            {
                return Err(SetupError::InvalidParameter {
                    name: name.to_owned(),
                    value: h,
                    requirement: "positive and finite",
                });
            }
        }
        Ok(())
    }
}

/// What the controller did (cumulative since construction).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct AdaptiveStats {
    /// Accepted macro steps.
    pub accepted: u64,
    /// Rejected macro steps: the error estimate above the tolerance.
    pub rejected: u64,
    /// Macro steps abandoned because a sub-step failed (a Newton failure, a non-finite state,
    /// the projection's failure): the step was halved.
    pub failed: u64,
    /// Base steps taken (accepted, rejected and failed macro steps alike).
    pub base_steps: u64,
    /// `orders[k]`: steps accepted at order `2k` (`k` table rows).
    pub orders: [u64; MAX_ROWS + 1],
    /// The smallest accepted step (`∞` before the first).
    pub smallest: f64,
    /// The largest accepted step.
    pub largest: f64,
    /// The error estimate of the last accepted step, in the weighted norm (≤ 1).
    pub last_error: f64,
}
