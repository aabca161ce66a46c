//! The inputs of an open system in the Petrov–Galerkin step: `x' = M (z + Gᵀλ) + B(x) u(t)`.
//!
//! Tested against `v ∈ P_{k−1}`, row (a) gains `∫ ⟨B(x) u(t), v⟩`, by the same `s`-point rule as
//! the other integrals: `acc_i` gains `(1/β_i) Σ_r b_r ℓ_i(e_r) h B(x_r) u(t_n + e_r h)`, added
//! to the step's increments as it stands (not through `M`). With `v = z` the energy identity
//! becomes
//!
//! ```text
//! H(x_{n+1}) − H(x_n) = −h ∫ zᵀRz + S_n,      S_n = h Σ_r b_r z(e_r)ᵀ B(x_r) u(t_r)
//! ```
//!
//! `S_n` the supplied work `∫ yᵀu dt` (`y = Bᵀ∇H`, `z` the L²-projection of `∇H`) by the
//! quadrature, exact to the Newton tolerance as the dissipation is. For a mechanical form with
//! forces on the momenta, `z_p = q'` and `S_n = Σ_r b_r (h q'(e_r))ᵀ (B u)_p(x_r)`: velocity
//! times force. The order `2k` is kept for smooth `u` (the rule has `s ≥ k` points).

use super::Tables;
use crate::flow::forcing::Forcing;
use crate::vector::{Vector, ops};
use num_traits::Zero;

impl<V: Vector> Forcing<V> {
    /// `S_n = Σ_i β_i accz_iᵀ accu_i / h` from the last residual's parts (evaluated at the
    /// solution: the dense solve's last residual is its solution's): `h Σ_r b_r z(e_r)ᵀ
    /// B(x_r) u(t_r)`, since `z(e_r) = Σ_i ℓ_i(e_r) z(c_i)` and `accu_i` is the test sum.
    pub(super) fn supplied(
        &self,
        tables: &Tables<V::Real>,
        accz: &[V],
        accu: &[V],
        h: V::Real,
    ) -> V::Real {
        let mut s = V::Real::zero();
        for ((z, f), &beta) in accz.iter().zip(accu).zip(&tables.beta) {
            s = s + beta * ops::dot(z.as_slice(), f.as_slice());
        }
        s / h
    }

    /// `S_n` of a mechanical form from the unknowns `u` (stage-major `Y_j`, the step's start
    /// `x`): `z_p = q'`, so `S_n = Σ_r b_r (h q'(e_r))ᵀ (B u)_p(x_r)`, velocity times force at
    /// each quadrature point (`x_r` formed again in `xr`: the solve may stop without a
    /// residual at its solution).
    pub(super) fn supplied_mechanical(
        &mut self,
        tables: &Tables<V::Real>,
        x: &V,
        u: &[V::Real],
        nq: usize,
        h: V::Real,
        xr: &mut V,
    ) -> V::Real {
        let (k, n) = (tables.k, x.len());
        let mut s = V::Real::zero();
        for r in 0..tables.s {
            xr.copy_from(x);
            for j in 0..k {
                ops::axpy(
                    xr.as_mut_slice(),
                    tables.a[r * k + j],
                    &u[j * n..(j + 1) * n],
                );
            }
            let force = self.force_at(r, xr);
            let f = &force.as_slice()[nq..n];
            let mut power = V::Real::zero();
            for (d, &fd) in f.iter().enumerate() {
                let dq = (0..k).fold(V::Real::zero(), |acc, j| {
                    acc + tables.ell[r * k + j] * u[j * n + d]
                });
                power = power + dq * fd;
            }
            s = s + tables.b[r] * power;
        }
        s / h
    }
}
