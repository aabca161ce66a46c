//! Dampers on joints' coordinates — a hinge's angle (the torque `−c θ'` between two rigid bodies
//! about their common axis) or a slider's displacement (the force `−c d'` along its axis) — and
//! their exact flow along the constraint-consistent direction
//! (`../shared/docs/METHOD.md` §8, "the trap"; the library's `rigid::JointDamper`).
//!
//! The rate is `θ' = wᵀW⁻¹p` with `w = ∇θ(q)`. Along `w` itself the damper's force fights the
//! constraints wherever `w` has a part the joints forbid: the step drops to order 1 and part of
//! the energy it takes vanishes unbooked inside the projection. Along
//!
//! ```text
//! w̃ = w − Gᵀ S⁻¹ G W⁻¹ w,     S = G W⁻¹ Gᵀ
//! ```
//!
//! (`W⁻¹`-orthogonal to every constraint force: the consistent part of `w`, formed as the
//! dashpots' consistent momentum is) the frozen-position flow is exact and forward: with
//! `a = w̃ᵀW⁻¹w̃` and `u = w̃ᵀW⁻¹p`, `u' = −c a u`, so
//!
//! ```text
//! p ← p − (1 − e^{−c a τ}) (u/a) w̃,     removed ½ (u²/a)(1 − e^{−2 c a τ}).
//! ```
//!
//! A projection's impulse `Gᵀλ` has no part along `w̃`, so nothing is booked for it. Several
//! dampers run one after another over `τ/2` and back (symmetric, order 2), joined to the kick
//! of the splitting as the dashpots are. The consistent direction is formed in `f64` with the
//! scene's Gram matrix; a constrained scene in another scalar (a double-double reference run)
//! is refused rather than run along `w`.

use super::SceneModel;
use super::dashpot::ConsistentMomentum;
use crate::error::StepError;
use crate::flow::{Flow, Ledger};
use crate::real::Real;
use crate::rigid::{Coordinate, JointCoordinate};
use crate::scene::counter::Counter;
use crate::vector::Vector;
use std::sync::Arc;

/// The hinge and slider dampers of a scene: `(coordinate, c)` each, and the label and counter
/// of the term.
#[derive(Debug)]
pub(crate) struct HingeDampers<T> {
    pub(crate) label: String,
    pub(crate) dampers: Vec<(Coordinate, T)>,
    pub(crate) counter: Counter,
}

impl<T> HingeDampers<T> {
    /// The effect kind in summaries: `hinge-damper`, `slider-damper`, or `joint-damper` for both.
    pub(crate) fn kind(&self) -> &'static str {
        let kind = |c: &Coordinate| match c {
            Coordinate::Angle(_) => "hinge-damper",
            Coordinate::Displacement(_) => "slider-damper",
            Coordinate::Distance(_) => "line-damper",
        };
        let first = self
            .dampers
            .first()
            .map_or("hinge-damper", |(c, _)| kind(c));
        if self.dampers.iter().all(|(c, _)| kind(c) == first) {
            first
        } else {
            "joint-damper"
        }
    }
}

impl<T: Real> HingeDampers<T> {
    /// The power `Σ c θ'²` at the state `(q, p)` (inverse masses `w`, one per slot).
    pub(crate) fn power(&self, w: &[T], q: &[T], p: &[T]) -> T {
        self.dampers.iter().fold(T::zero(), |s, (angle, c)| {
            let rate = angle.rate(q, p, w);
            s + *c * rate * rate
        })
    }
}

/// The exact flows of a scene's hinge dampers in a symmetric sequence (see the module docs).
pub struct HingeDamperFlow<T> {
    model: Arc<SceneModel<T>>,
    /// The constraint-consistent part of a direction (`None`: unconstrained, or not `f64`).
    consistent: Option<Box<dyn ConsistentMomentum>>,
    /// Scratch: the positions in `f64`, `w`, `w̃`.
    q: Vec<f64>,
    w: Vec<f64>,
    wc: Vec<f64>,
    /// The last step's `h` (its positions are `q`).
    last: Option<T>,
}

impl<T> core::fmt::Debug for HingeDamperFlow<T> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("HingeDamperFlow")
            .field("consistent", &self.consistent.is_some())
            .finish_non_exhaustive()
    }
}

impl<T: Real> HingeDamperFlow<T> {
    /// The hinge dampers of `model`, or `None` when it has none.
    pub fn new(model: Arc<SceneModel<T>>) -> Option<Self> {
        model.hinge_dampers.as_ref()?;
        let consistent = super::consistent::consistent_projector(&model);
        Some(Self {
            model,
            consistent,
            q: Vec::new(),
            w: Vec::new(),
            wc: Vec::new(),
            last: None,
        })
    }

