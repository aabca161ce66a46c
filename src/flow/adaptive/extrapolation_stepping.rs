//! The [`Flow`] an [`AdaptiveExtrapolation`] is: its macro step ([`MacroStep`]) run by the
//! stepping every error-controlled flow shares (`control.rs`).

use super::AdaptiveExtrapolation;
use crate::error::StepError;
use crate::flow::adaptive::control::{self, Control, MacroStep, Outcome};
use crate::flow::adaptive::{AcceptStep, AdaptiveStats};
use crate::flow::{Flow, FlowStats, Ledger, Multipliers};
use crate::vector::Vector;

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
        self.base.prepare(x);
    }
}

impl<V: Vector, F: Flow<V>, P: AcceptStep<V>> Flow<V> for AdaptiveExtrapolation<V, F, P> {
    fn step(&mut self, h: V::Real, x: &mut V) -> Result<(), StepError> {
        self.step_at(&mut Ledger::default(), h, x)
    }

    /// Advances by exactly `h`: macro steps of the controller's choosing, the last clipped to
    /// land on `t + h`.
    fn step_at(
        &mut self,
        ledger: &mut Ledger<V::Real>,
        h: V::Real,
        x: &mut V,
    ) -> Result<(), StepError> {
        control::step_at(self, ledger, h, x)
    }

    /// One macro step of the controller's own size, at most `|max|`, in the direction of `max`.
    fn step_own(
        &mut self,
        ledger: &mut Ledger<V::Real>,
        max: V::Real,
        x: &mut V,
    ) -> Option<Result<V::Real, StepError>> {
        Some(control::step_own(self, ledger, max, x))
    }

    fn order(&self) -> u32 {
        2 * self.kmax as u32
    }

    fn is_symmetric(&self) -> bool {
        false
    }

    fn prepare(&mut self, x: &V) {
        self.prepare_all(x);
    }

    fn stats(&self) -> FlowStats {
        self.base.stats() + self.finish.stats()
    }

    fn multipliers(&self) -> Option<Multipliers<'_, V::Real>> {
        self.base.multipliers()
    }

    fn dissipates(&self) -> bool {
        self.base.dissipates()
    }

    fn save_memory(&mut self, out: &mut Vec<V::Real>) {
        self.save_state(out);
    }

    fn adaptive_stats(&self) -> Option<AdaptiveStats> {
        Some(self.control.stats)
    }

    fn restore_memory(&mut self, from: &mut &[V::Real]) {
        self.restore_state(from);
    }
}
