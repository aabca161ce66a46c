//! Uniform gravity, `V = −Σ_b m_b g · q_b`: a constant force `m_b g` on each body it acts on.

use super::{Assembler, Effect, Potential, PotentialOps};
use crate::real::Real;
use crate::scene::error::FieldPath;
use crate::scene::names::Flag;
use crate::scene::validate::Result;
use crate::scene::validate::vector;
use serde::Deserialize;

/// `type = "gravity"`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GravitySpec {
    /// Label in summaries (default `gravity`).
    #[serde(default)]
    pub name: Option<String>,
    /// Acceleration (`dim` entries), e.g. `[0, -9.81]`.
    pub g: Vec<f64>,
    /// Bodies it acts on (default: all).
    #[serde(default)]
    pub bodies: Option<Vec<String>>,
}

/// Per body, the force `m_b g`.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Gravity<T> {
    forces: Vec<(usize, [T; 3])>,
}

impl Effect for GravitySpec {
    const FLAG: Flag = Flag::Gravity;
    fn assemble(
        &self,
        cx: &mut Assembler<'_>,
        path: &FieldPath,
        _label: &str,
        _on: bool,
    ) -> Result<Option<Potential<f64>>> {
        let bodies = cx.bodies;
        let g = vector(&self.g, cx.dim, &path.key("g"))?;
        let forces = bodies
            .select_opt(&self.bodies, &path.key("bodies"))?
            .into_iter()
            .map(|b| {
                let m = bodies.list[b].mass;
                (b, g.map(|x| m * x))
            })
            .collect();
        Ok(Some(Potential::Gravity(Gravity { forces })))
    }
}

impl<T: Real> PotentialOps<T> for Gravity<T> {
    fn energy(&self, q: &[T], d: usize) -> T {
        let mut e = T::lit(0.0);
        for (b, f) in &self.forces {
            for k in 0..d {
                e = e - (f[k] * q[b * d + k]);
            }
        }
        e
    }
    fn gradient_add(&self, _q: &[T], d: usize, alpha: T, out: &mut [T]) {
        for (b, f) in &self.forces {
            for k in 0..d {
                out[b * d + k] = out[b * d + k] - (alpha * f[k]);
            }
        }
    }
    /// Linear in `q`: no Hessian.
    fn hessian_apply_add(&self, _q: &[T], _d: usize, _v: &[T], _out: &mut [T]) {}
    /// Linear in `q`.
    fn is_quadratic(&self) -> bool {
        true
    }
    /// Linear in `q`: no Hessian.
    fn hessian_bodies(&self, _out: &mut Vec<(usize, usize)>) {}
}

impl<T: Real> Gravity<T> {
    /// Adds each body's force `m_b g` to `out[b]`.
    pub(crate) fn add_forces(&self, out: &mut [[T; 3]]) {
        for (b, f) in &self.forces {
            for k in 0..3 {
                out[*b][k] = out[*b][k] + f[k];
            }
        }
    }
}

impl Gravity<f64> {
    pub(crate) fn with_scalar<U: Real>(&self) -> Gravity<U> {
        Gravity {
            forces: self
                .forces
                .iter()
                .map(|&(b, f)| (b, f.map(U::lit)))
                .collect(),
        }
    }
}