    /// `true` when the flow acts along the constraint-consistent direction (or the scene has no
    /// constraint): `false` for a constrained scene in another scalar than `f64`, whose flow
    /// would act along `∇θ` at order 1 — the scheme refuses it.
    pub fn is_consistent(&self) -> bool {
        self.model.m == 0 || self.consistent.is_some()
    }

    /// The flow of damper `i` over `tau` on the momenta of `x`; returns the energy removed.
    fn flow_one(&mut self, i: usize, tau: T, x: &mut [T]) -> T {
        let model = &*self.model;
        let Some(dampers) = &model.hinge_dampers else {
            return T::zero();
        };
        let (angle, c) = &dampers.dampers[i];
        let nq = x.len() / 2;
        let (inv, d) = (&model.inv_masses, model.dim);
        self.w.clear();
        self.w.resize(nq, 0.0);
        angle.gradient_add(&self.q, 1.0, &mut self.w);
        let consistent = match self.consistent.as_mut() {
            Some(projector) => projector.consistent(&self.q, &self.w, &mut self.wc),
            None => false,
        };
        let direction = if consistent { &self.wc } else { &self.w };
        let p = &mut x[nq..];
        let (mut u, mut a) = (T::zero(), T::zero());
        for (j, &wj) in direction.iter().enumerate() {
            let wj = T::lit(wj);
            u = u + wj * inv[j / d] * p[j];
            a = a + wj * inv[j / d] * wj;
        }
        if a <= T::zero() {
            return T::zero();
        }
        let decay = -(-*c * a * tau).exp_m1();
        let decay2 = -(T::lit(-2.0) * *c * a * tau).exp_m1();
        let k = decay * u / a;
        for (pj, &wj) in p.iter_mut().zip(direction.iter()) {
            *pj = *pj - k * T::lit(wj);
        }
        T::lit(0.5) * u * u / a * decay2
    }

    /// Advances the momenta of `x` by `h`; returns the energy removed.
    fn advance(&mut self, h: T, x: &mut [T]) -> T {
        let n = match &self.model.hinge_dampers {
            Some(d) => {
                d.counter.hit();
                d.dampers.len()
            }
            None => return T::zero(),
        };
        let nq = x.len() / 2;
        self.q.clear();
        self.q.extend(x[..nq].iter().map(|v| v.to_f64_lossy()));
        self.last = Some(h);
        self.sequence(n, h, x)
    }

    /// The dampers' flows over `h` on the momenta of `x`, at the positions `q` (one, or all
    /// over `h/2` and back); returns the energy removed.
    fn sequence(&mut self, n: usize, h: T, x: &mut [T]) -> T {
        if n == 1 {
            return self.flow_one(0, h, x);
        }
        let half = T::lit(0.5) * h;
        let mut removed = T::zero();
        for i in (0..n).chain((0..n).rev()) {
            removed = removed + self.flow_one(i, half, x);
        }
        removed
    }
}

impl<T: Real, V: Vector<Real = T>> Flow<V> for HingeDamperFlow<T> {
    fn step(&mut self, h: T, x: &mut V) -> Result<(), StepError> {
        self.advance(h, x.as_mut_slice());
        Ok(())
    }
    fn step_at(&mut self, ledger: &mut Ledger<T>, h: T, x: &mut V) -> Result<(), StepError> {
        let removed = self.advance(h, x.as_mut_slice());
        ledger.dissipated = ledger.dissipated + removed;
        Ok(())
    }
    /// Each damper's flow is exact; several in sequence are a symmetric composition.
    fn order(&self) -> u32 {
        match &self.model.hinge_dampers {
            Some(d) if d.dampers.len() > 1 => 2,
            _ => crate::flow::EXACT,
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
    /// The dampers move momenta only.
    fn is_kick(&self) -> bool {
        true
    }
    /// For a change of the momenta alone (`v`'s positions zero): the flow is linear in the
    /// momenta, so `DΦ v` is the last step's flow (its directions at its positions) applied to
    /// `v`. A change of the positions turns the directions, which is not formed: `false`.
    fn tangent_apply(&mut self, v: &V, out: &mut V) -> bool {
        let (Some(h), Some(d)) = (self.last, &self.model.hinge_dampers) else {
            return false;
        };
        let n = d.dampers.len();
        let nq = v.len() / 2;
        if v.as_slice()[..nq].iter().any(|x| *x != T::zero()) {
            return false;
        }
        out.copy_from(v);
        self.sequence(n, h, out.as_mut_slice());
        true
    }
}
