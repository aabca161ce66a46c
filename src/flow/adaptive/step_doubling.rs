//! Step-size control for a scheme of fixed order by step doubling, with a PI controller.

use super::control::{Control, MacroStep, Outcome, controlled_flow};
use super::{AcceptStep, AdaptiveOptions, AdaptiveStats};
use crate::error::{SetupError, StepError};
use crate::flow::{EXACT, Flow, FlowStats, Ledger, Multipliers};
use crate::real::Real;
use crate::vector::Vector;
use num_traits::Float as _;

/// The shortest span, in units of the state's round-off (weighted norm), over which
/// [`StepDoubling`] measures its error per unit step: a step shorter than
/// `ROUNDOFF_STEPS · ε ‖x‖` is held to an error per step of that size instead.
const ROUNDOFF_STEPS: f64 = 4.0;

/// Step-size control for any one-step scheme `S_h` of fixed order `p` — the Petrov–Galerkin
/// scheme, the (projected) midpoint rule, the discrete gradients, a composition — by step
/// doubling: each step of size `H` is taken once whole and once as two halves, and
///
/// ```text
/// err = ‖S_{H/2}² x − S_H x‖ / (2^p − 1)
/// ```
///
/// (the weighted norm of [`Tolerances`](super::Tolerances)) estimates the error of the two
/// halves, which are kept: the result is a genuine step sequence of the scheme, so whatever it
/// preserves step by step — Petrov–Galerkin's discrete energy balance, a projection's
/// constraints, a discrete gradient's energy — it preserves under variable steps (no local
/// extrapolation, which would not). Without local extrapolation a local error at the tolerance
/// in every step adds up to a global error `∝ tol^{p/(p+1)}`; the error is therefore
/// controlled **per unit step**, `err/|H| ≤ 1` (`H` in the model's time unit), so that the
/// global error over a span `T` is about `tol · T` and proportional to the tolerance
/// (Shampine, *Numerical Solution of ODEs*, §7.1). The span is never taken shorter than
/// four times the state's round-off `ε ‖x‖` in the weighted norm
/// ([`Tolerances::roundoff`](super::Tolerances::roundoff)): a tolerance near the round-off
/// (`rtol` ≈ 1e-12 lets `tol · H` fall below `ε |x|` for `H` ≲ 1e-3) would otherwise ask every
/// step for less than rounding gives, and the estimate of a shrinking step — its round-off
/// over `H` — would reject it for ever; there, steps are held to an error per step at a few
/// times the rounding, the best a step can do. With `err_n = ‖…‖/((2^p − 1)|H_n|) = O(H^p)`,
/// a step with `err ≤ 1` is accepted and the next one is chosen by Gustafsson's PI controller,
///
/// ```text
/// H_{n+1} = H_n · 0.9 · err_n^{−0.7/p} · err_{n−1}^{0.4/p},   clamped to [0.2, 5] H_n,
/// ```
///
/// (no growth right after a rejection); a rejected one is retried with
/// `H · max(0.2, 0.9 err^{−1/p})` (Hairer & Wanner, *Solving ODEs II*, §IV.2; Gustafsson,
/// ACM TOMS 20, 1994). Each accepted result goes through `P` ([`AcceptStep`]). A rejected step,
/// or one whose sub-step fails (a Newton failure: the step halves), restores the state, the
/// ledger and the base flow's memory exactly; every sub-step has the sign of the step, so
/// damping never runs backwards. It is a [`Flow`] like
/// [`AdaptiveExtrapolation`](super::AdaptiveExtrapolation): `step(h)` lands on `t + h`,
/// [`Flow::step_own`] takes one step of its own size, the controller's state is part of the
/// flow's memory.
#[derive(Debug)]
pub struct StepDoubling<V: Vector, F, P = ()> {
    base: F,
    finish: P,
    control: Control<V>,
    /// The scheme's order `p`.
    order: u32,
    /// The last accepted estimate (the PI controller's memory; 1 before the first).
    err_prev: f64,
    start: V,
    whole_step: V,
    memory: Vec<V::Real>,
}

impl<V: Vector, F: Flow<V>, P: AcceptStep<V>> StepDoubling<V, F, P> {
    /// Step doubling of `base` under `options` (`max_order` is not used), each accepted step
    /// finished by `finish`.
    ///
    /// # Errors
    /// [`SetupError::Scheme`] when `base` is exact (it needs no control) or of order 0;
    /// [`SetupError::InvalidParameter`] for bad step bounds.
    pub fn try_new(
        base: F,
        finish: P,
        options: AdaptiveOptions<V::Real>,
    ) -> Result<Self, SetupError> {
        let order = base.order();
        if order == 0 || order == EXACT || order > 30 {
            return Err(SetupError::Scheme {
                what: format!(
                    "step doubling needs a scheme of finite order 1 … 30; this one has order {}",
                    if order == EXACT {
                        "EXACT (an exact flow needs no step control)".to_owned()
                    } else {
                        order.to_string()
                    }
                ),
            });
        }
        options.check()?;
        Ok(Self {
            base,
            finish,
            control: Control::new(options),
            order,
            err_prev: 1.0,
            start: V::zeros(0),
            whole_step: V::zeros(0),
            memory: Vec::new(),
        })
    }

    /// The base scheme.
    pub fn base(&self) -> &F {
        &self.base
    }

    /// The next step the controller will try (`None` before the first).
    pub fn next_step(&self) -> Option<V::Real> {
        self.control.h_next
    }

    fn restore_base(&mut self) {
        let mut from = self.memory.as_slice();
        self.base.restore_memory(&mut from);
    }

