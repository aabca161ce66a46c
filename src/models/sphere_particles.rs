//! `N` particles in space, each constrained to its own sphere, optionally joined by springs:
//! the block-diagonal sparsity pattern (one constraint per particle, touching only that
//! particle), the second pattern of the sparse path next to the banded chain.
//!
//! ```text
//! x = (q₁ … q_N, p₁ … p_N) ∈ R^{6N},
//! H = Σ |pᵢ|²/(2mᵢ) + Σ mᵢ γ qᵢ,₃ + Σ k/2 |qᵢ₊₁ − qᵢ|²,
//! gᵢ = (|qᵢ − cᵢ|² − rᵢ²)/2,   M canonical.
//! ```
//!
//! Each particle alone is a spherical pendulum. The constraint Jacobian is block diagonal, so
//! the multiplier systems of a projection are diagonal in their pattern (`G Gᵀ`). With springs
//! (`k > 0`) and a drift–kick–drift inner flow, the kick in the middle moves each particle by
//! its neighbours' multipliers: the true multiplier Jacobian picks up `O(h³)` entries outside
//! that pattern, which the closed-form Jacobian (first order in `h M ∇²H`) leaves out, and
//! Newton converges linearly with a contraction of order `h² k / m` — to the same answer.
//! (With kick–drift–kick the Jacobians stay exactly diagonal: the positions after the drift
//! depend on each particle's own multiplier only.)

use crate::error::SetupError;
use crate::flow::{Coupling, FnFlow, ProjectionOptions, from_fn};
use crate::linalg::Sink;
use crate::nonlinear::NewtonOptions;
use crate::real::Real;
use crate::system::{Canonical, Case, Hamiltonian, HolonomicConstraint, System};
use crate::vector::Vector;

/// The particles' parameters and Hamiltonian; [`Spheres`] are the constraints.
#[derive(Debug, Clone, PartialEq)]
pub struct SphereParticles<T> {
    masses: Vec<T>,
    centers: Vec<[T; 3]>,
    radii: Vec<T>,
    gravity: T,
    spring: T,
}

/// The constraints `gᵢ = (|qᵢ − cᵢ|² − rᵢ²)/2` of [`SphereParticles`].
#[derive(Debug, Clone, PartialEq)]
pub struct Spheres<T> {
    centers: Vec<[T; 3]>,
    radii: Vec<T>,
}

impl<T: Real> SphereParticles<T> {
    /// Particles with the given masses, sphere centers and radii (one each per particle;
    /// masses and radii positive and finite), gravity `γ ≥ 0` along the third axis and spring
    /// stiffness `k ≥ 0` between consecutive particles.
    pub fn try_new(
        masses: Vec<T>,
        centers: Vec<[T; 3]>,
        radii: Vec<T>,
        gravity: T,
        spring: T,
    ) -> Result<Self, SetupError> {
        let bad = |what: String| Err(SetupError::Dimension { what });
        let n = masses.len();
        if n == 0 || centers.len() != n || radii.len() != n {
            return bad(format!(
                "{n} masses, {} centers, {} radii: need one of each per particle, at least one",
                centers.len(),
                radii.len()
            ));
        }
        super::check_parameters(
            &[("mass", &masses), ("radius", &radii)],
            &[("gravity", gravity), ("spring stiffness", spring)],
        )?;
        if let Some(i) = centers
            .iter()
            .position(|c| c.iter().any(|v| !v.is_finite()))
        {
            return bad(format!("center {i} must be finite"));
        }
        Ok(Self {
            masses,
            centers,
            radii,
            gravity,
            spring,
        })
    }

    /// `n` unit masses on unit spheres centred at `(2i, 0, 0)`, gravity 1, springs `k`.
    pub fn row(n: usize, spring: T) -> Result<Self, SetupError> {
        let centers = (0..n).map(|i| [T::lit(2.0 * i as f64), T::zero(), T::zero()]);
        Self::try_new(
            vec![T::one(); n],
            centers.collect(),
            vec![T::one(); n],
            T::one(),
            spring,
        )
    }

    /// The number of particles.
    pub fn particles(&self) -> usize {
        self.masses.len()
    }

    /// The state dimension `6N`.
    pub fn state_len(&self) -> usize {
        6 * self.particles()
    }

    /// The model as a [`System`].
    pub fn system(&self) -> System<Canonical, Self, Spheres<T>> {
        System::new(
            Canonical,
            self.clone(),
            Spheres {
                centers: self.centers.clone(),
                radii: self.radii.clone(),
            },
        )
    }

