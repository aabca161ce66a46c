//! The [`Flow`] an [`AdaptiveExtrapolation`] is: its macro step ([`MacroStep`]) run by the
//! stepping every error-controlled flow shares (`control.rs`).

use super::AdaptiveExtrapolation;
use crate::error::StepError;
use crate::flow::adaptive::control::{Control, MacroStep, Outcome, controlled_flow};
use crate::flow::adaptive::first_step;
use crate::flow::adaptive::interpolant::Interpolant;
use crate::flow::adaptive::{AcceptStep, AdaptiveStats};
use crate::flow::{Flow, FlowStats, Ledger, Multipliers};
use crate::real::Real;
use crate::vector::Vector;
use num_traits::Float as _;

impl<V: Vector, F: Flow<V>, P: AcceptStep<V>> MacroStep<V> for AdaptiveExtrapolation<V, F, P> {
    const NAME: &'static str = "adaptive extrapolation (per-component tolerances)";

    fn control(&mut self) -> &mut Control<V> {
        &mut self.control
    }

    fn attempt(
        &mut self,
        ledger: &mut Ledger<V::Real>,
        big: V::Real,
        x: &mut V,
    ) -> Result<Outcome<V::Real>, StepError> {
        self.attempt_table(ledger, big, x)
    }

    fn save_all(&mut self, out: &mut Vec<V::Real>) {
        self.save_state(out);
    }

    fn restore_all(&mut self, from: &mut &[V::Real]) {
        self.restore_state(from);
    }

    fn prepare_all(&mut self, x: &V) {
        if self.prev.len() != self.kmax || self.start.len() != x.len() {
            self.start = x.zeros_like();
            self.prev = (0..self.kmax).map(|_| x.zeros_like()).collect();
            self.cur = (0..self.kmax).map(|_| x.zeros_like()).collect();
        }
        if self.control.options.dense_output
            && !self
                .dense
                .as_ref()
                .is_some_and(|d| d.fits(x.len(), self.kmax))
        {
            self.dense = Some(Interpolant::new(x.len(), self.kmax));
        }
        self.base.prepare(x);
    }

    /// The polynomial of the last accepted step at `ledger.t`, projected by `finish`.
    fn interpolate(
        &mut self,
        ledger: &mut Ledger<V::Real>,
        out: &mut V,
    ) -> Option<Result<(), StepError>> {
        let d = self.dense.as_ref()?;
        if out.len() != self.start.len() || !d.eval(ledger, out.as_mut_slice()) {
            return None;
        }
        let projected = super::super::accept::finish_accepted(&mut self.finish, out);
        // What the projection kept from this point is not the run's: its next accepted step
        // rebuilds it, as after a dense output by a partial step.
        self.finish.forget();
        Some(projected)
    }

    /// Estimated for the order the controller starts at, `2 k_c`.
    fn first_step(
        &mut self,
        ledger: &Ledger<V::Real>,
        sign: V::Real,
        span: V::Real,
        x: &V,
    ) -> (Option<V::Real>, u64) {
        let start = first_step::Start {
            tolerances: &self.control.options.tolerances,
            order: 2 * self.kc as u32,
            ledger,
            sign,
            span,
            x,
        };
        first_step::estimate(&mut self.base, &start)
    }

    /// `n_{k_c} · resolve`: the finest row's sub-steps resolve the time asked for.
    fn longest(&self) -> V::Real {
        self.control
            .options
            .resolve
            .map_or_else(V::Real::infinity, |r| {
                r * V::Real::lit(f64::from(self.sub_steps(self.kc)))
            })
    }
}

controlled_flow!(AdaptiveExtrapolation, |s| 2 * s.kmax as u32);
