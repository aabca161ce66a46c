//! The spherical pendulum in Cartesian coordinates: a point mass on a massless rod of length
//! `L` in 3D under gravity.
//!
//! ```text
//! x = (q, p) ∈ R⁶,   H = |p|²/(2m) + m g q_z,   g(q) = (|q|² − L²)/2,   M = [[0, I], [−I, 0]].
//! ```
//!
//! Degenerate case: `⟨g,g⟩ = 0`, hidden constraint `φ = q·p/m = 0` (velocity tangent to the
//! sphere). Its natural scheme is the projected Strang splitting kick–drift–kick, i.e. RATTLE.

use crate::error::SetupError;
use crate::flow::{FnFlow, from_fn};
use crate::real::Real;
use crate::system::{Canonical, Hamiltonian, HolonomicConstraint, System};
use crate::vector::Vector;

/// Mass, rod length and gravitational acceleration (gravity along `−z`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SphericalPendulum<T> {
    /// Mass `m > 0`.
    pub mass: T,
    /// Rod length `L > 0`.
    pub length: T,
    /// Gravitational acceleration `g ≥ 0`, pointing along `−z`.
    pub gravity: T,
}

/// The sphere `|q| = L` as the constraint `g(q) = (|q|² − L²)/2`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sphere<T> {
    /// Radius `L`.
    pub radius: T,
}

impl<T: Real> SphericalPendulum<T> {
    /// A pendulum; [`SetupError::InvalidParameter`] (naming the parameter) unless `mass > 0`,
    /// `length > 0`, `gravity ≥ 0`, all finite.
    pub fn try_new(mass: T, length: T, gravity: T) -> Result<Self, SetupError> {
        super::check_parameters(
            &[("mass", &[mass]), ("length", &[length])],
            &[("gravity", gravity)],
        )?;
        Ok(Self {
            mass,
            length,
            gravity,
        })
    }

    /// The model as a [`System`]: canonical `M`, this Hamiltonian, the sphere constraint.
    pub fn system(&self) -> System<Canonical, Self, Sphere<T>> {
        System::new(
            Canonical,
            *self,
            Sphere {
                radius: self.length,
            },
        )
    }

    /// The exact flow of the potential: `p_z −= h m g`.
    pub fn kick<V: Vector<Real = T>>(&self) -> FnFlow<impl FnMut(T, &mut V) + Clone + use<T, V>> {
        let f = self.mass * self.gravity;
        from_fn(move |h: T, x: &mut V| {
            let x = x.as_mut_slice();
            x[5] = x[5] - h * f;
        })
        .kick()
    }

    /// The exact flow of the kinetic energy: `q += h p / m`.
    pub fn drift<V: Vector<Real = T>>(&self) -> FnFlow<impl FnMut(T, &mut V) + Clone + use<T, V>> {
        let inv_m = T::one() / self.mass;
        from_fn(move |h: T, x: &mut V| {
            let x = x.as_mut_slice();
            let c = h * inv_m;
            for i in 0..3 {
                x[i] = x[i] + c * x[i + 3];
            }
        })
    }

    /// A state on the constraint manifold: polar angle `theta` from the downward vertical,
    /// azimuth `0`, and a horizontal (tangential) velocity `speed` along `+y`.
    pub fn state<V: Vector<Real = T>>(&self, theta: T, speed: T) -> V {
        let mut x = V::zeros(6);
        let s = x.as_mut_slice();
        let (st, ct) = theta.sin_cos();
        s[0] = self.length * st;
        s[1] = T::zero();
        s[2] = -self.length * ct;
        s[3] = T::zero();
        s[4] = self.mass * speed;
        s[5] = T::zero();
        x
    }

    /// The angular momentum about the vertical axis, `q_x p_y − q_y p_x` (conserved).
    pub fn vertical_angular_momentum<V: Vector<Real = T>>(&self, x: &V) -> T {
        let s = x.as_slice();
        s[0] * s[4] - s[1] * s[3]
    }
}

impl<T: Real, V: Vector<Real = T>> Hamiltonian<V> for SphericalPendulum<T> {
    #[inline]
    fn energy(&self, x: &V) -> T {
        let s = x.as_slice();
        let p2 = s[3] * s[3] + s[4] * s[4] + s[5] * s[5];
        p2 / (self.mass + self.mass) + self.mass * self.gravity * s[2]
    }
    #[inline]
    fn gradient(&self, x: &V, out: &mut V) {
        let s = x.as_slice();
        let o = out.as_mut_slice();
        let inv_m = T::one() / self.mass;
        o[0] = T::zero();
        o[1] = T::zero();
        o[2] = self.mass * self.gravity;
        o[3] = s[3] * inv_m;
        o[4] = s[4] * inv_m;
        o[5] = s[5] * inv_m;
    }
}

impl<T: Real, V: Vector<Real = T>> HolonomicConstraint<V> for Sphere<T> {
    fn dim(&self) -> usize {
        1
    }
    #[inline]
    fn residual(&self, x: &V, out: &mut [T]) {
        let s = x.as_slice();
        let r2 = s[0] * s[0] + s[1] * s[1] + s[2] * s[2];
        out[0] = (r2 - self.radius * self.radius) * T::lit(0.5);
    }
    #[inline]
    fn jacobian_apply(&self, x: &V, v: &V, out: &mut [T]) {
        let (s, v) = (x.as_slice(), v.as_slice());
        out[0] = s[0] * v[0] + s[1] * v[1] + s[2] * v[2];
    }
    #[inline]
    fn jacobian_transpose_apply_add(&self, x: &V, mu: &[T], alpha: T, out: &mut V) {
        let s = x.as_slice();
        let o = out.as_mut_slice();
        let c = alpha * mu[0];
        for i in 0..3 {
            o[i] = o[i] + c * s[i];
        }
    }
    /// `Gᵀ μ = μ (q, 0)`, written directly.
    #[inline]
    fn jacobian_transpose_apply(&self, x: &V, mu: &[T], out: &mut V) {
        let s = x.as_slice();
        let o = out.as_mut_slice();
        for i in 0..3 {
            o[i] = mu[0] * s[i];
        }
        for v in &mut o[3..] {
            *v = T::zero();
        }
    }
}

impl<T: Real> Default for SphericalPendulum<T> {
    fn default() -> Self {
        Self {
            mass: T::one(),
            length: T::one(),
            gravity: T::one(),
        }
    }
}
