//! Where the Petrov–Galerkin solve stops: the rounding floor of its momentum rows, measured
//! at each step (docs/method.md §5c).

use super::PetrovGalerkin;
use crate::real::Real;
use crate::system::{HolonomicConstraint, Model, StructureMatrix};
use crate::vector::{Vector, ops};
use num_traits::{Float as _, Zero};

impl<V, Sys, W> PetrovGalerkin<V, Sys, W>
where
    V: Vector,
    Sys: Model<V>,
    W: Vector<Real = V::Real>,
{
    /// The rounding floor of the residual's state rows at `x`. The positions of the quadrature
    /// points round by up to an ulp, and the constraint forces `G(q)ᵀL` amplify that by their
    /// curvature `Σ_a L_a ∇²g_a` — on a taut chain the tension over the link length, so that a
    /// row rounds far above `ε` times its own size (a hanging chain of 10⁴ links of 1 g at
    /// `h = 10⁻⁴`: 4e-15 against 1e-21). Measured, not bounded: `½ M (G(x + δ) − G(x − δ))ᵀ L̄`
    /// with `δ_i = ±ε|x_i|/2` (which rounds to one ulp of `x_i`) in a pseudo-random sign pattern
    /// (neighbours in a chain move apart as rounding moves them) and `L̄ = Σ_j β_j L_j` the last
    /// step's multipliers, times the rounding weight of a row. Zero when there are no last
    /// multipliers (the first step, the step after a failure) and when it is not finite.
    pub(super) fn rounding_floor(&mut self, x: &V) -> V::Real {
        let m = self.nu.len();
        let (k, n) = (self.tables.k, x.len());
        if m == 0 {
            return V::Real::zero();
        }
        let u = self.u.as_slice();
        for (a, l) in self.nu.iter_mut().enumerate() {
            *l = (0..k).fold(V::Real::zero(), |acc, j| {
                acc + self.tables.beta[j] * u[k * n + j * m + a]
            });
        }
        if self.nu.iter().all(|l| *l == V::Real::zero()) {
            return V::Real::zero();
        }
        for ((p, q), (&xi, &e)) in self
            .tmp
            .as_mut_slice()
            .iter_mut()
            .zip(self.t2.as_mut_slice())
            .zip(x.as_slice().iter().zip(&self.signs))
        {
            let d = e * xi.abs();
            *p = xi + d;
            *q = xi - d;
        }
        let half = V::Real::lit(0.5);
        ops::fill_zero(self.xe.as_mut_slice());
        let c = self.system.constraint();
        c.jacobian_transpose_apply_add(&self.tmp, &self.nu, half, &mut self.xe);
        c.jacobian_transpose_apply_add(&self.t2, &self.nu, -half, &mut self.xe);
        // Into the residual's rows: the forces enter through `M` (the momentum rows of a
        // mechanical model).
        self.system.structure().apply(x, &self.xe, &mut self.tmp);
        let floor = ops::norm_inf(self.tmp.as_slice()) * self.tables.rounding_weight;
        if floor.is_finite() {
            floor
        } else {
            V::Real::zero()
        }
    }
}

/// `±ε/2` for each of `n` components, the sign by [`scattered_bit`] of the index: a bit of
/// splitmix64's finaliser, signs without the runs a plain multiplicative hash has at the
/// strides of a body-major state (2 and 3). Computed once, at construction.
pub(super) fn rounding_signs<T: Real>(n: usize) -> Vec<T> {
    let eps = T::epsilon() * T::lit(0.5);
    (0..n as u64)
        .map(|i| if scattered_bit(i) { eps } else { -eps })
        .collect()
}

/// Bit 63 of splitmix64's finaliser (Steele, Lea & Flood, OOPSLA 2014) of `i`: a sign pattern
/// with no correlation between nearby indices.
fn scattered_bit(i: u64) -> bool {
    let mut z = i.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    (z ^ (z >> 31)) >> 63 == 1
}
