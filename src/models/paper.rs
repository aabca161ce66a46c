//! The numerical example of Zhang & Deng (2004, §4).
//!
//! ```text
//! x ∈ R⁴,   H = (x₃² + x₄²)/2,   g = (x₁² + x₂² − 1)/2,
//! M = [[ 0, 0, 1, 0],
//!      [ 0, 0, 0, 1],
//!      [−1, 0, 0, 0],
//!      [ 0,−2, 0, 0]],     x(0) = (1, 0, 0, −0.15),  h = 0.1.
//! ```
//!
//! `exp(h D_H)` is the drift `x₁ += h x₃, x₂ += h x₄`; `M Gᵀ = (0, 0, −x₁, −2x₂)` moves only
//! `x₃, x₄`; `⟨g,g⟩ = 0`, so this is the degenerate case with hidden constraint
//! `φ = x₁x₃ + x₂x₄`. `H` is not conserved (the symmetric part of `M` is indefinite), but
//! `H̃ = (x₃² + x₄²/2)/2` is: in `x₂ → x₂/√2, x₄ → x₄/√2` the system is a free particle on an ellipse.

use crate::flow::{FnFlow, from_fn};
use crate::real::Real;
use crate::system::{
    Hamiltonian, HolonomicConstraint, ModifiedHamiltonian, StructureMatrix, System,
};
use crate::vector::Vector;

/// The paper's constant structure matrix (applied without storing it).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Structure;

/// `H = (x₃² + x₄²)/2`.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Energy;

/// `g = (x₁² + x₂² − 1)/2`, the unit circle in `(x₁, x₂)`.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Circle;

impl<V: Vector> StructureMatrix<V> for Structure {
    #[inline(always)]
    fn apply_add(&self, _x: &V, v: &V, alpha: V::Real, out: &mut V) {
        let v = v.as_slice();
        let o = out.as_mut_slice();
        let two = V::Real::lit(2.0);
        o[0] = o[0] + alpha * v[2];
        o[1] = o[1] + alpha * v[3];
        o[2] = o[2] - alpha * v[0];
        o[3] = o[3] - alpha * two * v[1];
    }
    /// `out = M v = (v₃, v₄, −v₁, −2v₂)`, written directly.
    #[inline(always)]
    fn apply(&self, _x: &V, v: &V, out: &mut V) {
        let v = v.as_slice();
        let o = out.as_mut_slice();
        o[0] = v[2];
        o[1] = v[3];
        o[2] = -v[0];
        o[3] = -(V::Real::lit(2.0) * v[1]);
    }
    fn is_constant(&self) -> bool {
        true
    }
}

impl<V: Vector> Hamiltonian<V> for Energy {
    #[inline(always)]
    fn energy(&self, x: &V) -> V::Real {
        let x = x.as_slice();
        (x[2] * x[2] + x[3] * x[3]) * V::Real::lit(0.5)
    }
    #[inline(always)]
    fn gradient(&self, x: &V, out: &mut V) {
        let x = x.as_slice();
        let o = out.as_mut_slice();
        o[0] = V::Real::zero();
        o[1] = V::Real::zero();
        o[2] = x[2];
        o[3] = x[3];
    }
    fn is_quadratic(&self) -> bool {
        true
    }
    /// `∇²H = diag(0, 0, 1, 1)`.
    #[inline(always)]
    fn hessian_apply(&self, _x: &V, v: &V, out: &mut V) -> bool {
        let v = v.as_slice();
        let o = out.as_mut_slice();
        o[0] = V::Real::zero();
        o[1] = V::Real::zero();
        o[2] = v[2];
        o[3] = v[3];
        true
    }
}

impl<V: Vector> HolonomicConstraint<V> for Circle {
    fn dim(&self) -> usize {
        1
    }
    #[inline(always)]
    fn residual(&self, x: &V, out: &mut [V::Real]) {
        let x = x.as_slice();
        out[0] = (x[0] * x[0] + x[1] * x[1] - V::Real::one()) * V::Real::lit(0.5);
    }
    #[inline(always)]
    fn jacobian_apply(&self, x: &V, v: &V, out: &mut [V::Real]) {
        let (x, v) = (x.as_slice(), v.as_slice());
        out[0] = x[0] * v[0] + x[1] * v[1];
    }
    #[inline(always)]
    fn jacobian_transpose_apply_add(&self, x: &V, mu: &[V::Real], alpha: V::Real, out: &mut V) {
        let x = x.as_slice();
        let o = out.as_mut_slice();
        o[0] = o[0] + alpha * mu[0] * x[0];
        o[1] = o[1] + alpha * mu[0] * x[1];
    }
    /// `g = (x₁² + x₂² − 1)/2` is quadratic: `uᵀ∇²g v = u₁v₁ + u₂v₂`.
    #[inline(always)]
    fn hessian_form(&self, _x: &V, u: &V, v: &V, out: &mut [V::Real]) -> bool {
        let (u, v) = (u.as_slice(), v.as_slice());
        out[0] = u[0] * v[0] + u[1] * v[1];
        true
    }
    /// `out = Gᵀ μ = μ (x₁, x₂, 0, 0)`, written directly.
    #[inline(always)]
    fn jacobian_transpose_apply(&self, x: &V, mu: &[V::Real], out: &mut V) {
        let x = x.as_slice();
        let o = out.as_mut_slice();
        o[0] = mu[0] * x[0];
        o[1] = mu[0] * x[1];
        o[2] = V::Real::zero();
        o[3] = V::Real::zero();
    }
}

