//! A harmonic trap, `V = k/2 Σ_b |q_b − c|²`.

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

/// `k`, `c` and the bodies held.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Trap<T> {
    stiffness: T,
    center: [T; 3],
    bodies: Vec<usize>,
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
        })))
    }
}

impl<T: Real> PotentialOps<T> for Trap<T> {
    fn energy(&self, q: &[T], d: usize) -> T {
        let mut e = T::lit(0.0);
        for &b in &self.bodies {
            for k in 0..d {
                let z = q[b * d + k] - self.center[k];
                e = e + (z * z);
            }
        }
        T::lit(0.5) * self.stiffness * e
    }
    fn gradient_add(&self, q: &[T], d: usize, alpha: T, out: &mut [T]) {
        for &b in &self.bodies {
            for k in 0..d {
                out[b * d + k] =
                    out[b * d + k] + (alpha * self.stiffness * (q[b * d + k] - self.center[k]));
            }
        }
    }
    fn hessian_apply_add(&self, _q: &[T], d: usize, v: &[T], out: &mut [T]) {
        for &b in &self.bodies {
            for k in 0..d {
                out[b * d + k] = out[b * d + k] + (self.stiffness * v[b * d + k]);
            }
        }
    }
    /// Quadratic in `q`.
    fn is_quadratic(&self) -> bool {
        true
    }
}

impl Trap<f64> {
    pub(crate) fn with_scalar<U: Real>(&self) -> Trap<U> {
        Trap {
            stiffness: U::lit(self.stiffness),
            center: self.center.map(U::lit),
            bodies: self.bodies.clone(),
        }
    }
}
