//! A harmonic trap, `V = k/2 Σ_b |q_b − c|²`, and its generalization with a rest length `L`,
//! `V = k/2 Σ_b (|q_b − c| − L)²`: a spring from each body to the fixed point `c` (declared as
//! a `spring` with one body and a `point`).

use super::{Assembler, Effect, Potential, PotentialOps};
use crate::real::Real;
use crate::scene::error::FieldPath;
use crate::scene::names::Flag;
use crate::scene::validate::Result;
use crate::scene::validate::{non_negative, vector_or};
use serde::Deserialize;

/// `type = "trap"`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrapSpec {
    /// Label in summaries (default `trap`).
    #[serde(default)]
    pub name: Option<String>,
    /// Stiffness `k ≥ 0`.
    pub stiffness: f64,
    /// Centre (default: the origin).
    #[serde(default)]
    pub center: Option<Vec<f64>>,
    /// Bodies it acts on (default: all).
    #[serde(default)]
    pub bodies: Option<Vec<String>>,
}

/// `k`, `c`, the rest length `L` (0 for a trap) and the bodies held.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Trap<T> {
    stiffness: T,
    center: [T; 3],
    bodies: Vec<usize>,
    rest: T,
}

impl Trap<f64> {
    /// A spring of stiffness `k` and rest length `rest` from each of `bodies` to `point`.
    pub(crate) fn anchored(stiffness: f64, point: [f64; 3], rest: f64, bodies: Vec<usize>) -> Self {
        Self {
            stiffness,
            center: point,
            bodies,
            rest,
        }
    }
}

impl<T: Copy> Trap<T> {
    /// Its centre and the bodies it pulls towards it (for a drawing: `scene::sketch`).
    pub(crate) fn ends(&self) -> ([T; 3], &[usize]) {
        (self.center, &self.bodies)
    }
}

impl<T: Real> Trap<T> {
    /// `(r = |q_b − c|, 1 − L/r)` for body `b`: the gradient is `k (1 − L/r)(q_b − c)`. At
    /// `r = 0` with `L > 0` the spring has no direction: its force is taken as zero there.
    #[inline]
    fn stretch(&self, q: &[T], d: usize, b: usize) -> (T, T) {
        if self.rest == T::lit(0.0) {
            return (T::lit(0.0), T::lit(1.0));
        }
        let mut r2 = T::lit(0.0);
        for k in 0..d {
            let z = q[b * d + k] - self.center[k];
            r2 = r2 + z * z;
        }
        let r = r2.sqrt();
        if r == T::lit(0.0) {
            (r, T::lit(0.0))
        } else {
            (r, T::lit(1.0) - self.rest / r)
        }
    }
}

impl Effect for TrapSpec {
    const FLAG: Flag = Flag::Trap;
    fn assemble(
        &self,
        cx: &mut Assembler<'_>,
        path: &FieldPath,
        _label: &str,
        _on: bool,
    ) -> Result<Option<Potential<f64>>> {
        Ok(Some(Potential::Trap(Trap {
            stiffness: non_negative(self.stiffness, &path.key("stiffness"), "stiffness")?,
            center: vector_or(&self.center, cx.dim, &path.key("center"), [0.0; 3])?,
            bodies: cx.bodies.select_opt(&self.bodies, &path.key("bodies"))?,
            rest: 0.0,
        })))
    }
}

impl<T: Real> PotentialOps<T> for Trap<T> {
    fn energy(&self, q: &[T], d: usize) -> T {
        let mut e = T::lit(0.0);
        for &b in &self.bodies {
            if self.rest == T::lit(0.0) {
                for k in 0..d {
                    let z = q[b * d + k] - self.center[k];
                    e = e + (z * z);
                }
            } else {
                let (r, _) = self.stretch(q, d, b);
                e = e + (r - self.rest) * (r - self.rest);
            }
        }
        T::lit(0.5) * self.stiffness * e
    }
    fn gradient_add(&self, q: &[T], d: usize, alpha: T, out: &mut [T]) {
        for &b in &self.bodies {
            let (_, f) = self.stretch(q, d, b);
            let s = alpha * self.stiffness * f;
            for k in 0..d {
                out[b * d + k] = out[b * d + k] + (s * (q[b * d + k] - self.center[k]));
            }
        }
    }
    /// `k [(1 − L/r) v + (L/r) u (u·v)]` per body, `u = (q_b − c)/r` (`k v` for a trap).
    fn hessian_apply_add(&self, q: &[T], d: usize, v: &[T], out: &mut [T]) {
        for &b in &self.bodies {
            let (r, f) = self.stretch(q, d, b);
            for k in 0..d {
                out[b * d + k] = out[b * d + k] + (self.stiffness * f * v[b * d + k]);
            }
            if self.rest != T::lit(0.0) && r != T::lit(0.0) {
                let mut zv = T::lit(0.0);
                for k in 0..d {
                    zv = zv + (q[b * d + k] - self.center[k]) * v[b * d + k];
                }
                // (L/r) u (u·v) = (L/r³) z (z·v).
                let s = self.stiffness * self.rest / (r * r * r) * zv;
                for k in 0..d {
                    out[b * d + k] = out[b * d + k] + (s * (q[b * d + k] - self.center[k]));
                }
            }
        }
    }
    /// Quadratic in `q` for a trap (`L = 0`); a spring with a rest length is not.
    fn is_quadratic(&self) -> bool {
        self.rest == T::lit(0.0)
    }
    fn hessian_bodies(&self, out: &mut Vec<(usize, usize)>) {
        out.extend(self.bodies.iter().map(|&b| (b, b)));
    }
}

impl Trap<f64> {
    pub(crate) fn with_scalar<U: Real>(&self) -> Trap<U> {
        Trap {
            stiffness: U::lit(self.stiffness),
            center: self.center.map(U::lit),
            bodies: self.bodies.clone(),
            rest: U::lit(self.rest),
        }
    }
}