use num_traits::{One, Zero};

/// The paper's system: `M`, `H`, `g`.
pub fn system() -> System<Structure, Energy, Circle> {
    System::new(Structure, Energy, Circle)
}

/// The multiplier of the modified Hamiltonian `H_N1 = H + μ g` (degenerate case,
/// `μ = −⟨φ,g⟩⁻¹⟨φ,H⟩`) in closed form: `⟨φ,g⟩ = −(x₁² + 2x₂²)`, `⟨φ,H⟩ = x₃² + x₄²`, so
/// `μ = (x₃² + x₄²)/(x₁² + 2x₂²)`.
pub fn modified_multiplier<V: Vector>(x: &V, out: &mut [V::Real]) {
    out[0] = ModifiedEnergy::mu(x.as_slice()).0;
}

/// `H_N1 = H + μ g` for the paper's model, `μ` from [`modified_multiplier`].
pub type Modified<V> =
    ModifiedHamiltonian<Energy, Circle, fn(&V, &mut [<V as Vector>::Real]), <V as Vector>::Real>;

/// The modified Hamiltonian `H_N1 = H + μ g` of the paper's §2 scheme (see
/// [`ModifiedHamiltonian`]).
pub fn modified_hamiltonian<V: Vector>() -> Modified<V> {
    ModifiedHamiltonian::new(
        Energy,
        Circle,
        modified_multiplier::<V> as fn(&V, &mut [V::Real]),
    )
}

/// `H_N1 = H + μ g` of the paper's model in closed form with its derivatives: the same energy
/// and gradient as [`modified_hamiltonian`] (`∇K = ∇H + Gᵀμ = (x₁μ, x₂μ, x₃, x₄)`, the
/// `(∂μ/∂x)ᵀ g` term dropped as there), and the exact derivative of that gradient field,
///
/// ```text
/// DK v = (v₁μ + x₁ ∇μ·v,  v₂μ + x₂ ∇μ·v,  v₃,  v₄),
/// ∇μ·v = (2x₃v₃ + 2x₄v₄ − μ (2x₁v₁ + 4x₂v₂)) / (x₁² + 2x₂²),
/// ```
///
/// so that the implicit midpoint rule of the §2 scheme builds its Newton matrix in closed form
/// instead of by differences (`DK` is not symmetric off `g = 0`: it is the Jacobian of the
/// gradient as defined, which is what Newton needs).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ModifiedEnergy;

/// The paper's modified Hamiltonian with closed-form derivatives (see [`ModifiedEnergy`]).
pub fn modified_energy() -> ModifiedEnergy {
    ModifiedEnergy
}

impl ModifiedEnergy {
    /// `(μ, 1/D)` with `D = x₁² + 2x₂²` (one division for both).
    #[inline(always)]
    fn mu<T: Real>(x: &[T]) -> (T, T) {
        let inv_d = T::one() / (x[0] * x[0] + T::lit(2.0) * x[1] * x[1]);
        ((x[2] * x[2] + x[3] * x[3]) * inv_d, inv_d)
    }
}

impl<V: Vector> Hamiltonian<V> for ModifiedEnergy {
    #[inline(always)]
    fn energy(&self, x: &V) -> V::Real {
        let (mu, _) = Self::mu(x.as_slice());
        let mut g = [V::Real::zero()];
        Circle.residual(x, &mut g);
        Energy.energy(x) + mu * g[0]
    }
    #[inline(always)]
    fn gradient(&self, x: &V, out: &mut V) {
        let x = x.as_slice();
        let (mu, _) = Self::mu(x);
        let o = out.as_mut_slice();
        o[0] = x[0] * mu;
        o[1] = x[1] * mu;
        o[2] = x[2];
        o[3] = x[3];
    }
    #[inline(always)]
    fn hessian_apply(&self, x: &V, v: &V, out: &mut V) -> bool {
        let (x, v) = (x.as_slice(), v.as_slice());
        let (mu, inv_d) = Self::mu(x);
        let two = V::Real::lit(2.0);
        let dmu = (two * (x[2] * v[2] + x[3] * v[3])
            - mu * (two * x[0] * v[0] + V::Real::lit(4.0) * x[1] * v[1]))
            * inv_d;
        let o = out.as_mut_slice();
        o[0] = v[0] * mu + x[0] * dmu;
        o[1] = v[1] * mu + x[1] * dmu;
        o[2] = v[2];
        o[3] = v[3];
        true
    }
}

/// The exact flow `exp(h D_H)`: the drift `x₁ += h x₃, x₂ += h x₄`.
pub fn drift<V: Vector>() -> FnFlow<impl FnMut(V::Real, &mut V) + Copy> {
    from_fn(|h: V::Real, x: &mut V| {
        let x = x.as_mut_slice();
        x[0] = x[0] + h * x[2];
        x[1] = x[1] + h * x[3];
    })
}

