//! The assembled model of a scene: the declared terms of `H` and of `M`, the declared
//! constraints, and the exact sub-flows they bring.
//!
//! ```text
//! x = (q, p),  q, p ∈ R^{dN} (body b at q[b·d .. b·d + d]),
//! H = Σ_b |p_b|²/(2 m_b) + Σ_terms V_term(q),
//! M = [[0, I], [−I, K − R]],  K_b v = e_b v × B (magnetic),  R_b = c_b I (damping),
//! g = (g_1, …, g_m)(q).
//! ```
//!
//! A scene's potential terms depend on `q` only, so their flows commute and merge into one kick
//! `p ← p − h ∇V(q)` (exact). The kinetic term's flow under `M` is the free flight of each
//! body, `q' = v = p/m`, `p' = e v × B − c v`, linear and solved exactly: a drift, rotated about
//! `B` and damped by `e^{−c t/m}` only for the bodies that have a field or damping (see
//! [`SceneModel::free_flight`]). Undeclared effects have no term: no evaluation, no cost.

// Per-coordinate loops `for k in 0..d` index several arrays at once (q, p, a 3-vector).
#![allow(clippy::needless_range_loop)]

use crate::linalg::Sink;
use crate::real::Real;
use crate::system::{Hamiltonian, HolonomicConstraint, StructureMatrix};
use crate::vector::Vector;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

/// What kind of physics a term is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum EffectKind {
    /// The kinetic energy `Σ |p|²/2m` and its flow (the drift).
    Kinetic,
    /// Uniform gravity.
    Gravity,
    /// A spring between two bodies.
    Spring,
    /// A pair potential within a group.
    Pair,
    /// A harmonic trap.
    Trap,
    /// Viscous damping (`R` in `M = J − R`).
    Damping,
    /// A uniform magnetic field (a non-canonical `J`).
    Magnetic,
    /// The holonomic constraints.
    Constraints,
}

impl EffectKind {
    /// The name used in scene files and summaries.
    pub fn name(self) -> &'static str {
        match self {
            EffectKind::Kinetic => "kinetic",
            EffectKind::Gravity => "gravity",
            EffectKind::Spring => "spring",
            EffectKind::Pair => "pair",
            EffectKind::Trap => "trap",
            EffectKind::Damping => "damping",
            EffectKind::Magnetic => "magnetic",
            EffectKind::Constraints => "constraints",
        }
    }
}

/// Evaluation counter of one term (and its time when profiling). Atomic so that a model can be
/// shared between the flows that use it; each run is single-threaded.
#[derive(Debug, Default)]
pub(crate) struct Counter {
    evaluations: AtomicU64,
    nanos: AtomicU64,
}

impl Counter {
    #[inline]
    fn hit(&self) {
        self.evaluations.fetch_add(1, Ordering::Relaxed);
    }
    fn add_time(&self, since: Instant) {
        let ns = since.elapsed().as_nanos() as u64;
        self.nanos.fetch_add(ns, Ordering::Relaxed);
    }
    pub(crate) fn evaluations(&self) -> u64 {
        self.evaluations.load(Ordering::Relaxed)
    }
    pub(crate) fn nanos(&self) -> u64 {
        self.nanos.load(Ordering::Relaxed)
    }
    fn reset(&self) {
        self.evaluations.store(0, Ordering::Relaxed);
        self.nanos.store(0, Ordering::Relaxed);
    }
}

/// A radial law `φ(r)` of a pair potential.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum PairLaw<T = f64> {
    /// `s / rⁿ`.
    InversePower { strength: T, power: T },
    /// `−s ln r`.
    Log { strength: T },
    /// `4ε ((σ/r)¹² − (σ/r)⁶)`.
    LennardJones { epsilon: T, sigma: T },
    /// `k/2 (r − L)²` (a spring).
    Spring { stiffness: T, rest: T },
}

