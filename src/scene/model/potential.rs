//! The potential `V(q)`, the sum of the scene's potential terms (each computed by its effect's
//! file): its value, gradient, Hessian product, and its exact flow, the kick
//! `p ← p − t ∇V(q)`.

use super::SceneModel;
use crate::error::StepError;
use crate::flow::{EXACT, Flow};
use crate::real::Real;
use crate::scene::effects::EffectKind;
use crate::vector::Vector;
use std::sync::Arc;

impl<T: Real> SceneModel<T> {
    /// `V(q)`, the sum of the potential terms.
    pub(crate) fn potential_energy(&self, q: &[T]) -> T {
        let d = self.dim;
        let mut v = T::lit(0.0);
        for term in &self.potentials {
            v = v + self.timed(&term.counter, || term.potential.energy(q, d));
        }
        v
    }

    /// `V(q') − V(q)`, term by term.
    pub(crate) fn potential_energy_difference(&self, q: &[T], q2: &[T]) -> T {
        let d = self.dim;
        let mut v = T::lit(0.0);
        for term in &self.potentials {
            v = v + self.timed(&term.counter, || term.potential.energy_difference(q, q2, d));
        }
        v
    }

    /// `out += α ∇V(q)`, `V` the sum of the potential terms (length `d N`: positions only).
    pub fn potential_gradient_add(&self, q: &[T], alpha: T, out: &mut [T]) {
        let d = self.dim;
        for term in &self.potentials {
            self.timed(&term.counter, || {
                term.potential.gradient_add(q, d, alpha, out)
            });
        }
    }

    /// `out += ∇²V(q) v`.
    pub(super) fn potential_hessian_apply_add(&self, q: &[T], v: &[T], out: &mut [T]) {
        let d = self.dim;
        for term in &self.potentials {
            self.timed(&term.counter, || {
                term.potential.hessian_apply_add(q, d, v, out)
            });
        }
    }

    /// The kick `p ← p − t ∇V_kick(q)`: the exact flow of the potential terms together, all
    /// but uniform gravity when the free flight carries it ([`has_kick`](Self::has_kick)).
    /// `scratch` holds `dN` entries.
    pub fn kick(&self, t: T, x: &mut [T], scratch: &mut [T]) {
        let nq = self.dim * self.masses.len();
        let (q, p) = x.split_at_mut(nq);
        scratch.fill(T::lit(0.0));
        self.kick_gradient_add(q, scratch);
        for (pi, gi) in p.iter_mut().zip(scratch.iter()) {
            *pi = *pi - (t * *gi);
        }
    }

    /// [`kick`](Self::kick) with the gradient of the last positions kept in `cache`: a projected
    /// step's half-steps move only momenta (a scene's constraint forces act on `p`), so the
    /// first kick of each Newton iteration, and of the next step, is at positions the last
    /// kick already saw. Kept only when the kick has pair terms (`O(n²)` a gradient); for the
    /// others comparing the positions costs what recomputing does.
    pub fn kick_cached(&self, t: T, x: &mut [T], cache: &mut KickCache<T>) {
        let nq = self.dim * self.masses.len();
        let (q, p) = x.split_at_mut(nq);
        if cache.grad.len() != nq {
            cache.grad = vec![T::lit(0.0); nq];
            cache.q = vec![T::lit(0.0); nq];
            cache.valid = false;
            cache.anchor_valid = false;
            cache.enabled = self.potentials.iter().any(|t| t.kind == EffectKind::Pair);
        }
        let grad = if cache.valid && cache.q.as_slice() == &*q {
            &cache.grad
        } else if cache.anchor_valid && cache.anchor_q.as_slice() == &*q {
            &cache.anchor_grad
        } else {
            cache.grad.fill(T::lit(0.0));
            self.kick_gradient_add(q, &mut cache.grad);
            if cache.enabled {
                cache.q.copy_from_slice(q);
                cache.valid = true;
                if cache.anchor_pending {
                    cache.anchor_q.clone_from(&cache.q);
                    cache.anchor_grad.clone_from(&cache.grad);
                    cache.anchor_valid = true;
                }
            }
            cache.anchor_pending = false;
            &cache.grad
        };
        for (pi, gi) in p.iter_mut().zip(grad.iter()) {
            *pi = *pi - (t * *gi);
        }
    }

    /// `out += ∇V_kick(q)`: the potential terms the kick carries.
    fn kick_gradient_add(&self, q: &[T], out: &mut [T]) {
        let d = self.dim;
        for term in &self.potentials {
            if self.gravity_in_flight && term.is_gravity() {
                continue;
            }
            self.timed(&term.counter, || {
                term.potential.gradient_add(q, d, T::lit(1.0), out)
            });
        }
    }
}

/// The kick's gradient at the last positions it saw ([`SceneModel::kick_cached`]), and at an
/// *anchor*: the first positions it computed after the flow saved its memory
/// ([`Flow::save_memory`]), the point a caller returns to — every row of an extrapolation
/// starts there, so its first kick is computed once a macro step instead of once a row.
#[derive(Debug, Clone, Default)]
pub struct KickCache<T> {
    q: Vec<T>,
    grad: Vec<T>,
    valid: bool,
    enabled: bool,
    anchor_q: Vec<T>,
    anchor_grad: Vec<T>,
    anchor_valid: bool,
    /// The next computed gradient becomes the anchor.
    anchor_pending: bool,
}

/// The kick of a scene's potential terms as a [`Flow`] (see [`SceneModel::kick_cached`]):
/// exact, symmetric, a [kick](Flow::is_kick) (it moves momenta only), with its tangent map on
/// directions that move momenta only (the identity: the force reads positions alone), which
/// are the directions of a scene's constraint forces.
#[derive(Debug)]
pub struct Kick<T: Real> {
    model: Arc<SceneModel<T>>,
    cache: KickCache<T>,
}

impl<T: Real> Kick<T> {
    /// The kick of `model`'s potential terms.
    pub fn new(model: Arc<SceneModel<T>>) -> Self {
        Self {
            model,
            cache: KickCache::default(),
        }
    }
}

impl<T: Real, V: Vector<Real = T>> Flow<V> for Kick<T> {
    #[inline]
    fn step(&mut self, h: T, x: &mut V) -> Result<(), StepError> {
        self.model.kick_cached(h, x.as_mut_slice(), &mut self.cache);
        Ok(())
    }
    /// Nothing to save (the cache is exact, not memory); the next gradient computed becomes
    /// the cache's anchor, for the return to this point (see [`KickCache`]).
    fn save_memory(&mut self, _out: &mut Vec<T>) {
        self.cache.anchor_pending = true;
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
    fn is_kick(&self) -> bool {
        true
    }
    /// The increment `−t ∇V(q)` depends on the positions alone.
    fn is_affine_in_momenta(&self) -> bool {
        true
    }
    /// `DΦ v = v − t (0, ∇²V v_q)`: the identity for `v` with no position part; `false` for
    /// any other `v` (the Hessian is not formed here).
    fn tangent_apply(&mut self, v: &V, out: &mut V) -> bool {
        let nq = self.model.dim * self.model.masses.len();
        if v.as_slice()[..nq].iter().any(|&c| c != T::lit(0.0)) {
            return false;
        }
        out.copy_from(v);
        true
    }
}
