//! Radial pair terms, `Σ φ(|q_a − q_b|)` over listed pairs: the laws `φ` (inverse powers, the
//! logarithm, Lennard-Jones', the spring's) and the pairwise kernel of value, gradient and
//! Hessian product, shared by the `pair` and `spring` effects.

use super::PotentialOps;
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

impl<T: Real> PairLaw<T> {
    /// `φ(r') − φ(r)`: for a spring `k/2 (r' − r)(r' + r − 2L)`, otherwise the difference
    /// (the logarithm's is summed over all pairs at once by `Pairs`).
    #[inline]
    fn difference(self, r: T, r2: T) -> T {
        match self {
            PairLaw::Spring { stiffness, rest } => {
                T::lit(0.5) * stiffness * (r2 - r) * (r2 + r - rest - rest)
            }
            _ => self.eval(r2).0 - self.eval(r).0,
        }
    }
}

/// `Σ φ(|q_a − q_b|)` over the listed pairs.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Pairs<T> {
    pairs: Vec<(usize, usize)>,
    law: PairLaw<T>,
}

impl<T> Pairs<T> {
    /// The pairs `(a, b)` under `law`.
    pub(super) fn new(pairs: Vec<(usize, usize)>, law: PairLaw<T>) -> Self {
        Self { pairs, law }
    }

    /// The pairs a spring law joins (none for another law), for a drawing (`scene::sketch`).
    pub(crate) fn springs(&self) -> impl Iterator<Item = (usize, usize)> + '_ {
        let spring = matches!(self.law, PairLaw::Spring { .. });
        self.pairs.iter().copied().filter(move |_| spring)
    }
}

#[inline]
fn distance2<T: Real>(q: &[T], d: usize, a: usize, b: usize) -> T {
    let mut s = T::lit(0.0);
    for k in 0..d {
        let z = q[a * d + k] - q[b * d + k];
        s = s + (z * z);
    }
    s
}

#[inline]
fn distance<T: Real>(q: &[T], d: usize, a: usize, b: usize) -> T {
    distance2(q, d, a, b).sqrt()
}

impl<T: Real> Pairs<T> {
    /// `out_a += c (q_a − q_b)`, `out_b −= c (q_a − q_b)` with `c = slope(|q_a − q_b|²)` for
    /// every pair, in `d = 3` and `d = 2` with the dimension known to the compiler.
    #[inline(always)]
    fn accumulate(&self, q: &[T], d: usize, out: &mut [T], slope: impl Fn(T) -> T) {
        match d {
            3 => self.accumulate_d::<3>(q, out, slope),
            2 => self.accumulate_d::<2>(q, out, slope),
            _ => {
                for &(a, b) in &self.pairs {
                    let c = slope(distance2(q, d, a, b));
                    for k in 0..d {
                        let z = c * (q[a * d + k] - q[b * d + k]);
                        out[a * d + k] = out[a * d + k] + z;
                        out[b * d + k] = out[b * d + k] - z;
                    }
                }
            }
        }
    }

    #[inline(always)]
    fn accumulate_d<const D: usize>(&self, q: &[T], out: &mut [T], slope: impl Fn(T) -> T) {
        for &(a, b) in &self.pairs {
            let qa: &[T; D] = q[a * D..a * D + D].try_into().expect("D components");
            let qb: &[T; D] = q[b * D..b * D + D].try_into().expect("D components");
            let z: [T; D] = core::array::from_fn(|k| qa[k] - qb[k]);
            let c = slope(z.iter().fold(T::lit(0.0), |s, &zk| s + zk * zk));
            let oa: &mut [T; D] = (&mut out[a * D..a * D + D]).try_into().expect("D");
            for k in 0..D {
                oa[k] = oa[k] + c * z[k];
            }
            let ob: &mut [T; D] = (&mut out[b * D..b * D + D]).try_into().expect("D");
            for k in 0..D {
                ob[k] = ob[k] - c * z[k];
            }
        }
    }
}

