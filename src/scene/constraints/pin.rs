//! A pin, `q_b − point = 0`: `d` affine rows per body, each the body's coordinate along an axis.

use super::{ConstraintInfo, ConstraintOps, Declare, Declared, extent, scaled3, size3};
use crate::real::Real;
use crate::scene::bodies::Bodies;
use crate::scene::error::{FieldPath, SceneErrorKind};
use crate::scene::validate::{Result, err, vector_or};
use serde::Deserialize;

/// `type = "pin"`: `q_b = point` for each body `b` (`dim` equations each).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PinSpec {
    /// A name: the constraint's label in messages, its multipliers' CSV columns, and what
    /// `--off NAME` switches off.
    #[serde(default)]
    pub name: Option<String>,
    /// The bodies pinned.
    pub bodies: Vec<String>,
    /// Where (default: each body's initial position; only for a single body).
    #[serde(default)]
    pub point: Option<Vec<f64>>,
}

impl Declare for PinSpec {
    fn declare(
        &self,
        i: usize,
        path: &FieldPath,
        bodies: &Bodies,
        out: &mut Vec<Declared>,
    ) -> Result<()> {
        let list = bodies.select_all(&self.bodies, &path.key("bodies"))?;
        if self.point.is_some() && list.len() != 1 {
            return Err(err(
                SceneErrorKind::Value,
                path.key("point"),
                "a pin with a `point` names exactly one body",
            ));
        }
        for b in list {
            let point = vector_or(
                &self.point,
                bodies.dim,
                &path.key("point"),
                bodies.list[b].q,
            )?;
            out.push((
                super::Constraint::Pin(Pin { body: b, point }),
                format!("constraints[{i}] pin '{}'", bodies.list[b].name),
                path.clone(),
            ));
        }
        Ok(())
    }
}

/// The pin's term: `q_body − point = 0`.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Pin<T = f64> {
    pub(crate) body: usize,
    pub(crate) point: [T; 3],
}

impl Pin<f64> {
    pub(crate) fn with_scalar<U: Real>(&self) -> Pin<U> {
        Pin {
            body: self.body,
            point: self.point.map(U::lit),
        }
    }
}

impl<T: Real> ConstraintOps<T> for Pin<T> {
    #[inline(always)]
    fn rows(&self, d: usize) -> usize {
        d
    }
    #[inline(always)]
    fn residual(&self, q: &[T], d: usize, out: &mut [T]) {
        for k in 0..d {
            out[k] = q[self.body * d + k] - self.point[k];
        }
    }
    #[inline(always)]
    fn row_dots(
        &self,
        _q: &[T],
        v: &[T],
        d: usize,
        scale: Option<&[T]>,
        mut f: impl FnMut(usize, T),
    ) {
        let v = scaled3(v, self.body, d, scale);
        for k in 0..d {
            f(k, v[k]);
        }
    }
    #[inline(always)]
    fn gradient_transpose_add(&self, _q: &[T], mu: &[T], alpha: T, d: usize, out: &mut [T]) {
        let i = self.body * d;
        for k in 0..d {
            out[i + k] = out[i + k] + alpha * mu[k];
        }
    }
    #[inline(always)]
    fn gradients(&self, _q: &[T], d: usize, mut f: impl FnMut(usize, usize, [T; 3])) {
        for k in 0..d {
            let mut e = [T::lit(0.0); 3];
            e[k] = T::lit(1.0);
            f(k, self.body, e);
        }
    }
    #[inline(always)]
    fn hessian_form(&self, _u: &[T], _v: &[T], d: usize, out: &mut [T]) {
        out[..d].fill(T::lit(0.0));
    }
    #[inline(always)]
    fn velocity_curvature_add(&self, _v: &[T], _d: usize, _out: &mut [T]) {}
}

impl ConstraintInfo for Pin<f64> {
    fn kind(&self) -> &'static str {
        "pin"
    }
    fn bodies(&self, name: &dyn Fn(usize) -> String) -> String {
        name(self.body)
    }
    fn scales(&self, q: &[f64], d: usize, out: &mut [(f64, f64)]) {
        let s = 1.0 + extent(q, self.body, d) + size3(&self.point);
        out[..d].fill((s, 1.0));
    }
    /// Axis `r`'s name.
    fn row_name(&self, r: usize) -> String {
        ["x", "y", "z"][r].to_owned()
    }
    /// A pin pushes with `−λ_k` along axis `k`.
    fn force_per_multiplier(&self, _q: &[f64], _d: usize) -> f64 {
        -1.0
    }
}
