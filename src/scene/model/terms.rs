//! The terms a scene assembles: potentials (gravity, springs, pair laws, traps), constraint
//! kinds with their rows, and the merged per-body coefficients of `M`'s terms.

use super::{Counter, EffectKind};
use crate::real::Real;

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
    pub(super) fn eval(self, r: T) -> (T, T, T) {
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
    pub(crate) path: crate::scene::error::FieldPath,
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