impl<T: Real> PairLaw<T> {
    /// `(φ(r), φ'(r)/r, φ''(r))`.
    #[inline]
    fn eval(self, r: T) -> (T, T, T) {
        // One division per pair: everything in powers of 1/r.
        let inv_r = T::lit(1.0) / r;
        let inv_r2 = inv_r * inv_r;
        match self {
            PairLaw::InversePower { strength, power } => {
                // Integer powers (Coulomb, dipoles) by multiplication: powf costs ~10x more.
                let rn = if power == T::lit(1.0) {
                    inv_r
                } else if power.fract() == T::lit(0.0) && power <= T::lit(32.0) {
                    inv_r.powi(num_traits::ToPrimitive::to_i32(&power).unwrap_or(1))
                } else {
                    r.powf(-power)
                };
                let phi = strength * rn;
                (
                    phi,
                    -power * phi * inv_r2,
                    power * (power + T::lit(1.0)) * phi * inv_r2,
                )
            }
            PairLaw::Log { strength } => {
                (-strength * r.ln(), -strength * inv_r2, strength * inv_r2)
            }
            PairLaw::LennardJones { epsilon, sigma } => {
                let s2 = sigma * sigma * inv_r2;
                let s6 = s2 * s2 * s2;
                let s12 = s6 * s6;
                (
                    T::lit(4.0) * epsilon * (s12 - s6),
                    T::lit(4.0) * epsilon * (-T::lit(12.0) * s12 + T::lit(6.0) * s6) * inv_r2,
                    T::lit(4.0) * epsilon * (T::lit(156.0) * s12 - T::lit(42.0) * s6) * inv_r2,
                )
            }
            PairLaw::Spring { stiffness, rest } => {
                let e = r - rest;
                // φ'/r = k (1 − L/r): exact at L = 0 (a zero-length spring is linear).
                let dr = if rest == T::lit(0.0) {
                    stiffness
                } else {
                    stiffness * e * inv_r
                };
                (T::lit(0.5) * stiffness * e * e, dr, stiffness)
            }
        }
    }
}

/// A position-dependent potential term.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Potential<T = f64> {
    /// `V = −Σ_b m_b g · q_b`: per body, the force `m_b g`.
    Gravity { forces: Vec<(usize, [T; 3])> },
    /// `Σ φ(|q_a − q_b|)` over the listed pairs.
    Pairs {
        pairs: Vec<(usize, usize)>,
        law: PairLaw<T>,
    },
    /// `k/2 Σ_b |q_b − c|²`.
    Trap {
        stiffness: T,
        center: [T; 3],
        bodies: Vec<usize>,
    },
}

/// A declared term of `V` with its label and counter.
#[derive(Debug)]
pub(crate) struct PotentialTerm<T = f64> {
    pub(crate) label: String,
    pub(crate) kind: EffectKind,
    pub(crate) potential: Potential<T>,
    pub(crate) counter: Counter,
}

/// A holonomic constraint term.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum ConstraintKind<T = f64> {
    /// `q_b − point = 0` (`d` rows).
    Pin { body: usize, point: [T; 3] },
    /// `(|q_a − r|² − L²)/2 = 0` with `r = q_b`, or the fixed `point` when `b` is `None`.
    Rod {
        a: usize,
        b: Option<usize>,
        point: [T; 3],
        length: T,
    },
    /// `(|q_b − c|² − r²)/2 = 0`.
    Sphere {
        body: usize,
        center: [T; 3],
        radius: T,
    },
    /// `n · q_b − offset = 0`, `|n| = 1`.
    Plane {
        body: usize,
        normal: [T; 3],
        offset: T,
    },
}

/// A constraint term, its first row in `g`, and a label naming where it came from.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct ConstraintTerm<T = f64> {
    pub(crate) kind: ConstraintKind<T>,
    pub(crate) row: usize,
    pub(crate) label: String,
    /// Where the scene declares it (for errors).
    pub(crate) path: super::error::FieldPath,
}

impl<T> ConstraintTerm<T> {
    /// Number of rows (`d` for a pin, 1 otherwise).
    pub(crate) fn rows(&self, d: usize) -> usize {
        match self.kind {
            ConstraintKind::Pin { .. } => d,
            _ => 1,
        }
    }
}

/// The merged per-body coefficients of one kind of `M` term (damping `c_b` or `e_b B`).
#[derive(Debug)]
pub(crate) struct StructureTerm<P> {
    pub(crate) label: String,
    pub(crate) per_body: Vec<P>,
    pub(crate) counter: Counter,
}

/// The free flight of one body under `M`: what its kinetic flow has to do.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Flight<T> {
    /// `q += t p/m`.
    Drift,
    /// The closed form with `γ = c/m` and `ω⃗ = e B/m`.
    Exact { gamma: T, omega: [T; 3] },
}

/// A scene's assembled model. It implements [`Hamiltonian`], [`StructureMatrix`] and
/// [`HolonomicConstraint`] with only the declared terms, and provides the exact sub-flows
/// ([`kick`](Self::kick), [`free_flight`](Self::free_flight)).
#[derive(Debug)]
pub struct SceneModel<T = f64> {
    pub(crate) dim: usize,
    pub(crate) masses: Vec<T>,
    pub(crate) inv_masses: Vec<T>,
    pub(crate) potentials: Vec<PotentialTerm<T>>,
    pub(crate) constraints: Vec<ConstraintTerm<T>>,
    pub(crate) m: usize,
    pub(crate) damping: Option<StructureTerm<T>>,
    pub(crate) magnetic: Option<StructureTerm<[T; 3]>>,
    pub(crate) kinetic: Counter,
    pub(crate) constraint_counter: Counter,
    /// Time each evaluation (the `profile` diagnostic).
    pub(crate) profile: bool,
    /// Provide `jacobian_entries` (sparse multiplier systems); off for `m ≤ 4`, where the
    /// projection's small dense path is faster.
    pub(crate) sparse: bool,
    flights: Vec<Flight<T>>,
}

