//! Dashpots between bodies: their term of `R` (`c (e_a − e_b)(e_a − e_b)ᵀ ⊗ I` on the
//! momenta), its power, and its exact flow.
//!
//! The flow of `x' = −R_dashpot ∇T` keeps the positions and damps each dashpot's relative
//! velocity `u = v_a − v_b`: with the reduced mass `μ = m_a m_b/(m_a + m_b)` and `γ = c/μ`,
//!
//! ```text
//! u(t) = e^{−γt} u,   p_a(t) = p_a − (1 − e^{−γt}) μ u,   p_b(t) = p_b + (1 − e^{−γt}) μ u,
//! ```
//!
//! the total momentum `p_a + p_b` is kept, and the kinetic energy falls by exactly
//! `μ |u|² (1 − e^{−2γt})/2`, which the flow books as dissipated. Dashpots that share a body do
//! not commute: [`DashpotFlow`] takes them one after another over `h/2` and back in reverse
//! order over `h/2`, a symmetric composition (order 2, each factor exact), joined to the kick
//! of the splitting (`D(h/2) ∘ K(h) ∘ D(h/2)` in place of the kick `K`).

use super::SceneModel;
use crate::error::StepError;
use crate::flow::{EXACT, Flow, Ledger};
use crate::real::Real;
use crate::scene::counter::Counter;
use crate::vector::Vector;
use std::sync::Arc;

/// The dashpots of a scene: `(a, b, c)` each, and the label and counter of the term.
#[derive(Debug)]
pub(crate) struct Dashpots<T> {
    pub(crate) label: String,
    pub(crate) pairs: Vec<(usize, usize, T)>,
    pub(crate) counter: Counter,
}

impl<T: Real> Dashpots<T> {
    /// `op −= α c (vp_a − vp_b)`, `op_b += α c (vp_a − vp_b)` per dashpot (`vp` the velocity
    /// part `∇_p H` of the vector `M` is applied to).
    #[inline]
    pub(crate) fn apply_add(&self, vp: &[T], alpha: T, op: &mut [T], d: usize) {
        self.counter.hit();
        for &(a, b, c) in &self.pairs {
            for k in 0..d {
                let f = alpha * c * (vp[a * d + k] - vp[b * d + k]);
                op[a * d + k] = op[a * d + k] - f;
                op[b * d + k] = op[b * d + k] + f;
            }
        }
    }

    /// The power `Σ c |v_a − v_b|²` at momenta `p` (inverse masses `w`).
    pub(crate) fn power(&self, w: &[T], p: &[T], d: usize) -> T {
        let mut power = T::zero();
        for &(a, b, c) in &self.pairs {
            for k in 0..d {
                let u = w[a] * p[a * d + k] - w[b] * p[b * d + k];
                power = power + c * u * u;
            }
        }
        power
    }

    /// The exact flow of dashpot `i` over `t` on the momenta `p`; returns the energy it removed.
    #[inline]
    fn flow_one(&self, i: usize, t: T, w: &[T], p: &mut [T], d: usize) -> T {
        let (a, b, c) = self.pairs[i];
        let mu = T::one() / (w[a] + w[b]);
        let gamma = c / mu;
        // 1 − e^{−γt} and 1 − e^{−2γt} without cancellation for small γt.
        let decay = -(-gamma * t).exp_m1();
        let decay2 = -(T::lit(-2.0) * gamma * t).exp_m1();
        let mut u2 = T::zero();
        for k in 0..d {
            let u = w[a] * p[a * d + k] - w[b] * p[b * d + k];
            u2 = u2 + u * u;
            let dp = decay * mu * u;
            p[a * d + k] = p[a * d + k] - dp;
            p[b * d + k] = p[b * d + k] + dp;
        }
        T::lit(0.5) * mu * u2 * decay2
    }
}

/// The exact flows of a scene's dashpots in a symmetric sequence (see the module docs).
pub struct DashpotFlow<T> {
    model: Arc<SceneModel<T>>,
    /// The length of the last step (for its tangent map).
    last: Option<T>,
}

impl<T: Copy> Clone for DashpotFlow<T> {
    fn clone(&self) -> Self {
        Self {
            model: self.model.clone(),
            last: self.last,
        }
    }
}

impl<T: Real> DashpotFlow<T> {
    /// The dashpots of `model`, or `None` when it has none.
    pub fn new(model: Arc<SceneModel<T>>) -> Option<Self> {
        model.dashpots.as_ref()?;
        Some(Self { model, last: None })
    }

    /// Advances the momenta of `x` by `h`; returns the energy removed.
    fn advance(&mut self, h: T, x: &mut [T]) -> T {
        if let Some(dashpots) = &self.model.dashpots {
            dashpots.counter.hit();
        }
        self.last = Some(h);
        self.advance_uncounted(h, x)
    }

    /// [`advance`](Self::advance) without counting an evaluation.
    fn advance_uncounted(&self, h: T, x: &mut [T]) -> T {
        let model = &*self.model;
        let Some(dashpots) = &model.dashpots else {
            return T::zero();
        };
        let d = model.dim;
        let nq = x.len() / 2;
        let p = &mut x[nq..];
        let w = &model.inv_masses;
        let n = dashpots.pairs.len();
        if n == 1 {
            return dashpots.flow_one(0, h, w, p, d);
        }
        let half = T::lit(0.5) * h;
        let mut removed = T::zero();
        for i in (0..n).chain((0..n).rev()) {
            removed = removed + dashpots.flow_one(i, half, w, p, d);
        }
        removed
    }
}

impl<T: Real, V: Vector<Real = T>> Flow<V> for DashpotFlow<T> {
    fn step(&mut self, h: T, x: &mut V) -> Result<(), StepError> {
        self.advance(h, x.as_mut_slice());
        Ok(())
    }
    fn step_at(&mut self, ledger: &mut Ledger<T>, h: T, x: &mut V) -> Result<(), StepError> {
        let removed = self.advance(h, x.as_mut_slice());
        ledger.dissipated = ledger.dissipated + removed;
        Ok(())
    }
    fn order(&self) -> u32 {
        if self
            .model
            .dashpots
            .as_ref()
            .is_some_and(|t| t.pairs.len() > 1)
        {
            2
        } else {
            EXACT
        }
    }
    fn is_symmetric(&self) -> bool {
        true
    }
    fn is_fallible(&self) -> bool {
        false
    }
    fn dissipates(&self) -> bool {
        true
    }
    /// Dashpots move momenta only.
    fn is_kick(&self) -> bool {
        true
    }
    /// The flow is linear in the momenta and does not read the positions: `DΦ v` is the flow
    /// of `v` itself (its energy account aside).
    fn tangent_apply(&mut self, v: &V, out: &mut V) -> bool {
        let Some(h) = self.last else {
            return false;
        };
        out.copy_from(v);
        self.advance_uncounted(h, out.as_mut_slice());
        true
    }
}
