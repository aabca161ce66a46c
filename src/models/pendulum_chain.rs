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
//! Jacobian is banded (each `gᵢ` touches two particles), and [`ChainLinks`] provides it entry by
//! entry, so the multiplier systems of a projection are tridiagonal and solved by sparse LU in
//! `O(N)`. The natural scheme is RATTLE, the projected kick–drift–kick
//! ([`PendulumChain::projection_options`]).
//!
//! Extra rods ([`PendulumChain::with_rod`]) close loops or tie particles together; a rod that
//! repeats a link, or a loop that over-constrains the chain, makes the constraint gradients
//! dependent, and building a projection reports [`SetupError::RankDeficient`].

use crate::error::SetupError;
use crate::flow::{Coupling, FnFlow, ProjectionOptions, from_fn};
use crate::linalg::Sink;
use crate::nonlinear::NewtonOptions;
use crate::real::Real;
use crate::system::Case;
use crate::system::{Canonical, Hamiltonian, HolonomicConstraint, System};
use crate::vector::Vector;

/// The chain's parameters; also its Hamiltonian and (through [`ChainLinks`]) its constraints.
#[derive(Debug, Clone, PartialEq)]
pub struct PendulumChain<T> {
    dim: usize,
    masses: Vec<T>,
    /// `1/mᵢ`, so that the hot kernels multiply instead of divide.
    inv_masses: Vec<T>,
    lengths: Vec<T>,
    gravity: T,
    /// Extra rods `(a, b, length)` after the chain's own links (`a = None`: the pin).
    extra: Vec<(Option<usize>, usize, T)>,
}

