//! A damped mass–spring chain: `N` unit masses in a line, linked by springs of stiffness `k`, the
//! first one tied to a wall, each with viscous friction `c`.
//!
//! ```text
//! x = (q, p) ∈ R²ᴺ,   H = |p|²/2 + (k/2) Σᵢ (qᵢ − qᵢ₋₁)²   (q₀ = 0),
//! M = J − R,   R = c · diag(0, I).
//! ```
//!
//! Linear: `x' = (J − R) Q x`, and `dH/dt = −c |p|²`. With `c` large (up to 1e6) the damping is
//! stiff: any scheme that treats it explicitly, or runs it backwards, blows up at moderate `h`.
//! The spring frequencies are at most `2√k`.

use crate::error::SetupError;
use crate::flow::{FnFlow, LinearFlow, from_fn};
use crate::real::Real;
use crate::system::{Canonical, Hamiltonian, JMinusR, MomentumDamping};
use crate::vector::Vector;

/// The chain: number of masses, spring stiffness, damping.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpringChain<T> {
    /// Number of masses `N ≥ 1`.
    pub masses: usize,
    /// Spring stiffness `k > 0`.
    pub stiffness: T,
    /// Damping coefficient `c ≥ 0`.
    pub damping: T,
}

impl<T: Real> SpringChain<T> {
    /// A chain; [`SetupError::InvalidParameter`] (naming the parameter) unless `masses ≥ 1`,
    /// `stiffness > 0` and `damping ≥ 0`, all finite.
    pub fn try_new(masses: usize, stiffness: T, damping: T) -> Result<Self, SetupError> {
        if masses == 0 {
            return Err(SetupError::InvalidParameter {
                name: "masses".into(),
                value: 0.0,
                requirement: "at least 1",
            });
        }
        super::check_parameters(&[("stiffness", &[stiffness])], &[("damping", damping)])?;
        Ok(Self {
            masses,
            stiffness,
            damping,
        })
    }

    /// `J − R`.
    pub fn structure(&self) -> JMinusR<Canonical, MomentumDamping<T>> {
        JMinusR::new(Canonical, MomentumDamping { c: self.damping })
    }

    /// The exact flow of the potential: `p −= h ∇V(q)`.
    pub fn kick<V: Vector<Real = T>>(&self) -> FnFlow<impl FnMut(T, &mut V) + Clone + use<T, V>> {
        let (n, k) = (self.masses, self.stiffness);
        from_fn(move |h: T, x: &mut V| {
            let x = x.as_mut_slice();
            let (q, p) = x.split_at_mut(n);
            for i in 0..n {
                let left = if i == 0 { q[0] } else { q[i] - q[i - 1] };
                let right = if i + 1 < n {
                    q[i + 1] - q[i]
                } else {
                    T::zero()
                };
                p[i] = p[i] - h * k * (left - right);
            }
        })
        .kick()
    }

    /// The exact flow of the kinetic energy: `q += h p`.
    pub fn drift<V: Vector<Real = T>>(&self) -> FnFlow<impl FnMut(T, &mut V) + Clone + use<T, V>> {
        let n = self.masses;
        from_fn(move |h: T, x: &mut V| {
            let x = x.as_mut_slice();
            let (q, p) = x.split_at_mut(n);
            for (qi, &pi) in q.iter_mut().zip(p.iter()) {
                *qi = *qi + h * pi;
            }
        })
    }

    /// The exact damping flow `p ← e^{−ch} p` (dissipative when `c > 0`).
    pub fn damping_flow<V: Vector<Real = T>>(
        &self,
    ) -> FnFlow<impl FnMut(T, &mut V) + Clone + use<T, V>> {
        let (n, c) = (self.masses, self.damping);
        from_fn(move |h: T, x: &mut V| {
            let f = (-c * h).exp();
            for pi in &mut x.as_mut_slice()[n..] {
                *pi = *pi * f;
            }
        })
        .dissipative_if(c > T::zero())
    }

    /// The exact flow of the whole linear system, `e^{h (J − R) Q}` ([`LinearFlow`], dense:
    /// for small `N`).
    pub fn exact_flow(&self) -> Result<LinearFlow<T>, SetupError> {
        let n = self.masses;
        let k = self.stiffness;
        // A = [[0, I], [−K, −c I]], K the stiffness matrix (tridiagonal, 2k on the diagonal except
        // k at the free end, −k off the diagonal).
        LinearFlow::from_fn(2 * n, |i, j| {
            if i < n {
                if j == i + n { T::one() } else { T::zero() }
            } else {
                let r = i - n;
                if j == i {
                    -self.damping
                } else if j < n {
                    if j == r {
                        if r + 1 < n { -(k + k) } else { -k }
                    } else if j + 1 == r || r + 1 == j {
                        k
                    } else {
                        T::zero()
                    }
                } else {
                    T::zero()
                }
            }
        })
    }

    /// The state with mass `i` displaced by `amplitude · (i+1)/N` (a stretched chain) at rest.
    pub fn stretched<V: Vector<Real = T>>(&self, amplitude: T) -> V {
        let n = self.masses;
        let mut x = V::zeros(2 * n);
        for (i, qi) in x.as_mut_slice()[..n].iter_mut().enumerate() {
            *qi = amplitude * T::lit((i + 1) as f64 / n as f64);
        }
        x
    }
}

impl<T: Real, V: Vector<Real = T>> Hamiltonian<V> for SpringChain<T> {
    fn energy(&self, x: &V) -> T {
        let n = self.masses;
        let (q, p) = x.as_slice().split_at(n);
        let mut e = p.iter().fold(T::zero(), |s, &v| s + v * v);
        for i in 0..n {
            let d = if i == 0 { q[0] } else { q[i] - q[i - 1] };
            e = e + self.stiffness * d * d;
        }
        T::lit(0.5) * e
    }
    fn gradient(&self, x: &V, out: &mut V) {
        spring_gradient(
            self.masses,
            self.stiffness,
            x.as_slice(),
            out.as_mut_slice(),
        );
    }
    /// `H` is quadratic: `∇²H v = ∇H(v)`.
    fn hessian_apply(&self, _x: &V, v: &V, out: &mut V) -> bool {
        spring_gradient(
            self.masses,
            self.stiffness,
            v.as_slice(),
            out.as_mut_slice(),
        );
        true
    }
}

/// `o = ∇H(x)` for the chain: `(K q, p)`.
fn spring_gradient<T: Real>(n: usize, k: T, x: &[T], o: &mut [T]) {
    let (q, p) = x.split_at(n);
    for i in 0..n {
        let left = if i == 0 { q[0] } else { q[i] - q[i - 1] };
        let right = if i + 1 < n {
            q[i + 1] - q[i]
        } else {
            T::zero()
        };
        o[i] = k * (left - right);
        o[n + i] = p[i];
    }
}
