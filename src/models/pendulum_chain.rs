//! An `N`-link pendulum chain in Cartesian coordinates, planar (`d = 2`) or spatial (`d = 3`):
//! point masses `mᵢ` joined by massless rods of lengths `lᵢ`, the first rod pinned at the origin,
//! gravity `γ` along the last axis.
//!
//! ```text
//! x = (q₁ … q_N, p₁ … p_N) ∈ R^{2dN},   H = Σ |pᵢ|²/(2mᵢ) + Σ mᵢ γ qᵢ,d,
//! gᵢ = (|qᵢ − qᵢ₋₁|² − lᵢ²)/2   (q₀ = 0),   M canonical.
//! ```
//!
//! Degenerate case; hidden constraints `φᵢ = (qᵢ − qᵢ₋₁)·(pᵢ/mᵢ − pᵢ₋₁/mᵢ₋₁)`. The constraint
//! Jacobian is banded (each `gᵢ` touches two particles). The natural scheme is RATTLE, the
//! projected kick–drift–kick.

use crate::error::SetupError;
use crate::flow::{FnFlow, from_fn};
use crate::real::Real;
use crate::system::{Canonical, Hamiltonian, HolonomicConstraint, System};
use crate::vector::Vector;

/// The chain's parameters; also its Hamiltonian and (through [`ChainLinks`]) its constraints.
#[derive(Debug, Clone, PartialEq)]
pub struct PendulumChain<T> {
    dim: usize,
    masses: Vec<T>,
    lengths: Vec<T>,
    gravity: T,
}

/// The rod constraints `gᵢ = (|qᵢ − qᵢ₋₁|² − lᵢ²)/2` of a [`PendulumChain`].
#[derive(Debug, Clone, PartialEq)]
pub struct ChainLinks<T> {
    dim: usize,
    lengths: Vec<T>,
}

impl<T: Real> PendulumChain<T> {
    /// A chain in `dim ∈ {2, 3}` dimensions with the given masses and rod lengths (one each per
    /// link, all positive and finite) and gravity `γ ≥ 0`.
    pub fn try_new(
        dim: usize,
        masses: Vec<T>,
        lengths: Vec<T>,
        gravity: T,
    ) -> Result<Self, SetupError> {
        let bad = |what: String| Err(SetupError::Dimension { what });
        if dim != 2 && dim != 3 {
            return bad(format!(
                "a pendulum chain lives in 2 or 3 dimensions, not {dim}"
            ));
        }
        if masses.is_empty() || masses.len() != lengths.len() {
            return bad(format!(
                "{} masses and {} lengths: need one of each per link, at least one link",
                masses.len(),
                lengths.len()
            ));
        }
        let positive = |v: &T| *v > T::zero() && v.is_finite();
        if let Some(i) = masses.iter().position(|m| !positive(m)) {
            return bad(format!("mass {i} must be positive and finite"));
        }
        if let Some(i) = lengths.iter().position(|l| !positive(l)) {
            return bad(format!("length {i} must be positive and finite"));
        }
        if !(gravity >= T::zero() && gravity.is_finite()) {
            return bad("gravity must be finite and non-negative".into());
        }
        Ok(Self {
            dim,
            masses,
            lengths,
            gravity,
        })
    }

    /// `links` unit masses on rods of length `1/links` (total length 1), gravity 1.
    pub fn uniform(dim: usize, links: usize) -> Result<Self, SetupError> {
        let l = T::one() / T::lit(links.max(1) as f64);
        Self::try_new(dim, vec![T::one(); links], vec![l; links], T::one())
    }

    /// The number of links `N`.
    pub fn links(&self) -> usize {
        self.masses.len()
    }

    /// The state dimension `2dN`.
    pub fn state_len(&self) -> usize {
        2 * self.dim * self.links()
    }

    /// The model as a [`System`].
    pub fn system(&self) -> System<Canonical, Self, ChainLinks<T>> {
        System::new(
            Canonical,
            self.clone(),
            ChainLinks {
                dim: self.dim,
                lengths: self.lengths.clone(),
            },
        )
    }

    /// The exact flow of the potential: `pᵢ,d −= h mᵢ γ`.
    pub fn kick<V: Vector<Real = T>>(&self) -> FnFlow<impl FnMut(T, &mut V) + Clone + use<T, V>> {
        let (d, n) = (self.dim, self.links());
        let weights: Vec<T> = self.masses.iter().map(|&m| m * self.gravity).collect();
        from_fn(move |h: T, x: &mut V| {
            let p = &mut x.as_mut_slice()[d * n..];
            for (i, &w) in weights.iter().enumerate() {
                p[i * d + d - 1] = p[i * d + d - 1] - h * w;
            }
        })
    }