/// The rod constraints of a [`PendulumChain`]: `gᵢ = (|q_b − q_a|² − lᵢ²)/2` for rod `i` between
/// particles `a` and `b` (`q_a = 0` for the pin). Rods `0..N` are the chain's links
/// (`a = i − 1`, `b = i`); extra rods follow.
#[derive(Debug, Clone, PartialEq)]
pub struct ChainLinks<T> {
    dim: usize,
    /// The number of the chain's own links (rods `0..links`, rod `i` from `i − 1` to `i`).
    links: usize,
    /// `(a, b, length)`, `a = usize::MAX` for the pin.
    rods: Vec<(usize, usize, T)>,
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
        super::check_parameters(
            &[("mass", &masses), ("length", &lengths)],
            &[("gravity", gravity)],
        )?;
        Ok(Self {
            dim,
            inv_masses: masses.iter().map(|&m| T::one() / m).collect(),
            masses,
            lengths,
            gravity,
            extra: Vec::new(),
        })
    }

    /// Adds a rod of length `length` between particle `a` (`None`: the pin at the origin) and
    /// particle `b`, as constraint number `links() + (rods added before)`.
    pub fn with_rod(mut self, a: Option<usize>, b: usize, length: T) -> Result<Self, SetupError> {
        let n = self.links();
        if a.is_some_and(|a| a >= n) || b >= n || a == Some(b) {
            return Err(SetupError::Dimension {
                what: format!("a rod between {a:?} and {b} in a chain of {n} particles"),
            });
        }
        super::check_parameters(&[("rod length", &[length])], &[])?;
        self.extra.push((a, b, length));
        Ok(self)
    }

    /// The number of constraints: links plus extra rods.
    pub fn constraints(&self) -> usize {
        self.links() + self.extra.len()
    }

    /// The projection options for RATTLE on this chain: degenerate case, decoupled multiplier
    /// systems (position constraints, momentum-only constraint forces). Naming them skips the
    /// `O(m² n)` dense bracket analysis, which is what lets `N` reach `10⁵`. The multiplier
    /// Jacobians come in closed form from the chain's Hessian (the projection's grouped
    /// Jacobian–vector products): the Newton matrix of a long chain has condition number
    /// `~N²`, which finite differences (`√ε` relative error) cannot afford beyond `N ≈ 10³`.
    ///
    /// The residual tolerance is scaled to the chain: `ftol = 16 ε l_min L` (`L` the total
    /// length), the rounding level of `g` and `φ` (positions of size `L` differenced over a link
    /// of length `l`, a few operations each). The default `2ε` is absolute; for short links it
    /// would stop Newton while the smooth tension mode — whose Newton matrix eigenvalue is
    /// `~(l/L)²` times the largest — is still far off.
    pub fn projection_options(&self) -> ProjectionOptions<T> {
        let l_min = self.lengths.iter().fold(T::infinity(), |a, &b| a.min(b));
        let total = self.lengths.iter().fold(T::zero(), |a, &b| a + b);
        let ftol = T::lit(16.0) * T::epsilon() * l_min * total.max(l_min);
        ProjectionOptions::default()
            .with_case(Case::Degenerate)
            .with_coupling(Coupling::Decoupled)
            .with_newton(NewtonOptions::default().with_ftol(ftol))
    }

    /// `links` unit masses on rods of length `1/links` (total length 1), gravity 1.
    pub fn uniform(dim: usize, links: usize) -> Result<Self, SetupError> {
        let l = T::one() / T::lit(links.max(1) as f64);
        Self::try_new(dim, vec![T::one(); links], vec![l; links], T::one())
    }

    /// The masses, the link lengths and the gravity constant.
    pub fn parameters(&self) -> (&[T], &[T], T) {
        (&self.masses, &self.lengths, self.gravity)
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
                links: self.links(),
                rods: (0..self.links())
                    .map(|i| (i.wrapping_sub(1), i, self.lengths[i]))
                    .chain(
                        self.extra
                            .iter()
                            .map(|&(a, b, l)| (a.unwrap_or(usize::MAX), b, l)),
                    )
                    .collect(),
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
        .kick()
    }

    /// The exact flow of the kinetic energy: `qᵢ += h pᵢ/mᵢ`.
    pub fn drift<V: Vector<Real = T>>(&self) -> FnFlow<impl FnMut(T, &mut V) + Clone + use<T, V>> {
        let (d, n) = (self.dim, self.links());
        let inv: Vec<T> = self.masses.iter().map(|&m| T::one() / m).collect();
        from_fn(move |h: T, x: &mut V| {
            let (q, p) = x.as_mut_slice().split_at_mut(d * n);
            match d {
                2 => drift_points::<T, 2>(&inv, h, q, p),
                _ => drift_points::<T, 3>(&inv, h, q, p),
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
    fn is_quadratic(&self) -> bool {
        true
    }
    /// `∇²H = diag(0, M⁻¹)` (gravity is linear in `q`).
    fn hessian_apply(&self, _x: &V, v: &V, out: &mut V) -> bool {
        let n = self.dim * self.links();
        let vp = &v.as_slice()[n..];
        let (oq, op) = out.as_mut_slice().split_at_mut(n);
        oq.iter_mut().for_each(|o| *o = T::zero());
        match self.dim {
            2 => scale_points::<T, 2>(&self.inv_masses, vp, op),
            _ => scale_points::<T, 3>(&self.inv_masses, vp, op),
        }
        true
    }
    fn gradient(&self, x: &V, out: &mut V) {
        let n = self.dim * self.links();
        let p = &x.as_slice()[n..];
        let (oq, op) = out.as_mut_slice().split_at_mut(n);
        match self.dim {
            2 => self.gravity_gradient::<2>(oq),
            _ => self.gravity_gradient::<3>(oq),
        }
        match self.dim {
            2 => scale_points::<T, 2>(&self.inv_masses, p, op),
            _ => scale_points::<T, 3>(&self.inv_masses, p, op),
        }
    }
}

impl<T: Real> PendulumChain<T> {
    /// `∂H/∂q`: `mᵢ γ` on the last axis of every particle.
    #[inline]
    fn gravity_gradient<const D: usize>(&self, oq: &mut [T]) {
        for (o, &m) in oq.chunks_exact_mut(D).zip(&self.masses) {
            for v in o[..D - 1].iter_mut() {
                *v = T::zero();
            }
            o[D - 1] = m * self.gravity;
        }
    }
}

/// `qᵢ += h wᵢ pᵢ` for every particle `i`.
#[inline]
fn drift_points<T: Real, const D: usize>(w: &[T], h: T, q: &mut [T], p: &[T]) {
    for ((qi, pi), &wi) in q.chunks_exact_mut(D).zip(p.chunks_exact(D)).zip(w) {
        let s = h * wi;
        for k in 0..D {
            qi[k] = qi[k] + s * pi[k];
        }
    }
}

/// `outᵢ = wᵢ vᵢ` for every `D`-vector `vᵢ` (particle `i`).
#[inline]
fn scale_points<T: Real, const D: usize>(w: &[T], v: &[T], out: &mut [T]) {
    for ((o, vi), &wi) in out.chunks_exact_mut(D).zip(v.chunks_exact(D)).zip(w) {
        for k in 0..D {
            o[k] = vi[k] * wi;
        }
    }
}

impl<T: Real> ChainLinks<T> {
    /// `q_b − q_a` of rod `(a, b)`, component `k` (`q_a = 0` for the pin).
    #[inline]
    fn diff(&self, q: &[T], a: usize, b: usize, k: usize) -> T {
        let d = self.dim;
        if a == usize::MAX {
            q[b * d + k]
        } else {
            q[b * d + k] - q[a * d + k]
        }
    }

    /// `q_b − q_a` of rod `(a, b)` as a `D`-vector (`q_a = 0` for the pin).
    #[inline(always)]
    fn rod<const D: usize>(q: &[T], a: usize, b: usize) -> [T; D] {
        let qb = &q[b * D..b * D + D];
        let mut r = [T::zero(); D];
        if a == usize::MAX {
            r.copy_from_slice(qb);
        } else {
            let qa = &q[a * D..a * D + D];
            for k in 0..D {
                r[k] = qb[k] - qa[k];
            }
        }
        r
    }

    #[inline]
    fn residual_d<const D: usize>(&self, q: &[T], out: &mut [T]) {
        for (o, &(a, b, l)) in out.iter_mut().zip(&self.rods) {
            let r = Self::rod::<D>(q, a, b);
            let r2 = r.iter().fold(T::zero(), |s, &v| s + v * v);
            *o = (r2 - l * l) * T::lit(0.5);
        }
    }

    #[inline]
    fn jacobian_apply_d<const D: usize>(&self, q: &[T], v: &[T], out: &mut [T]) {
        for (o, &(a, b, _)) in out.iter_mut().zip(&self.rods) {
            let r = Self::rod::<D>(q, a, b);
            let w = Self::rod::<D>(v, a, b);
            *o = (0..D).fold(T::zero(), |s, k| s + r[k] * w[k]);
        }
    }

    /// `Gᵀ μ` written directly (positions; zero momenta), one pass over the state: along the
    /// chain, particle `j` is the end of link `j` and the start of link `j + 1`, so its entry
    /// is `μ_j r_j − μ_{j+1} r_{j+1}`, formed from the last particle back; extra rods are then
    /// accumulated.
    #[inline]
    fn jacobian_transpose_apply_d<const D: usize>(&self, q: &[T], mu: &[T], o: &mut [T]) {
        let nq = self.links * D;
        let (oq, op) = o.split_at_mut(nq);
        op.iter_mut().for_each(|v| *v = T::zero());
        let mut next = [T::zero(); D];
        for j in (0..self.links).rev() {
            let r = Self::rod::<D>(q, j.wrapping_sub(1), j);
            let oj = &mut oq[j * D..j * D + D];
            for k in 0..D {
                let c = mu[j] * r[k];
                oj[k] = c - next[k];
                next[k] = c;
            }
        }
        self.transpose_add_d::<D>(q, mu, T::one(), o, self.links);
    }

    /// The part of `α Gᵀ μ` from rods `from..`, added to `o`.
    #[inline]
    fn transpose_add_d<const D: usize>(
        &self,
        q: &[T],
        mu: &[T],
        alpha: T,
        o: &mut [T],
        from: usize,
    ) {
        for (&m, &(a, b, _)) in mu.iter().zip(&self.rods).skip(from) {
            let r = Self::rod::<D>(q, a, b);
            let c = alpha * m;
            for k in 0..D {
                o[b * D + k] = o[b * D + k] + c * r[k];
            }
            if a != usize::MAX {
                for k in 0..D {
                    o[a * D + k] = o[a * D + k] - c * r[k];
                }
            }
        }
    }
}

impl<T: Real, V: Vector<Real = T>> HolonomicConstraint<V> for ChainLinks<T> {
    fn dim(&self) -> usize {
        self.rods.len()
    }
    fn residual(&self, x: &V, out: &mut [T]) {
        match self.dim {
            2 => self.residual_d::<2>(x.as_slice(), out),
            _ => self.residual_d::<3>(x.as_slice(), out),
        }
    }
    fn jacobian_apply(&self, x: &V, v: &V, out: &mut [T]) {
        match self.dim {
            2 => self.jacobian_apply_d::<2>(x.as_slice(), v.as_slice(), out),
            _ => self.jacobian_apply_d::<3>(x.as_slice(), v.as_slice(), out),
        }
    }
    fn jacobian_transpose_apply(&self, x: &V, mu: &[T], out: &mut V) {
        let (q, o) = (x.as_slice(), out.as_mut_slice());
        match self.dim {
            2 => self.jacobian_transpose_apply_d::<2>(q, mu, o),
            _ => self.jacobian_transpose_apply_d::<3>(q, mu, o),
        }
    }
    fn jacobian_transpose_apply_add(&self, x: &V, mu: &[T], alpha: T, out: &mut V) {
        let (q, o) = (x.as_slice(), out.as_mut_slice());
        match self.dim {
            2 => self.transpose_add_d::<2>(q, mu, alpha, o, 0),
            _ => self.transpose_add_d::<3>(q, mu, alpha, o, 0),
        }
    }
    /// `∂gᵢ/∂q_b = q_b − q_a`, `∂gᵢ/∂q_a = −(q_b − q_a)`: `2d` entries per rod (`d` at the pin).
    fn jacobian_entries(&self, x: &V, sink: &mut dyn Sink<T>) -> bool {
        let d = self.dim;
        let q = x.as_slice();
        for (i, &(a, b, _)) in self.rods.iter().enumerate() {
            for k in 0..d {
                let v = self.diff(q, a, b, k);
                if a != usize::MAX {
                    sink.add(i, a * d + k, -v);
                }
                sink.add(i, b * d + k, v);
            }
        }
        true
    }
}