    /// Projection options for RATTLE: degenerate case, decoupled multiplier systems (named,
    /// so that no dense bracket analysis runs), and a residual tolerance at the rounding level of
    /// `g`: `ftol = 16 ε r (|c| + r)` (positions of size `|c| + r` differenced with centers, over
    /// radii `r`) — the default `2ε` is absolute and unreachable far from the origin.
    pub fn projection_options(&self) -> ProjectionOptions<T> {
        let r = self.radii.iter().fold(T::zero(), |a, &b| a.max(b));
        let c = self
            .centers
            .iter()
            .flatten()
            .fold(T::zero(), |a, &b| a.max(b.abs()));
        let ftol = T::lit(16.0) * T::epsilon() * r * (c + r);
        ProjectionOptions::default()
            .with_case(Case::Degenerate)
            .with_coupling(Coupling::Decoupled)
            .with_newton(NewtonOptions::default().with_ftol(ftol))
    }

    /// The exact flow of the potential (gravity and springs depend on `q` only):
    /// `p −= h ∇V(q)`.
    pub fn kick<V: Vector<Real = T>>(&self) -> FnFlow<impl FnMut(T, &mut V) + Clone + use<T, V>> {
        let n = self.particles();
        let weights: Vec<T> = self.masses.iter().map(|&m| m * self.gravity).collect();
        let k = self.spring;
        from_fn(move |h: T, x: &mut V| {
            let (q, p) = x.as_mut_slice().split_at_mut(3 * n);
            for (i, &w) in weights.iter().enumerate() {
                p[3 * i + 2] = p[3 * i + 2] - h * w;
            }
            if k > T::zero() {
                for i in 0..n.saturating_sub(1) {
                    for c in 0..3 {
                        let f = h * k * (q[3 * (i + 1) + c] - q[3 * i + c]);
                        p[3 * i + c] = p[3 * i + c] + f;
                        p[3 * (i + 1) + c] = p[3 * (i + 1) + c] - f;
                    }
                }
            }
        })
        .kick()
    }

    /// The exact flow of the kinetic energy: `qᵢ += h pᵢ/mᵢ`.
    pub fn drift<V: Vector<Real = T>>(&self) -> FnFlow<impl FnMut(T, &mut V) + Clone + use<T, V>> {
        let n = self.particles();
        let inv: Vec<T> = self.masses.iter().map(|&m| T::one() / m).collect();
        from_fn(move |h: T, x: &mut V| {
            let (q, p) = x.as_mut_slice().split_at_mut(3 * n);
            for (i, &w) in inv.iter().enumerate() {
                for c in 0..3 {
                    q[3 * i + c] = q[3 * i + c] + h * w * p[3 * i + c];
                }
            }
        })
    }

    /// A state at rest on the spheres: particle `i` at polar angle `theta(i)` from the downward
    /// direction, azimuth `phi(i)`.
    pub fn at_rest<V: Vector<Real = T>>(
        &self,
        theta: impl Fn(usize) -> T,
        phi: impl Fn(usize) -> T,
    ) -> V {
        let mut x = V::zeros(self.state_len());
        let q = x.as_mut_slice();
        for (i, (c, &r)) in self.centers.iter().zip(&self.radii).enumerate() {
            let (st, ct) = theta(i).sin_cos();
            let (sp, cp) = phi(i).sin_cos();
            q[3 * i] = c[0] + r * st * cp;
            q[3 * i + 1] = c[1] + r * st * sp;
            q[3 * i + 2] = c[2] - r * ct;
        }
        x
    }
}

