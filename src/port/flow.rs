//! The exact sub-flow of the inputs, `x ← x + B(x) ∫ u dt`.

use super::{InputMap, Signal};
use crate::error::StepError;
use crate::flow::{EXACT, Flow, Ledger};
use crate::real::Real;
use crate::system::Hamiltonian;
use crate::vector::Vector;
use num_traits::{Float as _, Zero};

/// The exact flow of `x' = B(x) u(t)` over a sub-step `[τ, τ + h]`: `x ← x + B(x) w` with
/// `w_j = ∫_τ^{τ+h} u_j dt` (exact under the [`InputMap`] contract).
///
/// It is the part of the splitting that carries time (see [`Ledger`]): it reads `τ` from the
/// ledger and advances it by `h`, so that in any composition each of its sub-steps integrates
/// the input over its own interval and the composition keeps its order for time-dependent
/// inputs. Built with [`supplying`](Self::supplying), it adds the energy it supplies,
/// `H(x_after) − H(x_before)` (which is `∫ yᵀu` along the sub-flow, exactly), to the ledger;
/// summed over a step, that is `∫ yᵀu dt` to the scheme's order. Without it, no energy is
/// evaluated.
///
/// Symmetric (`Φ_{−h}` integrates back over the same interval) and closed-form, so
/// compositions pay nothing to guard it. A step allocates nothing.
#[derive(Debug, Clone)]
pub struct InputFlow<V: Vector, B, H = ()> {
    map: B,
    signals: Vec<Signal<V::Real>>,
    w: Vec<V::Real>,
    hamiltonian: H,
    before: Option<V>,
    kick: bool,
}

impl<V: Vector, B: InputMap<V>> InputFlow<V, B, ()> {
    /// The input flow of `map` driven by `signals` (one per input).
    ///
    /// # Errors
    /// [`SetupError::Dimension`](crate::error::SetupError::Dimension) when the number of
    /// signals differs from `map.inputs()`.
    pub fn try_new(
        map: B,
        signals: Vec<Signal<V::Real>>,
    ) -> Result<Self, crate::error::SetupError> {
        if signals.len() != map.inputs() {
            return Err(crate::error::SetupError::Dimension {
                what: format!(
                    "{} signals for an input map with {} inputs",
                    signals.len(),
                    map.inputs()
                ),
            });
        }
        let k = signals.len();
        Ok(Self {
            map,
            signals,
            w: vec![V::Real::zero(); k],
            hamiltonian: (),
            before: None,
            kick: false,
        })
    }

    /// Accounts for the energy supplied, with the model's Hamiltonian (see the type's docs).
    pub fn supplying<H: Hamiltonian<V>>(self, hamiltonian: H) -> InputFlow<V, B, Supplying<H>> {
        InputFlow {
            map: self.map,
            signals: self.signals,
            w: self.w,
            hamiltonian: Supplying(hamiltonian),
            before: None,
            kick: self.kick,
        }
    }
}

impl<V: Vector, B, H> InputFlow<V, B, H> {
    /// Declares the inputs forces: `B(x)` moves only momenta (no coordinate a constraint
    /// reads) and is read at the positions alone (the first half of the state), so the flow is
    /// a kick ([`Flow::is_kick`]) and a projection around a splitting
    /// that ends with it applies it once per step.
    pub fn kick(mut self) -> Self {
        self.kick = true;
        self
    }
    /// The input map.
    pub fn map(&self) -> &B {
        &self.map
    }
    /// The signals, one per input.
    pub fn signals(&self) -> &[Signal<V::Real>] {
        &self.signals
    }
    /// Replaces the signal of input `j` (a parameter change between steps); `false` if there
    /// is no input `j`.
    pub fn set_signal(&mut self, j: usize, signal: Signal<V::Real>) -> bool {
        match self.signals.get_mut(j) {
            Some(s) => {
                *s = signal;
                true
            }
            None => false,
        }
    }
    /// `u(t)`, into `u` (`k` entries).
    pub fn values(&self, t: V::Real, u: &mut [V::Real]) {
        for (uj, s) in u.iter_mut().zip(&self.signals) {
            *uj = s.value(t);
        }
    }
}

