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
    /// The account on the constraint-consistent momentum, when dashpots join constrained
    /// bodies (`consistent.rs`, set by [`with_account`](Self::with_account)), with scratch for
    /// the consistent state.
    account: Option<Account<T>>,
}

/// The consistent account and its scratch: the state in `f64`, the consistent momentum, and
/// the consistent state the flows run on.
struct Account<T> {
    momentum: Box<dyn ConsistentMomentum>,
    state: Vec<f64>,
    pc: Vec<f64>,
    work: Vec<T>,
}

impl<T> core::fmt::Debug for DashpotFlow<T> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("DashpotFlow")
            .field("consistent_account", &self.account.is_some())
            .finish_non_exhaustive()
    }
}

/// The constraint-consistent part of a momentum, given to the dashpots by the scheme that
/// builds them (so that they do not depend on the constraints' linear algebra).
///
/// Inside a projected step the dashpots act on momenta that cross the constraints by the
/// projection's impulse `p_i = p − p_c` (`O(h)` off the consistent motion `p_c`); the energy
/// their flows take from it, `E(p_i)` (a quadratic form, `E(p) = E(p_c) + 2B(p_c, p_i) +
/// E(p_i)`), is not lost by the state — the projection returns it — and was booked as
/// dissipated: a dashpot to a body held at rest by a rod against a spring booked 0.62 over
/// 100 s at `h = 0.01` though `H` stayed constant. The account books `E(p) − E(p_i)`, clamped
/// at zero: the flows' own account to the scheme's order in motion (the cross term carries the
/// step's second-order symmetry; `E(p_c)` alone is first order when the constraints change the
/// relative velocities' decay rate), and nothing for the impulse alone (see `consistent.rs`,
/// `../shared/docs/METHOD.md` §8).
pub(crate) trait ConsistentMomentum: core::fmt::Debug {
    /// The consistent part of the momentum `p` at positions `q` into `out`; `false` when it
    /// cannot be formed there (then the dashpots keep their own account).
    fn consistent(&mut self, q: &[f64], p: &[f64], out: &mut Vec<f64>) -> bool;
}

impl<T: Real> DashpotFlow<T> {
    /// The dashpots of `model`, or `None` when it has none.
    pub fn new(model: Arc<SceneModel<T>>) -> Option<Self> {
        model.dashpots.as_ref()?;
        Some(Self {
            model,
            last: None,
            account: None,
        })
    }

    /// The same flows booking their dissipation through `account`.
    pub(crate) fn with_account(mut self, account: Box<dyn ConsistentMomentum>) -> Self {
        self.account = Some(Account {
            momentum: account,
            state: Vec::new(),
            pc: Vec::new(),
            work: Vec::new(),
        });
        self
    }

    /// Advances the momenta of `x` by `h`; returns the energy removed (on the consistent
    /// momentum, with an account).
    fn advance(&mut self, h: T, x: &mut [T]) -> T {
        if let Some(dashpots) = &self.model.dashpots {
            dashpots.counter.hit();
        }
        self.last = Some(h);
        // The account's flows on a copy only when the run reads the books.
        let inconsistent = if self.model.books.on() {
            self.inconsistent_removed(h, x)
        } else {
            None
        };
        let removed = self.advance_uncounted(h, x);
        match inconsistent {
            // The flows' own energy less that of the inconsistent part `p − p_c` (see
            // `ConsistentMomentum`): zero at rest, their own account to the scheme's order in
            // motion, never negative.
            Some(phantom) => (removed - phantom).max(T::zero()),
            None => removed,
        }
    }

    /// The energy the same flows would remove from the inconsistent part `p − p_c` of `x`'s
    /// momentum (`None` without an account, or when `p_c` cannot be formed).
    fn inconsistent_removed(&mut self, h: T, x: &[T]) -> Option<T> {
        let Account {
            momentum,
            state,
            pc,
            work,
        } = self.account.as_mut()?;
        let nq = x.len() / 2;
        state.clear();
        state.extend(x.iter().map(|v| v.to_f64_lossy()));
        let (q, p) = state.split_at(nq);
        if !momentum.consistent(q, p, pc) {
            return None;
        }
        work.clear();
        work.extend_from_slice(&x[..nq]);
        work.extend(x[nq..].iter().zip(pc.iter()).map(|(&p, &c)| p - T::lit(c)));
        Some(Self::flows(&self.model, h, work))
    }

    /// [`advance`](Self::advance) without counting an evaluation.
    fn advance_uncounted(&self, h: T, x: &mut [T]) -> T {
        Self::flows(&self.model, h, x)
    }

    /// The dashpots' flows over `h` on the momenta of `x`; returns the energy removed.
    fn flows(model: &SceneModel<T>, h: T, x: &mut [T]) -> T {
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