impl<T: Real, V: Vector<Real = T>> Hamiltonian<V> for SphereParticles<T> {
    fn energy(&self, x: &V) -> T {
        let n = self.particles();
        let (q, p) = x.as_slice().split_at(3 * n);
        let mut e = T::zero();
        for (i, &m) in self.masses.iter().enumerate() {
            let p2 = (0..3).fold(T::zero(), |s, c| s + p[3 * i + c] * p[3 * i + c]);
            e = e + p2 / (m + m) + m * self.gravity * q[3 * i + 2];
        }
        for i in 0..n.saturating_sub(1) {
            let d2 = (0..3).fold(T::zero(), |s, c| {
                let d = q[3 * (i + 1) + c] - q[3 * i + c];
                s + d * d
            });
            e = e + self.spring * d2 * T::lit(0.5);
        }
        e
    }
    fn gradient(&self, x: &V, out: &mut V) {
        let n = self.particles();
        let (q, p) = x.as_slice().split_at(3 * n);
        let (oq, op) = out.as_mut_slice().split_at_mut(3 * n);
        for (i, &m) in self.masses.iter().enumerate() {
            for c in 0..3 {
                oq[3 * i + c] = T::zero();
                op[3 * i + c] = p[3 * i + c] / m;
            }
            oq[3 * i + 2] = m * self.gravity;
        }
        for i in 0..n.saturating_sub(1) {
            for c in 0..3 {
                let f = self.spring * (q[3 * (i + 1) + c] - q[3 * i + c]);
                oq[3 * i + c] = oq[3 * i + c] - f;
                oq[3 * (i + 1) + c] = oq[3 * (i + 1) + c] + f;
            }
        }
    }
    /// `∇²H = diag(k L ⊗ I₃, M⁻¹)` with `L` the path Laplacian of the springs.
    fn hessian_apply(&self, _x: &V, v: &V, out: &mut V) -> bool {
        let n = self.particles();
        let (vq, vp) = v.as_slice().split_at(3 * n);
        let (oq, op) = out.as_mut_slice().split_at_mut(3 * n);
        oq.iter_mut().for_each(|o| *o = T::zero());
        for i in 0..n.saturating_sub(1) {
            for c in 0..3 {
                let f = self.spring * (vq[3 * (i + 1) + c] - vq[3 * i + c]);
                oq[3 * i + c] = oq[3 * i + c] - f;
                oq[3 * (i + 1) + c] = oq[3 * (i + 1) + c] + f;
            }
        }
        for (i, &m) in self.masses.iter().enumerate() {
            for c in 0..3 {
                op[3 * i + c] = vp[3 * i + c] / m;
            }
        }
        true
    }
}

impl<T: Real, V: Vector<Real = T>> HolonomicConstraint<V> for Spheres<T> {
    fn dim(&self) -> usize {
        self.radii.len()
    }
    fn residual(&self, x: &V, out: &mut [T]) {
        let q = x.as_slice();
        for (i, (o, (c, &r))) in out
            .iter_mut()
            .zip(self.centers.iter().zip(&self.radii))
            .enumerate()
        {
            let d2 = (0..3).fold(T::zero(), |s, k| {
                let d = q[3 * i + k] - c[k];
                s + d * d
            });
            *o = (d2 - r * r) * T::lit(0.5);
        }
    }
    fn jacobian_apply(&self, x: &V, v: &V, out: &mut [T]) {
        let (q, v) = (x.as_slice(), v.as_slice());
        for (i, (o, c)) in out.iter_mut().zip(&self.centers).enumerate() {
            *o = (0..3).fold(T::zero(), |s, k| s + (q[3 * i + k] - c[k]) * v[3 * i + k]);
        }
    }
    /// `Gᵀ μ` written directly: `μᵢ (qᵢ − cᵢ)` for the constrained particles, zero elsewhere.
    fn jacobian_transpose_apply(&self, x: &V, mu: &[T], out: &mut V) {
        let q = x.as_slice();
        let o = out.as_mut_slice();
        let n = 3 * self.centers.len();
        for (i, (&m, c)) in mu.iter().zip(&self.centers).enumerate() {
            for k in 0..3 {
                o[3 * i + k] = m * (q[3 * i + k] - c[k]);
            }
        }
        o[n..].iter_mut().for_each(|v| *v = T::zero());
    }
    fn jacobian_transpose_apply_add(&self, x: &V, mu: &[T], alpha: T, out: &mut V) {
        let q = x.as_slice();
        let o = out.as_mut_slice();
        for (i, (&m, c)) in mu.iter().zip(&self.centers).enumerate() {
            for k in 0..3 {
                o[3 * i + k] = o[3 * i + k] + alpha * m * (q[3 * i + k] - c[k]);
            }
        }
    }
    /// `∂gᵢ/∂qᵢ = qᵢ − cᵢ`: three entries per row, block diagonal.
    fn jacobian_entries(&self, x: &V, sink: &mut dyn Sink<T>) -> bool {
        let q = x.as_slice();
        for (i, c) in self.centers.iter().enumerate() {
            for k in 0..3 {
                sink.add(i, 3 * i + k, q[3 * i + k] - c[k]);
            }
        }
        true
    }
}