impl<T: Real> PotentialOps<T> for Pairs<T> {
    fn energy(&self, q: &[T], d: usize) -> T {
        let mut e = T::lit(0.0);
        for &(a, b) in &self.pairs {
            e = e + (self.law.eval(distance(q, d, a, b)).0);
        }
        e
    }
    /// The sum of the pairs' differences; for the logarithm `−(s/2) ln Π r'²/r²`, one
    /// logarithm for all pairs (the product renormalized into the log before it could leave
    /// `[2⁻⁵⁰⁰, 2⁵⁰⁰]`; each factor is near 1 for a step).
    fn energy_difference(&self, q: &[T], q2: &[T], d: usize) -> T {
        if let PairLaw::Log { strength } = self.law {
            let (lo, hi) = (T::lit(2f64.powi(-500)), T::lit(2f64.powi(500)));
            let (mut product, mut logs) = (T::lit(1.0), T::lit(0.0));
            for &(a, b) in &self.pairs {
                product = product * (distance2(q2, d, a, b) / distance2(q, d, a, b));
                if !(lo..=hi).contains(&product) {
                    logs = logs + product.ln();
                    product = T::lit(1.0);
                }
            }
            return -T::lit(0.5) * strength * (logs + product.ln());
        }
        let mut e = T::lit(0.0);
        for &(a, b) in &self.pairs {
            e = e + self
                .law
                .difference(distance(q, d, a, b), distance(q2, d, a, b));
        }
        e
    }
    /// One pass over the pairs with the law's `φ'(r)/r` as a function of `r²` chosen once
    /// ([`PairLaw::slope`]): no branch per pair, and no square root for the laws that are
    /// functions of `r²` (the logarithm, Lennard-Jones', even powers).
    fn gradient_add(&self, q: &[T], d: usize, alpha: T, out: &mut [T]) {
        match self.law {
            PairLaw::Log { strength } => {
                let c = -(alpha * strength);
                self.accumulate(q, d, out, |r2| c / r2);
            }
            PairLaw::LennardJones { epsilon, sigma } => {
                let (c, s2) = (T::lit(4.0) * alpha * epsilon, sigma * sigma);
                self.accumulate(q, d, out, |r2| {
                    let inv_r2 = T::lit(1.0) / r2;
                    let x = s2 * inv_r2;
                    let s6 = x * x * x;
                    c * (s6 * (T::lit(6.0) - T::lit(12.0) * s6)) * inv_r2
                });
            }
            law => self.accumulate(q, d, out, |r2| alpha * law.eval(r2.sqrt()).1),
        }
    }
    fn hessian_apply_add(&self, q: &[T], d: usize, v: &[T], out: &mut [T]) {
        for &(a, b) in &self.pairs {
            let r = distance(q, d, a, b);
            let (_, d1, d2) = self.law.eval(r);
            // ∇²φ u = (φ'/r) u + (φ'' − φ'/r) (r̂·u) r̂, u = v_a − v_b.
            let mut ru = T::lit(0.0);
            for k in 0..d {
                ru = ru + ((q[a * d + k] - q[b * d + k]) * (v[a * d + k] - v[b * d + k]));
            }
            // A zero-length spring has d2 = d1: no radial term (and no 0/0 at r = 0).
            let s = if d2 == d1 {
                T::lit(0.0)
            } else {
                (d2 - d1) * ru / (r * r)
            };
            for k in 0..d {
                let z = d1 * (v[a * d + k] - v[b * d + k]) + s * (q[a * d + k] - q[b * d + k]);
                out[a * d + k] = out[a * d + k] + (z);
                out[b * d + k] = out[b * d + k] - (z);
            }
        }
    }
    /// Radial laws are not quadratic in `q` (a zero-length spring is, but is not told apart).
    fn is_quadratic(&self) -> bool {
        false
    }
    fn hessian_bodies(&self, out: &mut Vec<(usize, usize)>) {
        for &(a, b) in &self.pairs {
            out.extend([(a, a), (a, b), (b, a), (b, b)]);
        }
    }
}

impl Pairs<f64> {
    pub(crate) fn with_scalar<U: Real>(&self) -> Pairs<U> {
        let c = U::lit;
        let law = match self.law {
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
        Pairs {
            pairs: self.pairs.clone(),
            law,
        }
    }
}

#[cfg(test)]
#[path = "radial_tests.rs"]
mod tests;
