//! Dense output: the state between step points, to the scheme's order.

use super::Stepper;
use crate::error::StepError;
use crate::flow::{Flow, Ledger};
use crate::vector::Vector;
use std::borrow::BorrowMut;

/// What [`Stepper::show`] set aside besides the state: the step end's ledger and time base.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Shown<T> {
    ledger: Ledger<T>,
    t_base: T,
    k_base: usize,
}

impl<V, F, S> Stepper<V, F, S>
where
    V: Vector,
    F: Flow<V>,
    S: BorrowMut<V>,
{
    /// The state at time `t` between the last two step points, into `out`: one step of the
    /// scheme itself from the previous point to `t` (`θ h`, `0 ≤ θ ≤ 1`). It has the scheme's
    /// order and its geometry — a projected flow's dense state is on `g = 0` at round-off.
    /// Costs one step per evaluation; the flow's memory (warm starts) is kept as it was, so
    /// the run continues unchanged, except that kept Newton matrices are rebuilt at the next
    /// step. Before the first step, `t` is measured from the initial point. Returns the ledger
    /// at `t`. An adaptive extrapolation with [`dense_output`](crate::flow::AdaptiveOptions::dense_output)
    /// answers from the polynomial of its last accepted step instead, projected onto the
    /// manifold as the step's end is ([`Flow::interpolate`]), when that step covers `t`.
    ///
    /// # Errors
    /// The step's [`StepError`] (a `t` outside the last step is extrapolated, not refused:
    /// the map is defined for any `θ`, accurate for `θ` in `[0, 1]`).
    pub fn dense(&mut self, t: V::Real, out: &mut V) -> Result<Ledger<V::Real>, StepError> {
        let mut ledger = self.last_ledger;
        let mut at = Ledger { t, ..ledger };
        if let Some(r) = self.flow.interpolate(&mut at, out) {
            return r.map(|()| at);
        }
        let h = t - ledger.t;
        out.copy_from(&self.last);
        self.memory.clear();
        self.flow.save_memory(&mut self.memory);
        let r = self.flow.step_at(&mut ledger, h, out);
        self.flow.restore_memory(&mut self.memory.as_slice());
        r.map(|()| ledger)
    }

    /// Shows the dense output at `t` as the stepper's state, time and ledger (the step's end
    /// into `end`), until [`resume`](Self::resume) puts the end back: observers read a report
    /// time inside a step while the run goes on from the step's end. Nothing may step between.
    pub(crate) fn show(&mut self, t: V::Real, end: &mut V) -> Result<Shown<V::Real>, StepError> {
        let ledger = self.dense(t, end)?;
        core::mem::swap(self.x.borrow_mut(), end);
        let kept = Shown {
            ledger: self.ledger,
            t_base: self.t_base,
            k_base: self.k_base,
        };
        self.ledger = ledger;
        self.t_base = t;
        self.k_base = self.k;
        Ok(kept)
    }

    /// Puts back the step's end [`show`](Self::show) set aside.
    pub(crate) fn resume(&mut self, kept: Shown<V::Real>, end: &mut V) {
        core::mem::swap(self.x.borrow_mut(), end);
        self.ledger = kept.ledger;
        self.t_base = kept.t_base;
        self.k_base = kept.k_base;
    }

    /// The time of the previous step point (the start of the dense output's interval).
    pub fn previous_time(&self) -> V::Real {
        self.last_ledger.t
    }

    /// Moves the stepper to `t` on the dense output of the last step (a step of `t − t_prev`
    /// from the previous point, which becomes the current state): the step to an event.
    pub(crate) fn step_back_to(&mut self, t: V::Real, out: &mut V) -> Result<(), StepError> {
        let ledger = self.dense(t, out)?;
        self.x.borrow_mut().copy_from(out);
        self.ledger = ledger;
        self.t_base = t;
        self.k_base = self.k;
        Ok(())
    }
}
