//! The Hamiltonian of a [`Multibody`](super::Multibody): kinetic energy on the slots' constant
//! diagonal mass, gravity on the centres, springs on joint angles.

use super::elements::JointSpring;
use crate::real::Real;
use crate::system::Hamiltonian;
use crate::vector::Vector;

/// `H = Σ_s |p_s|²/(2 m_s) + Σ_s w_s·q_s` (`w_s = −m g` on the centres and point masses).
#[derive(Debug, Clone, PartialEq)]
pub struct MultibodyEnergy<T> {
    /// Positions per slot: 3, or 2 in a planar model.
    pub(crate) dim: usize,
    pub(crate) inv_masses: Vec<T>,
    pub(crate) weights: Vec<[T; 3]>,
    pub(crate) springs: Vec<JointSpring>,
}

impl<T: Real, V: Vector<Real = T>> Hamiltonian<V> for MultibodyEnergy<T> {
    fn energy(&self, x: &V) -> T {
        let (d, n) = (self.dim, self.dim * self.inv_masses.len());
        let (q, p) = x.as_slice().split_at(n);
        let mut e = T::zero();
        for (s, (&w, g)) in self.inv_masses.iter().zip(&self.weights).enumerate() {
            for k in 0..d {
                e = e + T::lit(0.5) * w * p[d * s + k] * p[d * s + k] + g[k] * q[d * s + k];
            }
        }
        for s in &self.springs {
            let stretch = s.angle.value(q) - T::lit(s.rest);
            e = e + T::lit(0.5 * s.stiffness) * stretch * stretch;
        }
        e
    }
    fn gradient(&self, x: &V, out: &mut V) {
        let (d, n) = (self.dim, self.dim * self.inv_masses.len());
        let p = &x.as_slice()[n..];
        let (oq, op) = out.as_mut_slice().split_at_mut(n);
        for (s, (&w, g)) in self.inv_masses.iter().zip(&self.weights).enumerate() {
            for k in 0..d {
                oq[d * s + k] = g[k];
                op[d * s + k] = w * p[d * s + k];
            }
        }
        let q = &x.as_slice()[..n];
        for s in &self.springs {
            let stretch = s.angle.value(q) - T::lit(s.rest);
            s.angle.gradient_add(
                q,
                T::lit(s.stiffness) * stretch,
                &mut out.as_mut_slice()[..n],
            );
        }
    }
    fn is_quadratic(&self) -> bool {
        self.springs.is_empty()
    }
    /// The mechanical form: `½ Σ w p²` with the slots' inverse masses (`dim` per slot), and a
    /// linear potential — so the implicit schemes eliminate the momenta.
    fn kinetic_inverse_mass(&self, w: &mut [T]) -> bool {
        let d = self.dim;
        for (s, &wi) in self.inv_masses.iter().enumerate() {
            w[d * s..d * s + d].fill(wi);
        }
        true
    }
    /// `∇²H = diag(0, M⁻¹)` without springs (differences with them).
    fn hessian_apply(&self, _x: &V, v: &V, out: &mut V) -> bool {
        if !self.springs.is_empty() {
            return false;
        }
        let (d, n) = (self.dim, self.dim * self.inv_masses.len());
        let vp = &v.as_slice()[n..];
        let (oq, op) = out.as_mut_slice().split_at_mut(n);
        oq.iter_mut().for_each(|o| *o = T::zero());
        for (s, &w) in self.inv_masses.iter().enumerate() {
            for k in 0..d {
                op[d * s + k] = w * vp[d * s + k];
            }
        }
        true
    }
}
