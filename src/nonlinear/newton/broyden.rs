//! Broyden's secant update of [`Newton`]'s kept Jacobian (its diagonal for independent
//! unknowns, its slope for one).

use super::Newton;
use crate::error::NewtonError;
use crate::linalg::LinearSolver;
use crate::vector::Vector;
use num_traits::{Float as _, One, Zero};

impl<V: Vector, L: LinearSolver<V::Real>> Newton<V, L> {
    /// Broyden's rank-one secant update `J += F(z_new) Δzᵀ / (Δzᵀ Δz)` (the "good" update,
    /// simplified because `J Δz = −F(z_old)`), then refactors. Broyden, Math. Comp. 19 (1965).
    /// `ratio = s₀/s` converts the update to the scale the Jacobian is kept at.
    pub(super) fn broyden_update<E>(&mut self, ratio: V::Real) -> Result<(), NewtonError<E>> {
        let k = self.k;
        if !self.diagonal.is_empty() {
            // Independent unknowns: the secant slope of each, as for one unknown below (the
            // rank-one update restricted to the diagonal pattern, which keeps it diagonal).
            self.lin.clear();
            for (i, d) in self.diagonal.iter_mut().enumerate() {
                let dz = self.dz.as_slice()[i];
                if dz != V::Real::zero() {
                    *d = *d + ratio * self.f.as_slice()[i] / dz;
                }
                if !d.is_finite() || *d == V::Real::zero() {
                    self.have_jacobian = false;
                    return Ok(());
                }
                self.lin.add(i, i, *d);
            }
            if self.lin.factor().is_err() {
                self.have_jacobian = false;
            }
            return Ok(());
        }
        if k == 1 {
            // The secant slope: J += ratio f / Δz.
            let j = self.j11 + ratio * self.f.as_slice()[0] / self.dz.as_slice()[0];
            if j.is_finite() && j != V::Real::zero() {
                self.j11 = j;
            } else {
                self.have_jacobian = false;
            }
            return Ok(());
        }
        let dz = &self.dz.as_slice()[..k];
        let denom = dz.iter().fold(V::Real::zero(), |s, &d| s + d * d);
        if denom.is_nan() || denom <= V::Real::zero() {
            return Ok(());
        }
        let f = &self.f.as_slice()[..k];
        for (j, &dzj) in dz.iter().enumerate() {
            let c = ratio * dzj / denom;
            let Some(col) = self.lin.column_mut(j) else {
                return Ok(());
            };
            for (i, (a, &fi)) in col.iter_mut().zip(f).enumerate() {
                let s = self.row_scale.get(i).copied().unwrap_or_else(V::Real::one);
                *a = *a + s * fi * c;
            }
        }
        if self.lin.factor().is_err() {
            // The secant matrix went singular: rebuild by differences next iteration.
            self.have_jacobian = false;
        }
        Ok(())
    }
}