impl<T: Real> SceneModel<T> {
    /// Builds the model from its parts (the compiler has validated them).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn new(
        dim: usize,
        masses: Vec<T>,
        potentials: Vec<PotentialTerm<T>>,
        constraints: Vec<ConstraintTerm<T>>,
        damping: Option<StructureTerm<T>>,
        magnetic: Option<StructureTerm<[T; 3]>>,
        profile: bool,
    ) -> Self {
        let inv_masses: Vec<T> = masses.iter().map(|&m| T::one() / m).collect();
        let m = constraints.iter().map(|c| c.rows(dim)).sum();
        let flights = (0..masses.len())
            .map(|b| {
                let c = damping.as_ref().map_or(T::lit(0.0), |t| t.per_body[b]);
                let eb = magnetic
                    .as_ref()
                    .map_or([T::lit(0.0); 3], |t| t.per_body[b]);
                if c == T::lit(0.0) && eb == [T::lit(0.0); 3] {
                    Flight::Drift
                } else {
                    let w = inv_masses[b];
                    Flight::Exact {
                        gamma: c * w,
                        omega: [eb[0] * w, eb[1] * w, eb[2] * w],
                    }
                }
            })
            .collect();
        Self {
            dim,
            masses,
            inv_masses,
            potentials,
            constraints,
            m,
            damping,
            magnetic,
            kinetic: Counter::default(),
            constraint_counter: Counter::default(),
            profile,
            sparse: m > 4,
            flights,
        }
    }

    /// Keeps the constraint terms whose index passes `keep`, renumbering their rows.
    pub(crate) fn retain_constraints(&mut self, keep: impl Fn(usize) -> bool) {
        let dim = self.dim;
        let mut row = 0;
        let old = std::mem::take(&mut self.constraints);
        self.constraints = old
            .into_iter()
            .enumerate()
            .filter(|(i, _)| keep(*i))
            .map(|(_, mut t)| {
                t.row = row;
                row += t.rows(dim);
                t
            })
            .collect();
        self.m = row;
        self.sparse = row > 4;
    }

    /// Number of bodies.
    pub fn bodies(&self) -> usize {
        self.masses.len()
    }
    /// Dimension of the space (2 or 3).
    pub fn space_dim(&self) -> usize {
        self.dim
    }
    /// Length of the state `x = (q, p)`: `2 d N`.
    pub fn state_len(&self) -> usize {
        2 * self.dim * self.masses.len()
    }
    /// Number of constraint rows `m` (the length of `g`).
    pub fn constraint_rows(&self) -> usize {
        self.m
    }
    /// The inverse masses `1/m_b`, one per body (`W⁻¹` is `1/m_b` on each of body `b`'s `d`
    /// coordinates).
    pub fn inv_masses(&self) -> &[T] {
        &self.inv_masses
    }

    /// `out_i += vᵀ ∇²g_i(q) v` for velocities `v = W⁻¹ p` (length `d N`): the term of
    /// `d²g/dt² = G q̈ + vᵀ ∇²g v` that does not depend on the acceleration — `|v_a − v_b|²` for
    /// a rod, `|v_b|²` for a sphere, zero for planes and pins (their `g` is affine). It does not
    /// depend on `q`: every constraint's Hessian is constant.
    pub fn velocity_curvature_add(&self, v: &[T], out: &mut [T]) {
        let d = self.dim;
        for c in &self.constraints {
            let add = match c.kind {
                ConstraintKind::Rod { a, b, .. } => (0..d).fold(T::lit(0.0), |acc, k| {
                    let dv = v[a * d + k] - b.map_or(T::lit(0.0), |b| v[b * d + k]);
                    acc + dv * dv
                }),
                ConstraintKind::Sphere { body, .. } => (0..d).fold(T::lit(0.0), |acc, k| {
                    acc + v[body * d + k] * v[body * d + k]
                }),
                ConstraintKind::Pin { .. } | ConstraintKind::Plane { .. } => continue,
            };
            out[c.row] = out[c.row] + add;
        }
    }
    /// Zeroes every term's evaluation counter and clock.
    pub fn reset_counters(&self) {
        self.kinetic.reset();
        self.constraint_counter.reset();
        for t in &self.potentials {
            t.counter.reset();
        }
        if let Some(t) = &self.damping {
            t.counter.reset();
        }
        if let Some(t) = &self.magnetic {
            t.counter.reset();
        }
    }

    /// `true` if a damping term is assembled (`M` has a dissipative part).
    pub fn is_dissipative(&self) -> bool {
        self.damping.is_some()
    }
    /// `true` if the skew part `J` of `M` is canonical (no magnetic term is assembled).
    pub fn is_canonical(&self) -> bool {
        self.magnetic.is_none()
    }

    #[inline]
    fn timed<R>(&self, counter: &Counter, f: impl FnOnce() -> R) -> R {
        counter.hit();
        if self.profile {
            let t = Instant::now();
            let r = f();
            counter.add_time(t);
            r
        } else {
            f()
        }
    }

    /// `V(q)`, the sum of the potential terms.
    pub(crate) fn potential_energy(&self, q: &[T]) -> T {
        let d = self.dim;
        let mut v = T::lit(0.0);
        for term in &self.potentials {
            v = v + self.timed(&term.counter, || match &term.potential {
                Potential::Gravity { forces } => {
                    let mut e = T::lit(0.0);
                    for (b, f) in forces {
                        for k in 0..d {
                            e = e - (f[k] * q[b * d + k]);
                        }
                    }
                    e
                }
                Potential::Pairs { pairs, law } => {
                    let mut e = T::lit(0.0);
                    for &(a, b) in pairs {
                        e = e + (law.eval(distance(q, d, a, b)).0);
                    }
                    e
                }
                Potential::Trap {
                    stiffness,
                    center,
                    bodies,
                } => {
                    let mut e = T::lit(0.0);
                    for &b in bodies {
                        for k in 0..d {
                            let z = q[b * d + k] - center[k];
                            e = e + (z * z);
                        }
                    }
                    T::lit(0.5) * *stiffness * e
                }
            });
        }
        v
    }

    /// `out += α ∇V(q)`, `V` the sum of the potential terms (length `d N`: positions only).
    pub fn potential_gradient_add(&self, q: &[T], alpha: T, out: &mut [T]) {
        let d = self.dim;
        for term in &self.potentials {
            self.timed(&term.counter, || match &term.potential {
                Potential::Gravity { forces } => {
                    for (b, f) in forces {
                        for k in 0..d {
                            out[b * d + k] = out[b * d + k] - (alpha * f[k]);
                        }
                    }
                }
                Potential::Pairs { pairs, law } => {
                    for &(a, b) in pairs {
                        let r = distance(q, d, a, b);
                        let s = alpha * law.eval(r).1;
                        for k in 0..d {
                            let z = s * (q[a * d + k] - q[b * d + k]);
                            out[a * d + k] = out[a * d + k] + (z);
                            out[b * d + k] = out[b * d + k] - (z);
                        }
                    }
                }
                Potential::Trap {
                    stiffness,
                    center,
                    bodies,
                } => {
                    for &b in bodies {
                        for k in 0..d {
                            out[b * d + k] =
                                out[b * d + k] + (alpha * *stiffness * (q[b * d + k] - center[k]));
                        }
                    }
                }
            });
        }
    }

    /// `out += ∇²V(q) v`.
    fn potential_hessian_apply_add(&self, q: &[T], v: &[T], out: &mut [T]) {
        let d = self.dim;
        for term in &self.potentials {
            self.timed(&term.counter, || match &term.potential {
                Potential::Gravity { .. } => {}
                Potential::Pairs { pairs, law } => {
                    for &(a, b) in pairs {
                        let r = distance(q, d, a, b);
                        let (_, d1, d2) = law.eval(r);
                        // ∇²φ u = (φ'/r) u + (φ'' − φ'/r) (r̂·u) r̂, u = v_a − v_b.
                        let mut ru = T::lit(0.0);
                        for k in 0..d {
                            ru = ru
                                + ((q[a * d + k] - q[b * d + k]) * (v[a * d + k] - v[b * d + k]));
                        }
                        // A zero-length spring has d2 = d1: no radial term (and no 0/0 at r = 0).
                        let s = if d2 == d1 {
                            T::lit(0.0)
                        } else {
                            (d2 - d1) * ru / (r * r)
                        };
                        for k in 0..d {
                            let z = d1 * (v[a * d + k] - v[b * d + k])
                                + s * (q[a * d + k] - q[b * d + k]);
                            out[a * d + k] = out[a * d + k] + (z);
                            out[b * d + k] = out[b * d + k] - (z);
                        }
                    }
                }
                Potential::Trap {
                    stiffness, bodies, ..
                } => {
                    for &b in bodies {
                        for k in 0..d {
                            out[b * d + k] = out[b * d + k] + (*stiffness * v[b * d + k]);
                        }
                    }
                }
            });
        }
    }

    /// The kick `p ← p − t ∇V(q)`: the exact flow of all potential terms together. `scratch`
    /// holds `dN` entries.
    pub fn kick(&self, t: T, x: &mut [T], scratch: &mut [T]) {
        let nq = self.dim * self.masses.len();
        let (q, p) = x.split_at_mut(nq);
        scratch.fill(T::lit(0.0));
        self.potential_gradient_add(q, T::lit(1.0), scratch);
        for (pi, gi) in p.iter_mut().zip(scratch.iter()) {
            *pi = *pi - (t * *gi);
        }
    }

    /// The exact flow of the kinetic term under `M` for time `t`: per body, `q' = v = p/m`,
    /// `p' = e v × B − c v`. With `γ = c/m`, `ω⃗ = e B/m = ω b̂`, `p = p∥ + p⊥` along and
    /// across `b̂`, `w = b̂ × p⊥` and `z = −γ + iω`:
    ///
    /// ```text
    /// p(t) = e^{−γt} (p∥ + cos(ωt) p⊥ − sin(ωt) w),
    /// q(t) = q + (1/m) (φ∥ p∥ + a p⊥ − b w),   φ∥ = (1 − e^{−γt})/γ,   a + ib = (e^{zt} − 1)/z,
    /// ```
    ///
    /// evaluated without cancellation (`expm1`, `1 − cos = 2 sin²`). Bodies without field and
    /// damping take the plain drift `q += t p/m`.
    pub fn free_flight(&self, t: T, x: &mut [T]) {
        let d = self.dim;
        let nq = d * self.masses.len();
        let (q, p) = x.split_at_mut(nq);
        self.kinetic.hit();
        if let Some(damping) = &self.damping {
            damping.counter.hit();
        }
        if let Some(magnetic) = &self.magnetic {
            magnetic.counter.hit();
        }
        for (b, flight) in self.flights.iter().enumerate() {
            let w = self.inv_masses[b];
            let (qb, pb) = (&mut q[b * d..b * d + d], &mut p[b * d..b * d + d]);
            match *flight {
                Flight::Drift => {
                    for k in 0..d {
                        qb[k] = qb[k] + (t * w * pb[k]);
                    }
                }
                Flight::Exact { gamma, omega } => {
                    let mut p3 = [T::lit(0.0); 3];
                    p3[..d].copy_from_slice(pb);
                    let (dq, pn) = exact_flight(gamma, omega, t, p3);
                    for k in 0..d {
                        qb[k] = qb[k] + (w * dq[k]);
                    }
                    pb.copy_from_slice(&pn[..d]);
                }
            }
        }
    }
}