/// The error of input `j` whose integral `w` over `[a, b]` is not finite: at the first of
/// `a`, the midpoint and `b` where its value is not, or at the midpoint with the mean value.
#[cold]
fn non_finite_input<T: Real>(j: usize, signal: &Signal<T>, a: T, b: T, w: T) -> StepError {
    let mid = (a + b) * T::lit(0.5);
    let (t, value) = [a, mid, b]
        .into_iter()
        .map(|t| (t, signal.value(t)))
        .find(|(_, u)| !u.is_finite())
        .unwrap_or((mid, w / (b - a)));
    StepError::NonFiniteInput {
        input: j,
        t: t.to_f64_lossy(),
        value: value.to_f64_lossy(),
    }
}

/// What the input flow does with the energy: nothing, or account for it with a Hamiltonian.
pub trait SuppliedEnergy<V: Vector> {
    /// `true` when the energy is accounted for.
    const ACCOUNTS: bool;
    /// `H(after) − H(before)`.
    fn supplied(&self, before: &V, after: &V) -> V::Real;
}

impl<V: Vector> SuppliedEnergy<V> for () {
    const ACCOUNTS: bool = false;
    fn supplied(&self, _: &V, _: &V) -> V::Real {
        V::Real::zero()
    }
}

/// The energy accounted with a Hamiltonian (see [`InputFlow::supplying`]).
#[derive(Debug, Clone)]
pub struct Supplying<H>(pub H);

impl<V: Vector, H: Hamiltonian<V>> SuppliedEnergy<V> for Supplying<H> {
    const ACCOUNTS: bool = true;
    fn supplied(&self, before: &V, after: &V) -> V::Real {
        self.0.energy_difference(before, after)
    }
}

impl<V, B, H> Flow<V> for InputFlow<V, B, H>
where
    V: Vector,
    B: InputMap<V>,
    H: SuppliedEnergy<V>,
{
    /// As a step from `t = 0` (see [`step_at`](Flow::step_at), which drivers call).
    fn step(&mut self, h: V::Real, x: &mut V) -> Result<(), StepError> {
        self.step_at(&mut Ledger::default(), h, x)
    }
    #[inline]
    fn step_at(
        &mut self,
        ledger: &mut Ledger<V::Real>,
        h: V::Real,
        x: &mut V,
    ) -> Result<(), StepError> {
        let (a, b) = (ledger.t, ledger.t + h);
        for (wj, s) in self.w.iter_mut().zip(&self.signals) {
            *wj = s.integral(a, b);
        }
        if let Some(j) = self.w.iter().position(|w| !w.is_finite()) {
            return Err(non_finite_input(j, &self.signals[j], a, b, self.w[j]));
        }
        if H::ACCOUNTS {
            let before = self.before.get_or_insert_with(|| x.clone());
            before.copy_from(x);
        }
        self.map.apply(x, &self.w);
        if H::ACCOUNTS
            && let Some(before) = self.before.as_ref()
        {
            ledger.supplied = ledger.supplied + self.hamiltonian.supplied(before, x);
        }
        ledger.t = b;
        Ok(())
    }
    fn order(&self) -> u32 {
        EXACT
    }
    fn is_symmetric(&self) -> bool {
        true
    }
    /// Closed-form: it fails only on a signal that is not finite, before it moves the state
    /// (a composition around it may have moved it; [`Stepper`](crate::stepper::Stepper)
    /// restores the state before the step).
    fn is_fallible(&self) -> bool {
        false
    }
    fn is_kick(&self) -> bool {
        self.kick
    }
    /// As a [kick](Self::kick) (`B` read at the positions, the first half of the state, which
    /// the flow leaves): for a change of the momenta alone the flow's tangent is the identity.
    /// A change of the positions changes `B`, which is not formed: `false`.
    fn tangent_apply(&mut self, v: &V, out: &mut V) -> bool {
        let nq = v.len() / 2;
        if !self.kick || v.as_slice()[..nq].iter().any(|x| *x != V::Real::zero()) {
            return false;
        }
        out.copy_from(v);
        true
    }
    fn prepare(&mut self, x: &V) {
        if H::ACCOUNTS && self.before.as_ref().is_none_or(|b| b.len() != x.len()) {
            self.before = Some(x.clone());
        }
    }
    /// Held inputs are the embedder's: the checkpoint keeps their values, so a restored run
    /// integrates what the saved one did.
    fn save_memory(&mut self, out: &mut Vec<V::Real>) {
        for s in &self.signals {
            if let Signal::Held(held) = s {
                out.push(V::Real::lit(held.get()));
            }
        }
    }
    fn restore_memory(&mut self, from: &mut &[V::Real]) {
        for s in &self.signals {
            if let Signal::Held(held) = s
                && let [v] = crate::flow::take_memory(from, 1)
            {
                held.set(v.to_f64_lossy());
            }
        }
    }
}
