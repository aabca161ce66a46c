//! The kick of a [`Multibody`](super::Multibody): the exact flow of its potential (gravity on
//! the centres, springs on joint angles) at frozen positions, `p −= h ∇V(q)`, and, with joint
//! dampers, their exact consistent flows around it, `D(h/2) ∘ K(h) ∘ D(h/2)` (symmetric, order
//! 2), booking the energy they remove in the [`Ledger`].

use super::elements::{DamperScratch, JointDamper, JointSpring};
use super::rows::QuadraticRows;
use crate::error::StepError;
use crate::flow::{EXACT, Flow, Ledger};
use crate::real::Real;
use crate::vector::Vector;

/// See the module documentation.
#[derive(Debug, Clone)]
pub struct MultibodyKick<T> {
    /// `−∂V_gravity/∂q` (constant).
    force: Vec<T>,
    springs: Vec<JointSpring>,
    dampers: Vec<JointDamper>,
    rows: QuadraticRows<T>,
    inv: Vec<T>,
    grad: Vec<T>,
    scratch: DamperScratch<T>,
}

impl<T: Real> MultibodyKick<T> {
    pub(crate) fn new(
        force: Vec<T>,
        springs: Vec<JointSpring>,
        dampers: Vec<JointDamper>,
        rows: QuadraticRows<T>,
        inv: Vec<T>,
    ) -> Self {
        Self {
            grad: vec![T::zero(); force.len()],
            force,
            springs,
            dampers,
            rows,
            inv,
            scratch: DamperScratch::default(),
        }
    }

    /// The potential's kick over `h`.
    fn potential(&mut self, h: T, x: &mut [T]) {
        let n = self.force.len();
        let (q, p) = x.split_at_mut(n);
        for (pi, &f) in p.iter_mut().zip(&self.force) {
            *pi = *pi + h * f;
        }
        if self.springs.is_empty() {
            return;
        }
        self.grad.iter_mut().for_each(|g| *g = T::zero());
        for s in &self.springs {
            let stretch = s.angle.value(q) - T::lit(s.rest);
            s.angle
                .gradient_add(q, T::lit(s.stiffness) * stretch, &mut self.grad);
        }
        for (pi, &g) in p.iter_mut().zip(&self.grad) {
            *pi = *pi - h * g;
        }
    }

    /// The dampers' flows over `tau`, in order then back (symmetric); returns the energy removed.
    fn dampers(&mut self, tau: T, x: &mut [T]) -> T {
        let n = self.force.len();
        let (q, p) = x.split_at_mut(n);
        let k = self.dampers.len();
        let mut removed = T::zero();
        if k == 1 {
            return self.dampers[0].flow(q, p, tau, &self.rows, &self.inv, &mut self.scratch);
        }
        let half = T::lit(0.5) * tau;
        for i in (0..k).chain((0..k).rev()) {
            removed = removed
                + self.dampers[i].flow(q, p, half, &self.rows, &self.inv, &mut self.scratch);
        }
        removed
    }
}

impl<T: Real, V: Vector<Real = T>> Flow<V> for MultibodyKick<T> {
    fn step(&mut self, h: T, x: &mut V) -> Result<(), StepError> {
        self.step_at(&mut Ledger::default(), h, x)
    }
    fn step_at(&mut self, ledger: &mut Ledger<T>, h: T, x: &mut V) -> Result<(), StepError> {
        let x = x.as_mut_slice();
        if self.dampers.is_empty() {
            self.potential(h, x);
            return Ok(());
        }
        let half = T::lit(0.5) * h;
        let mut removed = self.dampers(half, x);
        self.potential(h, x);
        removed = removed + self.dampers(half, x);
        ledger.dissipated = ledger.dissipated + removed;
        Ok(())
    }
    fn order(&self) -> u32 {
        if self.dampers.is_empty() { EXACT } else { 2 }
    }
    fn is_symmetric(&self) -> bool {
        true
    }
    fn is_fallible(&self) -> bool {
        false
    }
    fn dissipates(&self) -> bool {
        !self.dampers.is_empty()
    }
    /// It moves momenta only.
    fn is_kick(&self) -> bool {
        true
    }
    /// At frozen positions the potential's kick adds a constant and the dampers' flows are
    /// linear in the momenta.
    fn is_affine_in_momenta(&self) -> bool {
        true
    }
    /// `DΦ v = v` for `v` without a position part, without dampers (whose flows would act on
    /// it); `false` otherwise (the potential's Hessian is not formed here).
    fn tangent_apply(&mut self, v: &V, out: &mut V) -> bool {
        let n = self.force.len();
        if !self.dampers.is_empty() || v.as_slice()[..n].iter().any(|&c| c != T::zero()) {
            return false;
        }
        out.copy_from(v);
        true
    }
}