/// The free flight of one body with `γ`, `ω⃗` for time `t` from momentum `p`: `(∫₀ᵗ p(s) ds, p(t))`.
fn exact_flight<T: Real>(gamma: T, omega: [T; 3], t: T, p: [T; 3]) -> ([T; 3], [T; 3]) {
    let decay = (-gamma * t).exp();
    // φ∥ = ∫₀ᵗ e^{−γs} ds.
    let phi_par = if gamma == T::lit(0.0) {
        t
    } else {
        -(-gamma * t).exp_m1() / gamma
    };
    let om = (omega[0] * omega[0] + omega[1] * omega[1] + omega[2] * omega[2]).sqrt();
    if om == T::lit(0.0) {
        return (p.map(|pk| phi_par * pk), p.map(|pk| decay * pk));
    }
    let bh = omega.map(|o| o / om);
    let along = bh[0] * p[0] + bh[1] * p[1] + bh[2] * p[2];
    let par = bh.map(|b| along * b);
    let perp = [p[0] - par[0], p[1] - par[1], p[2] - par[2]];
    let w = cross(bh, perp);
    let (s, c) = (om * t).sin_cos();
    let half = (T::lit(0.5) * om * t).sin();
    // e^{zt} − 1 = (e^{−γt} cos ωt − 1) + i e^{−γt} sin ωt, the real part without cancellation.
    let nr = (-gamma * t).exp_m1() * c - T::lit(2.0) * half * half;
    let ni = decay * s;
    // (nr + i ni) / z with z scaled by s = max(γ, ω) first, so that a field so weak that
    // γ² + ω² underflows still divides correctly.
    let scale = gamma.max(om);
    let (zr, zi) = (-gamma / scale, om / scale);
    let den = (zr * zr + zi * zi) * scale;
    let a = (zr * nr + zi * ni) / den;
    let bb = (zr * ni - zi * nr) / den;
    let mut dq = [T::lit(0.0); 3];
    let mut pn = [T::lit(0.0); 3];
    for k in 0..3 {
        dq[k] = phi_par * par[k] + a * perp[k] - bb * w[k];
        pn[k] = decay * (par[k] + c * perp[k] - s * w[k]);
    }
    (dq, pn)
}

