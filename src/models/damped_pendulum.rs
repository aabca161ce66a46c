//! The damped planar pendulum in Cartesian coordinates: a unit mass on a rod of unit length,
//! gravity 1 along `−y`, viscous friction `c` on the momenta.
//!
//! ```text
//! x = (x, y, u, v),   H = (u² + v²)/2 + y,   g = (x² + y² − 1)/2,
//! M = J − R,   J = [[0, I], [−I, 0]],   R = c · diag(0, 0, 1, 1).
//! ```
//!
//! Degenerate case (`⟨g,g⟩ = 0`) with hidden constraint `φ = x u + y v` (velocity tangent to the
//! circle). Energy decays: `dH/dt = −c (u² + v²)`. In the angle `θ` from the downward vertical
//! (`x = sin θ`, `y = −cos θ`) the motion is `θ'' = −sin θ − c θ'`, which gives an independent
//! reference solution ([`DampedPendulum::reference`]).

use super::paper::Circle;
use crate::error::SetupError;
use crate::flow::LinearFlow;
use crate::real::Real;
use crate::system::{Canonical, Hamiltonian, JMinusR, MomentumDamping, System};
use crate::vector::Vector;

/// The damped pendulum with damping coefficient `c ≥ 0`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DampedPendulum<T> {
    /// The damping coefficient `c ≥ 0`.
    pub damping: T,
}

/// The structure matrix of the damped pendulum, `J − c · diag(0, I)`.
pub type DampedStructure<T> = JMinusR<Canonical, MomentumDamping<T>>;

impl<T: Real> DampedPendulum<T> {
    /// The pendulum with damping `c`; [`SetupError::InvalidParameter`] unless `c` is finite and
    /// `c ≥ 0`.
    pub fn try_new(damping: T) -> Result<Self, SetupError> {
        MomentumDamping::new(damping).map(|_| Self { damping })
    }

    /// The structure matrix `J − R`.
    pub fn structure(&self) -> DampedStructure<T> {
        JMinusR::new(Canonical, MomentumDamping { c: self.damping })
    }

    /// The model as a [`System`] (the constraint is the unit circle in `(x, y)`).
    pub fn system(&self) -> System<DampedStructure<T>, Self, Circle> {
        System::new(self.structure(), *self, Circle)
    }

    /// The exact flow of the unconstrained damped particle under gravity,
    /// `q' = p`, `p' = −c p − e_y`: the affine [`LinearFlow`] of
    /// `A = [[0, I], [0, −c I]]`, `b = (0, 0, 0, −1)`. It is `exp(h D_H)` for `M = J − R`, the
    /// inner flow of a projected scheme; it reports dissipation when `c > 0`.
    pub fn free_flow(&self) -> Result<LinearFlow<T>, SetupError> {
        let c = self.damping;
        let (o, z) = (T::one(), T::zero());
        #[rustfmt::skip]
        let a = [
            z, z, o, z,
            z, z, z, o,
            z, z, -c, z,
            z, z, z, -c,
        ];
        LinearFlow::try_new(4, &a)?.with_forcing(&[z, z, z, -o])
    }

    /// The state at angle `theta` from the downward vertical with angular velocity `omega`:
    /// `(sin θ, −cos θ, ω cos θ, ω sin θ)`, on both the constraint and the hidden constraint.
    pub fn state<V: Vector<Real = T>>(&self, theta: T, omega: T) -> V {
        let mut x = V::zeros(4);
        let (s, c) = theta.sin_cos();
        x.as_mut_slice()
            .copy_from_slice(&[s, -c, omega * c, omega * s]);
        x
    }

    /// The hidden constraint `φ = x u + y v`.
    pub fn hidden_constraint<V: Vector<Real = T>>(&self, x: &V) -> T {
        let s = x.as_slice();
        s[0] * s[2] + s[1] * s[3]
    }

    /// The rounding error of evaluating `H` at `x`, `8 ε ((u² + v²)/2 + |y|)`: energy changes
    /// below it are not resolved.
    pub fn energy_round_off<V: Vector<Real = T>>(&self, x: &V) -> T {
        let s = x.as_slice();
        T::lit(8.0) * T::epsilon() * (T::lit(0.5) * (s[2] * s[2] + s[3] * s[3]) + s[1].abs())
    }
}

impl DampedPendulum<f64> {
    /// The reference solution at time `t` from `(θ₀, ω₀)`: the angle equation
    /// `θ'' = −sin θ − c θ'` integrated by classical Runge–Kutta with steps
    /// `≤ min(dt, 0.5/c)` (error `O(dt⁴)`; the bound keeps the explicit method stable under
    /// stiff damping), mapped to Cartesian `(x, y, u, v)`.
    pub fn reference(&self, theta0: f64, omega0: f64, t: f64, dt: f64) -> [f64; 4] {
        let c = self.damping;
        let f = |th: f64, om: f64| (om, -th.sin() - c * om);
        let dt = if c > 0.0 { dt.min(0.5 / c) } else { dt };
        let n = (t / dt).ceil().max(1.0) as usize;
        let dt = t / n as f64;
        let (mut th, mut om) = (theta0, omega0);
        for _ in 0..n {
            let k1 = f(th, om);
            let k2 = f(th + 0.5 * dt * k1.0, om + 0.5 * dt * k1.1);
            let k3 = f(th + 0.5 * dt * k2.0, om + 0.5 * dt * k2.1);
            let k4 = f(th + dt * k3.0, om + dt * k3.1);
            th += dt / 6.0 * (k1.0 + 2.0 * k2.0 + 2.0 * k3.0 + k4.0);
            om += dt / 6.0 * (k1.1 + 2.0 * k2.1 + 2.0 * k3.1 + k4.1);
        }
        let (s, co) = th.sin_cos();
        [s, -co, om * co, om * s]
    }
}

impl<T: Real, V: Vector<Real = T>> Hamiltonian<V> for DampedPendulum<T> {
    #[inline]
    fn energy(&self, x: &V) -> T {
        let s = x.as_slice();
        T::lit(0.5) * (s[2] * s[2] + s[3] * s[3]) + s[1]
    }
    #[inline]
    fn gradient(&self, x: &V, out: &mut V) {
        let s = x.as_slice();
        out.as_mut_slice()
            .copy_from_slice(&[T::zero(), T::one(), s[2], s[3]]);
    }
    fn is_quadratic(&self) -> bool {
        true
    }
    #[inline]
    fn hessian_apply(&self, _x: &V, v: &V, out: &mut V) -> bool {
        let v = v.as_slice();
        out.as_mut_slice()
            .copy_from_slice(&[T::zero(), T::zero(), v[2], v[3]]);
        true
    }
}
