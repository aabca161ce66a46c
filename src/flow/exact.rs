use super::{EXACT, Flow, Ledger};
use crate::error::StepError;
use crate::vector::Vector;

/// A flow given by a closure `f(h, x)` that advances `x` in place.
///
/// Built by [`from_fn`] for a closed-form (exact) sub-flow `exp(h D_K)` — a drift, a kick, a
/// rotation, a linear flow — or by [`from_fn_with_order`] for an approximate one.
#[derive(Debug, Clone, Copy)]
pub struct FnFlow<F> {
    f: F,
    order: u32,
    symmetric: bool,
    dissipative: bool,
    kick: bool,
}

impl<F> FnFlow<F> {
    /// Marks the flow as a kick: it moves only momenta (no coordinate a constraint reads), so
    /// that a projection around `kick(h/2) ∘ drift(h) ∘ kick(h/2)` applies the trailing kick
    /// once per step instead of once per Newton iteration. See [`Flow::is_kick`].
    pub fn kick(mut self) -> Self {
        self.kick = true;
        self
    }

    /// Marks the flow as dissipative (for instance the exact damping flow `p ← e^{−ch} p`), so
    /// that compositions with backward sub-steps refuse it. See [`Flow::dissipates`].
    pub fn dissipative(self) -> Self {
        self.dissipative_if(true)
    }

    /// Marks the flow as dissipative when `dissipates` holds (e.g. `c > 0` for a damping flow
    /// `p ← e^{−ch} p`, which is the identity at `c = 0`).
    pub fn dissipative_if(mut self, dissipates: bool) -> Self {
        self.dissipative = dissipates;
        self
    }
}

/// An exact sub-flow `x ↦ exp(h D_K) x` from a closure: order [`EXACT`], symmetric.
///
/// The closure must be the exact flow of some vector field, so that `f(−h) ∘ f(h) = id`.
pub fn from_fn<F>(f: F) -> FnFlow<F> {
    FnFlow {
        f,
        order: EXACT,
        symmetric: true,
        dissipative: false,
        kick: false,
    }
}

/// An approximate flow from a closure, with its order and whether it is symmetric.
pub fn from_fn_with_order<F>(f: F, order: u32, symmetric: bool) -> FnFlow<F> {
    FnFlow {
        f,
        order,
        symmetric,
        dissipative: false,
        kick: false,
    }
}

impl<V: Vector, F: FnMut(V::Real, &mut V)> Flow<V> for FnFlow<F> {
    #[inline(always)]
    fn step(&mut self, h: V::Real, x: &mut V) -> Result<(), StepError> {
        (self.f)(h, x);
        Ok(())
    }
    fn order(&self) -> u32 {
        self.order
    }
    fn is_symmetric(&self) -> bool {
        self.symmetric
    }
    fn is_fallible(&self) -> bool {
        false
    }
    fn dissipates(&self) -> bool {
        self.dissipative
    }
    fn is_kick(&self) -> bool {
        self.kick
    }
}

/// An exact sub-flow from a closure `f(ledger, h, x)` that also advances the extended
/// coordinates it owns (see [`Ledger`]): a time-dependent closed-form flow reads `ledger.t`
/// and advances it by `h`; an exact damping flow adds the energy it removed to
/// `ledger.dissipated`. Built by [`from_fn_at`].
#[derive(Debug, Clone, Copy)]
pub struct FnLedgerFlow<F> {
    f: F,
    dissipative: bool,
}

impl<F> FnLedgerFlow<F> {
    /// Marks the flow as dissipative (see [`FnFlow::dissipative`]).
    pub fn dissipative(mut self) -> Self {
        self.dissipative = true;
        self
    }
}

/// An exact sub-flow that keeps a [`Ledger`]: `f(ledger, h, x)` advances `x` by the exact flow
/// over `[ledger.t, ledger.t + h]` and updates the ledger's coordinates it owns. Order
/// [`EXACT`], symmetric; `step(h, x)` runs it from a fresh ledger at `t = 0`.
pub fn from_fn_at<F>(f: F) -> FnLedgerFlow<F> {
    FnLedgerFlow {
        f,
        dissipative: false,
    }
}

impl<V: Vector, F: FnMut(&mut Ledger<V::Real>, V::Real, &mut V)> Flow<V> for FnLedgerFlow<F> {
    fn step(&mut self, h: V::Real, x: &mut V) -> Result<(), StepError> {
        (self.f)(&mut Ledger::default(), h, x);
        Ok(())
    }
    #[inline(always)]
    fn step_at(
        &mut self,
        ledger: &mut Ledger<V::Real>,
        h: V::Real,
        x: &mut V,
    ) -> Result<(), StepError> {
        (self.f)(ledger, h, x);
        Ok(())
    }
    fn order(&self) -> u32 {
        EXACT
    }
    fn is_symmetric(&self) -> bool {
        true
    }
    fn is_fallible(&self) -> bool {
        false
    }
    fn dissipates(&self) -> bool {
        self.dissipative
    }
}
