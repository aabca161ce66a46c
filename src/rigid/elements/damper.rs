//! A damper on a joint's rate, acting along the constraint-consistent direction
//! (`../shared/docs/METHOD.md` §8, "the trap").
//!
//! The rate is `u = wᵀM⁻¹p` with `w = ∇θ`. A damper force along `w` itself fights the
//! constraints wherever `w` has a part the joints forbid: the step drops to order 1 and part of
//! the dissipated energy vanishes unbooked inside the projection. Along the consistent
//! direction
//!
//! ```text
//! w̃ = w − Gᵀ S⁻¹ G M⁻¹ w,     S = G M⁻¹ Gᵀ
//! ```
//!
//! (`M⁻¹`-orthogonal to every constraint force) the frozen-position flow is exact and forward:
//! with `a = w̃ᵀM⁻¹w̃` and `u = w̃ᵀM⁻¹p`, `u' = −c a u`, so
//!
//! ```text
//! p ← p − (1 − e^{−c a τ}) (u/a) w̃,     removed ½ (u²/a)(1 − e^{−2 c a τ}).
//! ```
//!
//! A projection's impulse `Gᵀλ` has no part along `w̃`: nothing is booked for it.

use super::HingeAngle;
use crate::real::Real;
use crate::rigid::rows::QuadraticRows;

/// A damper of coefficient `c` on a hinge's angle (see the module documentation).
#[derive(Debug, Clone, PartialEq)]
pub struct JointDamper {
    pub(crate) angle: HingeAngle,
    pub(crate) coefficient: f64,
}

/// Scratch of the consistent direction: `w` and `w̃` (positions), `G M⁻¹ w` and `S`.
#[derive(Debug, Clone, Default)]
pub(crate) struct DamperScratch<T> {
    w: Vec<T>,
    t: Vec<T>,
    rhs: Vec<T>,
    unit: Vec<T>,
    col: Vec<T>,
    s: Vec<T>,
}

impl JointDamper {
    /// The exact flow over `tau` from positions `q` on the momenta `p` (`inv` the inverse mass
    /// of each position, `rows` the model's constraints); returns the energy removed.
    pub(crate) fn flow<T: Real>(
        &self,
        q: &[T],
        p: &mut [T],
        tau: T,
        rows: &QuadraticRows<T>,
        inv: &[T],
        scratch: &mut DamperScratch<T>,
    ) -> T {
        let nq = q.len();
        let m = rows.count();
        let DamperScratch {
            w,
            t,
            rhs,
            unit,
            col,
            s,
        } = scratch;
        w.clear();
        w.resize(nq, T::zero());
        self.angle.gradient_add(q, T::one(), w);
        if m > 0 {
            // rhs = G M⁻¹ w; S = G M⁻¹ Gᵀ column by column.
            t.clear();
            t.extend(w.iter().zip(inv).map(|(&a, &b)| a * b));
            rhs.resize(m, T::zero());
            rows.apply_positions(q, t, rhs);
            s.clear();
            s.resize(m * m, T::zero());
            unit.clear();
            unit.resize(m, T::zero());
            col.resize(m, T::zero());
            for j in 0..m {
                unit[j] = T::one();
                t.iter_mut().for_each(|v| *v = T::zero());
                rows.transpose_add_positions(q, unit, T::one(), t);
                for (v, &b) in t.iter_mut().zip(inv) {
                    *v = *v * b;
                }
                rows.apply_positions(q, t, col);
                for i in 0..m {
                    s[i * m + j] = col[i];
                }
                unit[j] = T::zero();
            }
            if cholesky_solve(s, m, rhs) {
                // w̃ = w − Gᵀ μ.
                rows.transpose_add_positions(q, rhs, -T::one(), w);
            }
        }
        let (mut u, mut a) = (T::zero(), T::zero());
        for ((&wi, &pi), &b) in w.iter().zip(p.iter()).zip(inv) {
            u = u + wi * b * pi;
            a = a + wi * b * wi;
        }
        if a <= T::zero() {
            return T::zero();
        }
        let c = T::lit(self.coefficient);
        let decay = -(-c * a * tau).exp_m1();
        let decay2 = -(T::lit(-2.0) * c * a * tau).exp_m1();
        let k = decay * u / a;
        for (pi, &wi) in p.iter_mut().zip(w.iter()) {
            *pi = *pi - k * wi;
        }
        T::lit(0.5) * u * u / a * decay2
    }
}

/// Solves `S x = b` in place for a symmetric positive definite `S` (`m × m`, row-major,
/// overwritten by its Cholesky factor); `false` when it is not positive definite.
fn cholesky_solve<T: Real>(s: &mut [T], m: usize, b: &mut [T]) -> bool {
    for j in 0..m {
        let mut d = s[j * m + j];
        for k in 0..j {
            d = d - s[j * m + k] * s[j * m + k];
        }
        if d.is_nan() || d <= T::zero() {
            return false;
        }
        let d = d.sqrt();
        s[j * m + j] = d;
        for i in j + 1..m {
            let mut v = s[i * m + j];
            for k in 0..j {
                v = v - s[i * m + k] * s[j * m + k];
            }
            s[i * m + j] = v / d;
        }
    }
    for i in 0..m {
        let mut v = b[i];
        for k in 0..i {
            v = v - s[i * m + k] * b[k];
        }
        b[i] = v / s[i * m + i];
    }
    for i in (0..m).rev() {
        let mut v = b[i];
        for k in i + 1..m {
            v = v - s[k * m + i] * b[k];
        }
        b[i] = v / s[i * m + i];
    }
    true
}
