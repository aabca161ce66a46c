//! A plane (a line in 2D), `n · q_b − offset = 0` with `|n| = 1`: one affine row per body.

use super::{ConstraintInfo, ConstraintOps, Declare, Declared, add3, dot3, extent, scaled3};
use crate::real::Real;
use crate::scene::bodies::Bodies;
use crate::scene::error::{FieldPath, SceneErrorKind};
use crate::scene::validate::{Result, err, finite, norm, vector};
use serde::Deserialize;

/// `type = "plane"`: `n · q_b = offset` for each body `b` (`n` normalized).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlaneSpec {
    /// A name: the constraint's label in messages, its multipliers' CSV columns, and what
    /// `--off NAME` switches off.
    #[serde(default)]
    pub name: Option<String>,
    /// The bodies held on the plane.
    pub bodies: Vec<String>,
    /// The normal, non-zero.
    pub normal: Vec<f64>,
    /// Offset (default: `n · q_b` of the first body's initial position).
    #[serde(default)]
    pub offset: Option<f64>,
}

impl Declare for PlaneSpec {
    fn declare(
        &self,
        i: usize,
        path: &FieldPath,
        bodies: &Bodies,
        out: &mut Vec<Declared>,
    ) -> Result<()> {
        let n = vector(&self.normal, bodies.dim, &path.key("normal"))?;
        let len = norm(n);
        if len == 0.0 {
            return Err(err(
                SceneErrorKind::Value,
                path.key("normal"),
                "the normal must not be zero",
            ));
        }
        let n = n.map(|x| x / len);
        let list = bodies.select_all(&self.bodies, &path.key("bodies"))?;
        let offset = self
            .offset
            .map(|o| finite(o, &path.key("offset")))
            .transpose()?;
        for &b in &list {
            let offset = offset.unwrap_or_else(|| dot3(n, bodies.list[list[0]].q));
            out.push((
                super::Constraint::Plane(Plane {
                    body: b,
                    normal: n,
                    offset,
                }),
                format!("constraints[{i}] plane '{}'", bodies.list[b].name),
                path.clone(),
            ));
        }
        Ok(())
    }
}

/// The plane's term for one body.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Plane<T = f64> {
    pub(crate) body: usize,
    pub(crate) normal: [T; 3],
    pub(crate) offset: T,
}

impl Plane<f64> {
    pub(crate) fn with_scalar<U: Real>(&self) -> Plane<U> {
        Plane {
            body: self.body,
            normal: self.normal.map(U::lit),
            offset: U::lit(self.offset),
        }
    }
}

impl<T: Real> ConstraintOps<T> for Plane<T> {
    #[inline(always)]
    fn rows(&self, _d: usize) -> usize {
        1
    }
    #[inline(always)]
    fn residual(&self, q: &[T], d: usize, out: &mut [T]) {
        let s = (0..d).fold(T::lit(0.0), |s, k| {
            s + self.normal[k] * q[self.body * d + k]
        });
        out[0] = s - self.offset;
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
        f(0, dot3(self.normal, scaled3(v, self.body, d, scale)));
    }
    #[inline(always)]
    fn gradient_transpose_add(&self, _q: &[T], mu: &[T], alpha: T, d: usize, out: &mut [T]) {
        add3(out, self.body, d, alpha * mu[0], self.normal);
    }
    #[inline(always)]
    fn gradients(&self, _q: &[T], _d: usize, mut f: impl FnMut(usize, usize, [T; 3])) {
        f(0, self.body, self.normal);
    }
    #[inline(always)]
    fn hessian_form(&self, _u: &[T], _v: &[T], _d: usize, out: &mut [T]) {
        out[0] = T::lit(0.0);
    }
    #[inline(always)]
    fn velocity_curvature_add(&self, _v: &[T], _d: usize, _out: &mut [T]) {}
}

impl ConstraintInfo for Plane<f64> {
    fn kind(&self) -> &'static str {
        "plane"
    }
    fn bodies(&self, name: &dyn Fn(usize) -> String) -> String {
        name(self.body)
    }
    fn scales(&self, q: &[f64], d: usize, out: &mut [(f64, f64)]) {
        out[0] = (1.0 + extent(q, self.body, d) + self.offset.abs(), 1.0);
    }
    /// A plane pushes along its unit normal with `−λ`.
    fn force_per_multiplier(&self, _q: &[f64], _d: usize) -> f64 {
        -1.0
    }
}