#[inline]
fn cross<T: Real>(a: [T; 3], b: [T; 3]) -> [T; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

#[inline]
fn distance<T: Real>(q: &[T], d: usize, a: usize, b: usize) -> T {
    let mut s = T::lit(0.0);
    for k in 0..d {
        let z = q[a * d + k] - q[b * d + k];
        s = s + (z * z);
    }
    s.sqrt()
}

impl SceneModel<f64> {
    /// The same model in another scalar (e.g. double-double for reference runs): every
    /// parameter rounded to `T`, fresh counters, no profiling.
    pub fn with_scalar<T: Real>(&self) -> SceneModel<T> {
        let c = |x: f64| T::lit(x);
        let c3 = |v: [f64; 3]| v.map(T::lit);
        let law = |l: &PairLaw| match *l {
            PairLaw::InversePower { strength, power } => PairLaw::InversePower {
                strength: c(strength),
                power: c(power),
            },
            PairLaw::Log { strength } => PairLaw::Log {
                strength: c(strength),
            },
            PairLaw::LennardJones { epsilon, sigma } => PairLaw::LennardJones {
                epsilon: c(epsilon),
                sigma: c(sigma),
            },
            PairLaw::Spring { stiffness, rest } => PairLaw::Spring {
                stiffness: c(stiffness),
                rest: c(rest),
            },
        };
        let potentials = self
            .potentials
            .iter()
            .map(|t| PotentialTerm {
                label: t.label.clone(),
                kind: t.kind,
                potential: match &t.potential {
                    Potential::Gravity { forces } => Potential::Gravity {
                        forces: forces.iter().map(|&(b, f)| (b, c3(f))).collect(),
                    },
                    Potential::Pairs { pairs, law: l } => Potential::Pairs {
                        pairs: pairs.clone(),
                        law: law(l),
                    },
                    Potential::Trap {
                        stiffness,
                        center,
                        bodies,
                    } => Potential::Trap {
                        stiffness: c(*stiffness),
                        center: c3(*center),
                        bodies: bodies.clone(),
                    },
                },
                counter: Counter::default(),
            })
            .collect();
        let constraints = self
            .constraints
            .iter()
            .map(|t| ConstraintTerm {
                kind: match t.kind {
                    ConstraintKind::Pin { body, point } => ConstraintKind::Pin {
                        body,
                        point: c3(point),
                    },
                    ConstraintKind::Rod {
                        a,
                        b,
                        point,
                        length,
                    } => ConstraintKind::Rod {
                        a,
                        b,
                        point: c3(point),
                        length: c(length),
                    },
                    ConstraintKind::Sphere {
                        body,
                        center,
                        radius,
                    } => ConstraintKind::Sphere {
                        body,
                        center: c3(center),
                        radius: c(radius),
                    },
                    ConstraintKind::Plane {
                        body,
                        normal,
                        offset,
                    } => ConstraintKind::Plane {
                        body,
                        normal: c3(normal),
                        offset: c(offset),
                    },
                },
                row: t.row,
                label: t.label.clone(),
                path: t.path.clone(),
            })
            .collect();
        let structure = |t: &StructureTerm<f64>| StructureTerm {
            label: t.label.clone(),
            per_body: t.per_body.iter().map(|&x| c(x)).collect(),
            counter: Counter::default(),
        };
        let field = |t: &StructureTerm<[f64; 3]>| StructureTerm {
            label: t.label.clone(),
            per_body: t.per_body.iter().map(|&x| c3(x)).collect(),
            counter: Counter::default(),
        };
        SceneModel::new(
            self.dim,
            self.masses.iter().map(|&m| c(m)).collect(),
            potentials,
            constraints,
            self.damping.as_ref().map(structure),
            self.magnetic.as_ref().map(field),
            false,
        )
    }
}

/// A constraint's geometry at `q`: the vector `u` such that the row's gradient is `u` at the
/// first body and `−u` at the second (if any), or for a pin the unit rows.
impl<T: Real> SceneModel<T> {
    #[inline]
    /// `g` of constraint term `index` at positions `q`, for the single-row kinds (rod, sphere,
    /// plane); `None` for a pin.
    pub(crate) fn term_residual(&self, q: &[T], index: usize) -> Option<T> {
        self.single_row_residual(q, &self.constraints[index].kind)
    }

    /// `g` of a single-row constraint (rod, sphere, plane) at positions `q`; `None` for a pin.
    fn single_row_residual(&self, q: &[T], kind: &ConstraintKind<T>) -> Option<T> {
        let half = T::lit(0.5);
        match kind {
            ConstraintKind::Rod {
                a,
                b,
                point,
                length,
            } => {
                let u = self.rod_vector(q, *a, *b, point);
                Some(half * (dot3(u, u) - *length * *length))
            }
            ConstraintKind::Sphere {
                body,
                center,
                radius,
            } => {
                let u = self.rod_vector(q, *body, None, center);
                Some(half * (dot3(u, u) - *radius * *radius))
            }
            ConstraintKind::Plane {
                body,
                normal,
                offset,
            } => {
                let s =
                    (0..self.dim).fold(T::lit(0.0), |s, k| s + normal[k] * q[body * self.dim + k]);
                Some(s - *offset)
            }
            ConstraintKind::Pin { .. } => None,
        }
    }

    fn rod_vector(&self, q: &[T], a: usize, b: Option<usize>, point: &[T; 3]) -> [T; 3] {
        let d = self.dim;
        let mut u = [T::lit(0.0); 3];
        for k in 0..d {
            let r = match b {
                Some(b) => q[b * d + k],
                None => point[k],
            };
            u[k] = q[a * d + k] - r;
        }
        u
    }
}

impl<T: Real, V: Vector<Real = T>> Hamiltonian<V> for Arc<SceneModel<T>> {
    fn energy(&self, x: &V) -> T {
        let x = x.as_slice();
        let nq = self.dim * self.masses.len();
        let (q, p) = x.split_at(nq);
        let d = self.dim;
        let mut t = T::lit(0.0);
        self.kinetic.hit();
        for (b, w) in self.inv_masses.iter().enumerate() {
            let mut s = T::lit(0.0);
            for k in 0..d {
                s = s + (p[b * d + k] * p[b * d + k]);
            }
            t = t + (T::lit(0.5) * *w * s);
        }
        t + self.potential_energy(q)
    }

    fn gradient(&self, x: &V, out: &mut V) {
        let x = x.as_slice();
        let nq = self.dim * self.masses.len();
        let (q, p) = x.split_at(nq);
        let out = out.as_mut_slice();
        let (oq, op) = out.split_at_mut(nq);
        oq.fill(T::lit(0.0));
        self.potential_gradient_add(q, T::lit(1.0), oq);
        self.kinetic.hit();
        let d = self.dim;
        for (b, w) in self.inv_masses.iter().enumerate() {
            for k in 0..d {
                op[b * d + k] = *w * p[b * d + k];
            }
        }
    }

    fn hessian_apply(&self, x: &V, v: &V, out: &mut V) -> bool {
        let nq = self.dim * self.masses.len();
        let q = &x.as_slice()[..nq];
        let v = v.as_slice();
        let out = out.as_mut_slice();
        let (oq, op) = out.split_at_mut(nq);
        oq.fill(T::lit(0.0));
        self.potential_hessian_apply_add(q, &v[..nq], oq);
        let d = self.dim;
        for (b, w) in self.inv_masses.iter().enumerate() {
            for k in 0..d {
                op[b * d + k] = *w * v[nq + b * d + k];
            }
        }
        true
    }

    fn is_quadratic(&self) -> bool {
        self.potentials.iter().all(|t| {
            matches!(
                t.potential,
                Potential::Gravity { .. } | Potential::Trap { .. }
            )
        })
    }
}

impl<T: Real, V: Vector<Real = T>> StructureMatrix<V> for Arc<SceneModel<T>> {
    fn apply_add(&self, _x: &V, v: &V, alpha: T, out: &mut V) {
        let v = v.as_slice();
        let out = out.as_mut_slice();
        let nq = v.len() / 2;
        let (oq, op) = out.split_at_mut(nq);
        let (vq, vp) = v.split_at(nq);
        for (o, x) in oq.iter_mut().zip(vp) {
            *o = *o + (alpha * *x);
        }
        for (o, x) in op.iter_mut().zip(vq) {
            *o = *o - (alpha * *x);
        }
        let d = self.dim;
        if let Some(damping) = &self.damping {
            damping.counter.hit();
            for (b, c) in damping.per_body.iter().enumerate() {
                for k in 0..d {
                    op[b * d + k] = op[b * d + k] - (alpha * *c * vp[b * d + k]);
                }
            }
        }
        if let Some(magnetic) = &self.magnetic {
            magnetic.counter.hit();
            // out_p += α v × (e B), written out per dimension (a stack temporary here costs a
            // store-forwarding stall per body).
            for (b, eb) in magnetic.per_body.iter().enumerate() {
                let i = b * d;
                if d == 2 {
                    op[i] = op[i] + (alpha * vp[i + 1] * eb[2]);
                    op[i + 1] = op[i + 1] - (alpha * vp[i] * eb[2]);
                } else {
                    let (vx, vy, vz) = (vp[i], vp[i + 1], vp[i + 2]);
                    op[i] = op[i] + (alpha * (vy * eb[2] - vz * eb[1]));
                    op[i + 1] = op[i + 1] + (alpha * (vz * eb[0] - vx * eb[2]));
                    op[i + 2] = op[i + 2] + (alpha * (vx * eb[1] - vy * eb[0]));
                }
            }
        }
    }

    fn is_constant(&self) -> bool {
        true
    }

    fn is_dissipative(&self) -> bool {
        self.damping.is_some()
    }
}

#[allow(clippy::misnamed_getters)] // `dim` is the number of constraints `m`.
impl<T: Real, V: Vector<Real = T>> HolonomicConstraint<V> for Arc<SceneModel<T>> {
    fn dim(&self) -> usize {
        self.m
    }

    fn residual(&self, x: &V, out: &mut [T]) {
        let q = x.as_slice();
        let d = self.dim;
        self.timed(&self.constraint_counter, || {
            for c in &self.constraints {
                let r = c.row;
                match &c.kind {
                    ConstraintKind::Pin { body, point } => {
                        for k in 0..d {
                            out[r + k] = q[body * d + k] - point[k];
                        }
                    }
                    kind => {
                        out[r] = self
                            .single_row_residual(q, kind)
                            .expect("rods, spheres and planes are single rows");
                    }
                }
            }
        });
    }

    fn jacobian_apply(&self, x: &V, v: &V, out: &mut [T]) {
        let v = v.as_slice();
        let d = self.dim;
        self.timed(&self.constraint_counter, || {
            out.fill(T::lit(0.0));
            self.for_each_gradient(x.as_slice(), |row, body, coef| {
                for k in 0..d {
                    out[row] = out[row] + (coef[k] * v[body * d + k]);
                }
            });
        });
    }

    fn jacobian_transpose_apply_add(&self, x: &V, mu: &[T], alpha: T, out: &mut V) {
        let out = out.as_mut_slice();
        let d = self.dim;
        self.timed(&self.constraint_counter, || {
            self.for_each_gradient(x.as_slice(), |row, body, coef| {
                let s = alpha * mu[row];
                for k in 0..d {
                    out[body * d + k] = out[body * d + k] + (s * coef[k]);
                }
            });
        });
    }

    fn jacobian_entries(&self, x: &V, sink: &mut dyn Sink<T>) -> bool {
        if !self.sparse {
            return false;
        }
        let d = self.dim;
        self.for_each_gradient(x.as_slice(), |row, body, coef| {
            for k in 0..d {
                sink.add(row, body * d + k, coef[k]);
            }
        });
        true
    }
}

impl<T: Real> SceneModel<T> {
    /// Calls `f(row, body, c)` for every body a row of `G(q)` touches, with `c` the row's
    /// gradient with respect to that body's position: a rod `(|u|² − L²)/2` gives `u` and `−u`
    /// (`u = q_a − q_b`), a sphere `u = q − c`, a plane `n`, a pin the unit vectors. `G v`,
    /// `Gᵀ μ` and the Jacobian entries are all written through it, so they cannot disagree.
    #[inline]
    pub(crate) fn for_each_gradient(&self, q: &[T], mut f: impl FnMut(usize, usize, [T; 3])) {
        for c in &self.constraints {
            let r = c.row;
            match &c.kind {
                ConstraintKind::Pin { body, .. } => {
                    for k in 0..self.dim {
                        let mut e = [T::lit(0.0); 3];
                        e[k] = T::lit(1.0);
                        f(r + k, *body, e);
                    }
                }
                ConstraintKind::Rod { a, b, point, .. } => {
                    let u = self.rod_vector(q, *a, *b, point);
                    f(r, *a, u);
                    if let Some(b) = b {
                        f(r, *b, u.map(|x| -x));
                    }
                }
                ConstraintKind::Sphere { body, center, .. } => {
                    f(r, *body, self.rod_vector(q, *body, None, center));
                }
                ConstraintKind::Plane { body, normal, .. } => f(r, *body, *normal),
            }
        }
    }
}

#[inline]
fn dot3<T: Real>(a: [T; 3], b: [T; 3]) -> T {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
