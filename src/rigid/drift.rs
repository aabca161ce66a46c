//! The drift of a [`Multibody`](super::Multibody): the exact flow of its kinetic energy,
//! `q_s += h p_s/m_s`, affine in the state, with its tangent map (so that a projection around it
//! forms its multiplier Jacobians in closed form and, the rows being quadratic, solves its `λ_k`
//! system from the exact quadratic model).

use crate::error::StepError;
use crate::flow::{EXACT, Flow};
use crate::real::Real;
use crate::vector::Vector;

/// See the module documentation.
#[derive(Debug, Clone)]
pub struct MultibodyDrift<T> {
    /// The inverse mass of each position.
    inv: Vec<T>,
    /// The last step's length (for the tangent map).
    last: Option<T>,
}

impl<T: Real> MultibodyDrift<T> {
    pub(crate) fn new(inv: Vec<T>) -> Self {
        Self { inv, last: None }
    }

    /// `q += h W p` on `x = (q, p)`.
    fn advance(&self, h: T, x: &mut [T]) {
        let (q, p) = x.split_at_mut(self.inv.len());
        for ((qi, &pi), &w) in q.iter_mut().zip(p.iter()).zip(&self.inv) {
            *qi = *qi + h * w * pi;
        }
    }
}

impl<T: Real, V: Vector<Real = T>> Flow<V> for MultibodyDrift<T> {
    fn step(&mut self, h: T, x: &mut V) -> Result<(), StepError> {
        self.last = Some(h);
        self.advance(h, x.as_mut_slice());
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
    /// The drift is linear in `x`.
    fn lead_is_affine(&self) -> bool {
        true
    }
    fn is_affine_in_momenta(&self) -> bool {
        true
    }
    /// `DΦ v = (v_q + h W v_p, v_p)`: the flow itself, applied to `v`.
    fn tangent_apply(&mut self, v: &V, out: &mut V) -> bool {
        let Some(h) = self.last else {
            return false;
        };
        out.copy_from(v);
        self.advance(h, out.as_mut_slice());
        true
    }
}