    /// The state, the ledger and the base flow's memory as the step found them.
    fn undo(&mut self, ledger: &mut Ledger<V::Real>, l0: Ledger<V::Real>, x: &mut V) {
        x.copy_from(&self.start);
        *ledger = l0;
        self.restore_base();
    }

    fn step_twice(
        &mut self,
        ledger: &mut Ledger<V::Real>,
        big: V::Real,
        x: &mut V,
    ) -> Result<Outcome<V::Real>, StepError> {
        let l0 = *ledger;
        self.start.copy_from(x);
        self.memory.clear();
        self.base.save_memory(&mut self.memory);
        // The whole step, then (from the same memory) the two halves, which are kept.
        let mut l_whole = l0;
        self.whole_step.copy_from(x);
        let whole = self.base.step_at(&mut l_whole, big, &mut self.whole_step);
        self.control.stats.base_steps += 1;
        if let Err(e) = whole {
            self.undo(ledger, l0, x);
            return Err(e);
        }
        self.restore_base();
        let half = big * V::Real::lit(0.5);
        let halves = self.base.step_repeated(ledger, half, 2, x);
        self.control.stats.base_steps += 2;
        if let Err(e) = halves {
            self.undo(ledger, l0, x);
            return Err(e);
        }
        let scale = f64::from(2u32.pow(self.order) - 1);
        let err = self
            .control
            .options
            .tolerances
            .error(
                x.as_slice(),
                self.whole_step.as_slice(),
                self.start.as_slice(),
                x.as_slice(),
            )
            .to_f64_lossy()
            / scale;
        // Per unit step: the local error over the step's length — but over no less than
        // `ROUNDOFF_STEPS` times the state's round-off, below which the criterion would ask a
        // step for less than rounding gives (the estimate of a tiny step is its round-off,
        // which grows as `1/H` per unit step: halving would never end).
        let hf = big.to_f64_lossy().abs();
        let roundoff = self
            .control
            .options
            .tolerances
            .roundoff(self.start.as_slice(), x.as_slice())
            .to_f64_lossy();
        let err = err / hf.max(ROUNDOFF_STEPS * roundoff);
        let p = f64::from(self.order);
        if err > 1.0 || err.is_nan() {
            self.undo(ledger, l0, x);
            let fac = if err.is_finite() {
                (0.9 * err.powf(-1.0 / p)).max(0.2)
            } else {
                0.2
            };
            self.control.book_rejected(err);
            return Ok(Outcome::Rejected(V::Real::lit(hf * fac)));
        }
        let finished = super::accept::finish_accepted(&mut self.finish, x);
        if let Err(e) = finished {
            self.undo(ledger, l0, x);
            self.finish.forget();
            return Err(e);
        }
        ledger.t = l0.t + big;
        let e = err.max(1e-10);
        let mut fac = (0.9 * e.powf(-0.7 / p) * self.err_prev.powf(0.4 / p)).clamp(0.2, 5.0);
        let c = &mut self.control;
        if c.rejected_last {
            fac = fac.min(1.0);
        }
        let mut next = hf * fac;
        if let Some(h_max) = c.options.h_max {
            next = next.min(h_max.to_f64_lossy());
        }
        self.err_prev = e;
        c.rejected_last = false;
        c.h_next = Some(V::Real::lit(next));
        c.book_accepted(hf, (self.order / 2) as usize, err);
        Ok(Outcome::Accepted)
    }
}

impl<V: Vector, F: Flow<V>, P: AcceptStep<V>> MacroStep<V> for StepDoubling<V, F, P> {
    const NAME: &'static str = "step doubling (per-component tolerances)";

    fn control(&mut self) -> &mut Control<V> {
        &mut self.control
    }

    fn attempt(
        &mut self,
        ledger: &mut Ledger<V::Real>,
        big: V::Real,
        x: &mut V,
    ) -> Result<Outcome<V::Real>, StepError> {
        self.step_twice(ledger, big, x)
    }

    fn save_all(&mut self, out: &mut Vec<V::Real>) {
        self.control.save(out);
        out.push(V::Real::lit(self.err_prev));
        self.base.save_memory(out);
    }

    fn restore_all(&mut self, from: &mut &[V::Real]) {
        if from.len() >= 3 {
            let (head, rest) = from.split_at(3);
            self.control.restore(&head[..2]);
            self.err_prev = head[2].to_f64_lossy();
            *from = rest;
        }
        self.base.restore_memory(from);
        self.finish.forget();
    }

    fn prepare_all(&mut self, x: &V) {
        if self.start.len() != x.len() {
            self.start = x.zeros_like();
            self.whole_step = x.zeros_like();
        }
        self.base.prepare(x);
    }

    /// Estimated for the scheme's order, at most [`AdaptiveOptions::resolve`].
    fn first_step(
        &mut self,
        ledger: &Ledger<V::Real>,
        sign: V::Real,
        span: V::Real,
        x: &V,
    ) -> (Option<V::Real>, u64) {
        let resolve = self.control.options.resolve;
        let start = super::first_step::Start {
            tolerances: &self.control.options.tolerances,
            order: self.order,
            ledger,
            sign,
            span,
            x,
        };
        let (h, steps) = super::first_step::estimate(&mut self.base, &start);
        let h = match (h, resolve) {
            (Some(h), Some(r)) => Some(h.min(r)),
            (None, Some(r)) => Some(r.min(span)),
            (h, None) => h,
        };
        (h, steps)
    }
}

controlled_flow!(StepDoubling, |s| s.order);