    /// The exact flow of the kinetic energy: `qᵢ += h pᵢ/mᵢ`.
    pub fn drift<V: Vector<Real = T>>(&self) -> FnFlow<impl FnMut(T, &mut V) + Clone + use<T, V>> {
        let (d, n) = (self.dim, self.links());
        let inv: Vec<T> = self.masses.iter().map(|&m| T::one() / m).collect();
        from_fn(move |h: T, x: &mut V| {
            let (q, p) = x.as_mut_slice().split_at_mut(d * n);
            for (i, &w) in inv.iter().enumerate() {
                for k in 0..d {
                    q[i * d + k] = q[i * d + k] + h * w * p[i * d + k];
                }
            }
        })
    }

    /// A state at rest on the constraints: link `i` at angle `angle(i)` from the downward
    /// vertical, in the plane of the first and last axes.
    pub fn at_rest<V: Vector<Real = T>>(&self, angle: impl Fn(usize) -> T) -> V {
        let d = self.dim;
        let mut x = V::zeros(self.state_len());
        let q = x.as_mut_slice();
        let (mut a, mut b) = (T::zero(), T::zero());
        for (i, &l) in self.lengths.iter().enumerate() {
            let (s, c) = angle(i).sin_cos();
            a = a + l * s;
            b = b - l * c;
            q[i * d] = a;
            q[i * d + d - 1] = b;
        }
        x
    }
}

impl<T: Real, V: Vector<Real = T>> Hamiltonian<V> for PendulumChain<T> {
    fn energy(&self, x: &V) -> T {
        let (d, n) = (self.dim, self.links());
        let (q, p) = x.as_slice().split_at(d * n);
        let mut e = T::zero();
        for (i, &m) in self.masses.iter().enumerate() {
            let p2 = p[i * d..(i + 1) * d]
                .iter()
                .fold(T::zero(), |s, &v| s + v * v);
            e = e + p2 / (m + m) + m * self.gravity * q[i * d + d - 1];
        }
        e
    }
    fn gradient(&self, x: &V, out: &mut V) {
        let (d, n) = (self.dim, self.links());
        let p = &x.as_slice()[d * n..];
        let (oq, op) = out.as_mut_slice().split_at_mut(d * n);
        for (i, &m) in self.masses.iter().enumerate() {
            for k in 0..d {
                oq[i * d + k] = T::zero();
                op[i * d + k] = p[i * d + k] / m;
            }
            oq[i * d + d - 1] = m * self.gravity;
        }
    }
}

impl<T: Real> ChainLinks<T> {
    /// `qᵢ − qᵢ₋₁`, component `k`.
    #[inline]
    fn diff(&self, q: &[T], i: usize, k: usize) -> T {
        let d = self.dim;
        if i == 0 {
            q[k]
        } else {
            q[i * d + k] - q[(i - 1) * d + k]
        }
    }
}

impl<T: Real, V: Vector<Real = T>> HolonomicConstraint<V> for ChainLinks<T> {
    fn dim(&self) -> usize {
        self.lengths.len()
    }
    fn residual(&self, x: &V, out: &mut [T]) {
        let q = x.as_slice();
        for (i, (o, &l)) in out.iter_mut().zip(&self.lengths).enumerate() {
            let r2 = (0..self.dim).fold(T::zero(), |s, k| {
                let v = self.diff(q, i, k);
                s + v * v
            });
            *o = (r2 - l * l) * T::lit(0.5);
        }
    }
    fn jacobian_apply(&self, x: &V, v: &V, out: &mut [T]) {
        let (q, v) = (x.as_slice(), v.as_slice());
        for (i, o) in out.iter_mut().enumerate() {
            *o = (0..self.dim).fold(T::zero(), |s, k| {
                s + self.diff(q, i, k) * self.diff(v, i, k)
            });
        }
    }
    fn jacobian_transpose_apply_add(&self, x: &V, mu: &[T], alpha: T, out: &mut V) {
        let d = self.dim;
        let q = x.as_slice();
        let o = out.as_mut_slice();
        for (i, &m) in mu.iter().enumerate() {
            for k in 0..d {
                let c = alpha * m * self.diff(q, i, k);
                o[i * d + k] = o[i * d + k] + c;
                if i > 0 {
                    o[(i - 1) * d + k] = o[(i - 1) * d + k] - c;
                }
            }
        }
    }
}