/// The paper's initial state `(1, 0, 0, −0.15)`.
pub fn initial_state<V: Vector>() -> V {
    state(&[1.0, 0.0, 0.0, -0.15])
}

/// A state of storage `V` from four values.
pub fn state<V: Vector>(values: &[f64; 4]) -> V {
    let mut x = V::zeros(4);
    for (xi, &v) in x.as_mut_slice().iter_mut().zip(values) {
        *xi = V::Real::lit(v);
    }
    x
}

/// The conserved quantity `H̃ = (x₃² + x₄²/2)/2`.
pub fn h_tilde<V: Vector>(x: &V) -> V::Real {
    let x = x.as_slice();
    (x[2] * x[2] + x[3] * x[3] * V::Real::lit(0.5)) * V::Real::lit(0.5)
}

/// The exact solution at time `t` from `x(0) = (1, 0, 0, v₀)` in closed form up to a
/// quadrature, accurate to about `10 ε |θ(t)|` (≈ 1e-12 at `t = 10⁴`), for long horizons where
/// integrating the angle equation ([`reference()`]) would accumulate error.
///
/// On the circle `x₁ = cos θ, x₂ = sin θ` the invariant `H̃ = v₀²/4` gives
/// `dt/dθ = sign(v₀) w(θ)`, `w(θ) = √((sin²θ + cos²θ/2) / (2H̃))`. `w` is even, analytic and
/// `π`-periodic, so its cosine series `w = a₀ + Σ_k a_k cos 2kθ` converges geometrically and the
/// trapezoid rule computes the coefficients to round-off (Trefethen & Weideman, SIAM Rev. 56,
/// 2014). Then `t(θ) = sign(v₀)(a₀ θ + Σ_k a_k sin(2kθ)/(2k))` is inverted by Newton's method
/// (`dt/dθ > 0` everywhere, so it converges from `θ = t/a₀`).
pub fn exact(t: f64, v0: f64) -> [f64; 4] {
    const TERMS: usize = 64;
    const NODES: usize = 256;
    let h_t = 0.25 * v0 * v0;
    let sign = if v0 < 0.0 { -1.0 } else { 1.0 };
    let w = |th: f64| {
        let (s, c) = th.sin_cos();
        ((s * s + 0.5 * c * c) / (2.0 * h_t)).sqrt()
    };
    // Cosine coefficients of the π-periodic w by the trapezoid rule on [0, π).
    let mut a = [0.0f64; TERMS];
    for j in 0..NODES {
        let th = std::f64::consts::PI * j as f64 / NODES as f64;
        let wj = w(th);
        for (k, ak) in a.iter_mut().enumerate() {
            *ak += wj * (2.0 * k as f64 * th).cos();
        }
    }
    a[0] /= NODES as f64;
    for ak in a.iter_mut().skip(1) {
        *ak *= 2.0 / NODES as f64;
    }
    let time_of = |th: f64| {
        let periodic: f64 = (1..TERMS)
            .map(|k| a[k] * (2.0 * k as f64 * th).sin() / (2.0 * k as f64))
            .sum();
        a[0] * th + periodic
    };
    let target = sign * t;
    let mut th = target / a[0];
    for _ in 0..50 {
        let step = (time_of(th) - target) / w(th);
        th -= step;
        if step.abs() <= 4.0 * f64::EPSILON * (1.0 + th.abs()) {
            break;
        }
    }
    let rate = sign / w(th);
    let (s, c) = th.sin_cos();
    [c, s, -s * rate, c * rate]
}

/// The exact solution at time `t` from `x(0) = (1, 0, 0, v₀)`, computed independently of any
/// scheme: on the circle `x₁ = cos θ, x₂ = sin θ` the invariant is
/// `H̃ = θ'² (sin²θ + cos²θ/2) / 2`, so `θ' = sign(v₀) √(2H̃ / (sin²θ + cos²θ/2))` with
/// `H̃ = v₀²/4`. This scalar ODE is integrated with classical RK4 at step `dt` (error `O(dt⁴)`).
pub fn reference(t: f64, v0: f64, dt: f64) -> [f64; 4] {
    let h_t = 0.25 * v0 * v0;
    let sign = if v0 < 0.0 { -1.0 } else { 1.0 };
    let rate = |th: f64| {
        let (s, c) = th.sin_cos();
        sign * (2.0 * h_t / (s * s + 0.5 * c * c)).sqrt()
    };
    let n = (t / dt).ceil().max(1.0) as usize;
    let dt = t / n as f64;
    let mut th = 0.0f64;
    for _ in 0..n {
        let k1 = rate(th);
        let k2 = rate(th + 0.5 * dt * k1);
        let k3 = rate(th + 0.5 * dt * k2);
        let k4 = rate(th + dt * k3);
        th += dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
    }
    let w = rate(th);
    let (s, c) = th.sin_cos();
    [c, s, -s * w, c * w]
}
