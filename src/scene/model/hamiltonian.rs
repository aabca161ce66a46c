//! The scene's `H = Σ_b |p_b|²/(2 m_b) + V(q)` as a [`Hamiltonian`].

use super::SceneModel;
use crate::real::Real;
use crate::system::Hamiltonian;
use crate::vector::Vector;
use std::sync::Arc;

impl<T: Real> SceneModel<T> {
    /// `Σ_b |p_b|²/(2 m_b)` of the state `x = (q, p)`.
    pub fn kinetic_energy(&self, x: &[T]) -> T {
        let nq = self.dim * self.masses.len();
        let p = &x[nq..];
        let d = self.dim;
        let mut t = T::lit(0.0);
        self.kinetic.hit();
        for (b, w) in self.inv_masses.iter().enumerate() {
            let mut s = T::lit(0.0);
            for k in 0..d {
                s = s + (p[b * d + k] * p[b * d + k]);
            }
            t = t + (T::lit(0.5) * *w * s);
        }
        t
    }
}

impl<T: Real, V: Vector<Real = T>> Hamiltonian<V> for Arc<SceneModel<T>> {
    fn energy(&self, x: &V) -> T {
        let x = x.as_slice();
        let nq = self.dim * self.masses.len();
        self.kinetic_energy(x) + self.potential_energy(&x[..nq])
    }

    /// `H(y) − H(x)` without cancelling the totals: `Σ_b (p'_b − p_b)·(p'_b + p_b)/(2 m_b)`
    /// and each potential term's own difference.
    fn energy_difference(&self, x: &V, y: &V) -> T {
        let (x, y) = (x.as_slice(), y.as_slice());
        let nq = self.dim * self.masses.len();
        let d = self.dim;
        let (p, p2) = (&x[nq..], &y[nq..]);
        let mut t = T::lit(0.0);
        self.kinetic.hit();
        for (b, w) in self.inv_masses.iter().enumerate() {
            let mut s = T::lit(0.0);
            for k in 0..d {
                let i = b * d + k;
                s = s + (p2[i] - p[i]) * (p2[i] + p[i]);
            }
            t = t + (T::lit(0.5) * *w * s);
        }
        t + self.potential_energy_difference(&x[..nq], &y[..nq])
    }

    fn gradient(&self, x: &V, out: &mut V) {
        let x = x.as_slice();
        let nq = self.dim * self.masses.len();
        let (q, p) = x.split_at(nq);
        let out = out.as_mut_slice();
        let (oq, op) = out.split_at_mut(nq);
        oq.fill(T::lit(0.0));
        self.potential_gradient_add(q, T::lit(1.0), oq);
        self.kinetic.hit();
        let d = self.dim;
        for (b, w) in self.inv_masses.iter().enumerate() {
            for k in 0..d {
                op[b * d + k] = *w * p[b * d + k];
            }
        }
    }

    #[inline(always)]
    fn hessian_apply(&self, x: &V, v: &V, out: &mut V) -> bool {
        let nq = self.dim * self.masses.len();
        let q = &x.as_slice()[..nq];
        let v = v.as_slice();
        let out = out.as_mut_slice();
        let (oq, op) = out.split_at_mut(nq);
        oq.fill(T::lit(0.0));
        // ∇²V reads the position part only: a direction that moves momenta alone (every
        // constraint force of a scene) skips it, exactly.
        if v[..nq].iter().any(|&c| c != T::lit(0.0)) {
            self.potential_hessian_apply_add(q, &v[..nq], oq);
        }
        let d = self.dim;
        for (b, w) in self.inv_masses.iter().enumerate() {
            for k in 0..d {
                op[b * d + k] = *w * v[nq + b * d + k];
            }
        }
        true
    }

    fn is_quadratic(&self) -> bool {
        self.potentials.iter().all(|t| t.potential.is_quadratic())
    }

    /// `H = Σ_b |p_b|²/(2 m_b) + V(q)`: each body's inverse mass on its `d` momenta.
    fn kinetic_inverse_mass(&self, w: &mut [T]) -> bool {
        let d = self.dim;
        if w.len() != d * self.inv_masses.len() {
            return false;
        }
        for (b, &inv) in self.inv_masses.iter().enumerate() {
            w[b * d..(b + 1) * d].fill(inv);
        }
        true
    }

    /// The `d × d` blocks of the bodies each potential term couples, and the diagonal of the
    /// momentum block.
    fn hessian_pattern(&self, n: usize, out: &mut Vec<(usize, usize)>) -> bool {
        let d = self.dim;
        let nq = d * self.inv_masses.len();
        if n != 2 * nq {
            return false;
        }
        let mut bodies = Vec::new();
        for term in &self.potentials {
            term.potential.hessian_bodies(&mut bodies);
        }
        bodies.sort_unstable();
        bodies.dedup();
        for (a, b) in bodies {
            for k in 0..d {
                for l in 0..d {
                    out.push((a * d + k, b * d + l));
                }
            }
        }
        out.extend((nq..n).map(|i| (i, i)));
        true
    }
}
