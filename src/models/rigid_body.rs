//! The free rigid body as a Lie–Poisson system on `so(3)*` (GNI §IV.1, §VII.5).
//!
//! ```text
//! y' = y × ∇H(y),    H(y) = ½ (y₁²/I₁ + y₂²/I₂ + y₃²/I₃),    M(y) = ŷ  (LiePoissonSo3)
//! ```
//!
//! `y` is the body angular momentum. Both `H` and the Casimir `C = |y|²` are quadratic, so the
//! implicit midpoint rule conserves both (to round-off).

use crate::error::SetupError;
use crate::real::Real;
use crate::system::{Hamiltonian, LiePoissonSo3};
use crate::vector::Vector;

/// Principal moments of inertia `I₁, I₂, I₃ > 0`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RigidBody<T> {
    /// `[I₁, I₂, I₃]`.
    pub inertia: [T; 3],
}

impl<T: Real> RigidBody<T> {
    /// A rigid body; [`SetupError::InvalidParameter`] (naming the moment) unless every moment
    /// is positive and finite.
    pub fn try_new(inertia: [T; 3]) -> Result<Self, SetupError> {
        super::check_parameters(&[("moment of inertia", &inertia)], &[])?;
        Ok(Self { inertia })
    }

    /// GNI's example: `I = (2, 1, 2/3)`.
    pub fn gni() -> Self {
        Self {
            inertia: [T::lit(2.0), T::one(), T::lit(2.0 / 3.0)],
        }
    }

    /// The structure matrix, `M(y) = ŷ`.
    pub fn structure(&self) -> LiePoissonSo3 {
        LiePoissonSo3
    }

    /// GNI's initial value `y(0) = (cos 1.1, 0, sin 1.1)`.
    pub fn gni_initial_state<V: Vector<Real = T>>() -> V {
        let mut y = V::zeros(3);
        let s = y.as_mut_slice();
        s[0] = T::lit(1.1f64.cos());
        s[2] = T::lit(1.1f64.sin());
        y
    }

    /// The Casimir `C(y) = |y|²`.
    pub fn casimir<V: Vector<Real = T>>(y: &V) -> T {
        y.as_slice().iter().fold(T::zero(), |s, &v| s + v * v)
    }
}

impl<T: Real, V: Vector<Real = T>> Hamiltonian<V> for RigidBody<T> {
    #[inline]
    fn energy(&self, y: &V) -> T {
        let y = y.as_slice();
        (0..3).fold(T::zero(), |s, i| s + y[i] * y[i] / self.inertia[i]) * T::lit(0.5)
    }
    #[inline]
    fn gradient(&self, y: &V, out: &mut V) {
        let (y, o) = (y.as_slice(), out.as_mut_slice());
        for i in 0..3 {
            o[i] = y[i] / self.inertia[i];
        }
    }
    #[inline]
    fn hessian_apply(&self, _y: &V, v: &V, out: &mut V) -> bool {
        let (v, o) = (v.as_slice(), out.as_mut_slice());
        for i in 0..3 {
            o[i] = v[i] / self.inertia[i];
        }
        true
    }
}
