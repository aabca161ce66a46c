//! A sphere (a circle in 2D), `(|q_b − c|² − r²)/2 = 0`: one quadratic row per body, gradient
//! `u = q_b − c`.

use super::{
    ConstraintInfo, ConstraintOps, Declare, Declared, add3, difference3, dot3, extent, scaled3,
    size3,
};
use crate::real::Real;
use crate::scene::bodies::Bodies;
use crate::scene::error::FieldPath;
use crate::scene::validate::{Result, norm, positive, sub, vector_or};
use serde::Deserialize;

/// `type = "sphere"`: `|q_b − center| = radius` for each body `b`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SphereSpec {
    /// A name: the constraint's label in messages, its multipliers' CSV columns, and what
    /// `--off NAME` switches off.
    #[serde(default)]
    pub name: Option<String>,
    /// The bodies held on the sphere.
    pub bodies: Vec<String>,
    /// Centre (default: the origin).
    #[serde(default)]
    pub center: Option<Vec<f64>>,
    /// Radius (default: each body's initial distance from the centre).
    #[serde(default)]
    pub radius: Option<f64>,
}

impl Declare for SphereSpec {
    fn declare(
        &self,
        i: usize,
        path: &FieldPath,
        bodies: &Bodies,
        out: &mut Vec<Declared>,
    ) -> Result<()> {
        let center = vector_or(&self.center, bodies.dim, &path.key("center"), [0.0; 3])?;
        let radius = self
            .radius
            .map(|r| positive(r, &path.key("radius"), "radius"))
            .transpose()?;
        for b in bodies.select_all(&self.bodies, &path.key("bodies"))? {
            let r = match radius {
                Some(r) => r,
                None => positive(
                    norm(sub(bodies.list[b].q, center)),
                    &path.key("bodies"),
                    "initial distance from the centre",
                )?,
            };
            out.push((
                super::Constraint::Sphere(Sphere {
                    body: b,
                    center,
                    radius: r,
                }),
                format!("constraints[{i}] sphere '{}'", bodies.list[b].name),
                path.clone(),
            ));
        }
        Ok(())
    }
}

/// The sphere's term for one body.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Sphere<T = f64> {
    pub(crate) body: usize,
    pub(crate) center: [T; 3],
    pub(crate) radius: T,
}

impl Sphere<f64> {
    pub(crate) fn with_scalar<U: Real>(&self) -> Sphere<U> {
        Sphere {
            body: self.body,
            center: self.center.map(U::lit),
            radius: U::lit(self.radius),
        }
    }
}

impl<T: Real> ConstraintOps<T> for Sphere<T> {
    #[inline(always)]
    fn rows(&self, _d: usize) -> usize {
        1
    }
    #[inline(always)]
    fn residual(&self, q: &[T], d: usize, out: &mut [T]) {
        let u = difference3(q, self.body, None, &self.center, d);
        out[0] = T::lit(0.5) * (dot3(u, u) - self.radius * self.radius);
    }
    #[inline(always)]
    fn row_dots(
        &self,
        q: &[T],
        v: &[T],
        d: usize,
        scale: Option<&[T]>,
        mut f: impl FnMut(usize, T),
    ) {
        let u = difference3(q, self.body, None, &self.center, d);
        f(0, dot3(u, scaled3(v, self.body, d, scale)));
    }
    #[inline(always)]
    fn gradient_transpose_add(&self, q: &[T], mu: &[T], alpha: T, d: usize, out: &mut [T]) {
        let u = difference3(q, self.body, None, &self.center, d);
        add3(out, self.body, d, alpha * mu[0], u);
    }
    #[inline(always)]
    fn gradients(&self, q: &[T], d: usize, mut f: impl FnMut(usize, usize, [T; 3])) {
        f(
            0,
            self.body,
            difference3(q, self.body, None, &self.center, d),
        );
    }
    /// `u_b · v_b`.
    #[inline(always)]
    fn hessian_form(&self, u: &[T], v: &[T], d: usize, out: &mut [T]) {
        out[0] = dot3(
            scaled3(u, self.body, d, None),
            scaled3(v, self.body, d, None),
        );
    }
    fn length(&self) -> Option<T> {
        Some(self.radius)
    }
    /// `|v_b|²`.
    #[inline(always)]
    fn velocity_curvature_add(&self, v: &[T], d: usize, out: &mut [T]) {
        let vb = scaled3(v, self.body, d, None);
        out[0] = out[0] + dot3(vb, vb);
    }
}

impl ConstraintInfo for Sphere<f64> {
    fn kind(&self) -> &'static str {
        "sphere"
    }
    fn bodies(&self, name: &dyn Fn(usize) -> String) -> String {
        name(self.body)
    }
    fn scales(&self, q: &[f64], d: usize, out: &mut [(f64, f64)]) {
        out[0] = (
            self.radius * (self.radius + extent(q, self.body, d) + size3(&self.center)),
            self.radius,
        );
    }
    /// A sphere pulls toward its centre with `λ |q − c|`.
    fn force_per_multiplier(&self, q: &[f64], d: usize) -> f64 {
        let u = difference3(q, self.body, None, &self.center, d);
        dot3(u, u).sqrt()
    }
}
