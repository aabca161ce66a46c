//! A rod, `(|q_a − r|² − L²)/2 = 0` with `r = q_b` or a fixed point: one quadratic row whose
//! gradient is `u = q_a − r` at `a` and `−u` at `b`.

use super::{
    ConstraintInfo, ConstraintOps, Declare, Declared, add3, difference3, dot3, extent, scaled3,
    size3, sub3,
};
use crate::real::Real;
use crate::scene::bodies::Bodies;
use crate::scene::error::{FieldPath, SceneErrorKind};
use crate::scene::validate::{Result, err, norm, positive, sub, vector};
use serde::Deserialize;

/// `type = "rod"`: `|q_a − q_b| = length` between two bodies, or between one body and a fixed
/// `point`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RodSpec {
    /// A name: the constraint's label in messages, its multipliers' CSV columns, and what
    /// `--off NAME` switches off.
    #[serde(default)]
    pub name: Option<String>,
    /// One or two bodies.
    pub bodies: Vec<String>,
    /// The fixed end, when one body is named.
    #[serde(default)]
    pub point: Option<Vec<f64>>,
    /// Length (default: the initial distance).
    #[serde(default)]
    pub length: Option<f64>,
}

impl Declare for RodSpec {
    fn declare(
        &self,
        i: usize,
        path: &FieldPath,
        bodies: &Bodies,
        out: &mut Vec<Declared>,
    ) -> Result<()> {
        let bp = path.key("bodies");
        let ends: Vec<usize> = self
            .bodies
            .iter()
            .enumerate()
            .map(|(j, s)| {
                let v = bodies.select(s, &bp.index(j))?;
                if v.len() == 1 {
                    Ok(v[0])
                } else {
                    Err(err(
                        SceneErrorKind::Reference,
                        bp.index(j),
                        format!("'{s}' names {} bodies; a rod end is one body", v.len()),
                    ))
                }
            })
            .collect::<Result<_>>()?;
        let (a, b, p) = match (ends.as_slice(), &self.point) {
            (&[a, b], None) if a != b => (a, Some(b), [0.0; 3]),
            (&[a], Some(p)) => (a, None, vector(p, bodies.dim, &path.key("point"))?),
            _ => {
                // Point at the `point` when it is the extra piece.
                let at = if self.point.is_some() && ends.len() != 1 {
                    path.key("point")
                } else {
                    bp
                };
                return Err(err(
                    SceneErrorKind::Value,
                    at,
                    "a rod joins two different bodies, or one body and a fixed `point`",
                ));
            }
        };
        let other = b.map_or(p, |b| bodies.list[b].q);
        let initial = norm(sub(bodies.list[a].q, other));
        let length = match self.length {
            Some(l) => positive(l, &path.key("length"), "length")?,
            None => positive(
                initial,
                &path.key("bodies"),
                "initial distance of the rod's ends",
            )?,
        };
        let names = match b {
            Some(b) => format!("'{}'–'{}'", bodies.list[a].name, bodies.list[b].name),
            None => format!("'{}'–point", bodies.list[a].name),
        };
        out.push((
            super::Constraint::Rod(Rod {
                a,
                b,
                point: p,
                length,
            }),
            format!("constraints[{i}] rod {names}"),
            path.clone(),
        ));
        Ok(())
    }
}

/// The rod's term: `(|q_a − r|² − L²)/2 = 0`, `r = q_b` or the fixed `point` when `b` is
/// `None`.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Rod<T = f64> {
    pub(crate) a: usize,
    pub(crate) b: Option<usize>,
    pub(crate) point: [T; 3],
    pub(crate) length: T,
}

impl Rod<f64> {
    pub(crate) fn with_scalar<U: Real>(&self) -> Rod<U> {
        Rod {
            a: self.a,
            b: self.b,
            point: self.point.map(U::lit),
            length: U::lit(self.length),
        }
    }
}

impl<T: Real> ConstraintOps<T> for Rod<T> {
    #[inline(always)]
    fn rows(&self, _d: usize) -> usize {
        1
    }
    #[inline(always)]
    fn residual(&self, q: &[T], d: usize, out: &mut [T]) {
        let u = difference3(q, self.a, self.b, &self.point, d);
        out[0] = T::lit(0.5) * (dot3(u, u) - self.length * self.length);
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
        let u = difference3(q, self.a, self.b, &self.point, d);
        let va = scaled3(v, self.a, d, scale);
        let dv = match self.b {
            Some(b) => sub3(va, scaled3(v, b, d, scale)),
            None => va,
        };
        f(0, dot3(u, dv));
    }
    #[inline(always)]
    fn gradient_transpose_add(&self, q: &[T], mu: &[T], alpha: T, d: usize, out: &mut [T]) {
        let u = difference3(q, self.a, self.b, &self.point, d);
        let s = alpha * mu[0];
        add3(out, self.a, d, s, u);
        if let Some(b) = self.b {
            add3(out, b, d, -s, u);
        }
    }
    #[inline(always)]
    fn gradients(&self, q: &[T], d: usize, mut f: impl FnMut(usize, usize, [T; 3])) {
        let u = difference3(q, self.a, self.b, &self.point, d);
        f(0, self.a, u);
        if let Some(b) = self.b {
            f(0, b, [-u[0], -u[1], -u[2]]);
        }
    }
    /// `(u_a − u_b)·(v_a − v_b)`.
    #[inline(always)]
    fn hessian_form(&self, u: &[T], v: &[T], d: usize, out: &mut [T]) {
        let zero = [T::lit(0.0); 3];
        let du = difference3(u, self.a, self.b, &zero, d);
        let dv = difference3(v, self.a, self.b, &zero, d);
        out[0] = dot3(du, dv);
    }
    fn length(&self) -> Option<T> {
        Some(self.length)
    }
    /// `|v_a − v_b|²`.
    #[inline(always)]
    fn velocity_curvature_add(&self, v: &[T], d: usize, out: &mut [T]) {
        let dv = difference3(v, self.a, self.b, &[T::lit(0.0); 3], d);
        out[0] = out[0] + dot3(dv, dv);
    }
}

impl ConstraintInfo for Rod<f64> {
    fn kind(&self) -> &'static str {
        "rod"
    }
    fn bodies(&self, name: &dyn Fn(usize) -> String) -> String {
        match self.b {
            Some(b) => format!("{}-{}", name(self.a), name(b)),
            None => name(self.a),
        }
    }
    /// `(|u|² − L²)/2` rounds at `ε L (L + |q_a| + |q_b|)`.
    fn scales(&self, q: &[f64], d: usize, out: &mut [(f64, f64)]) {
        let far = extent(q, self.a, d)
            + self
                .b
                .map_or_else(|| size3(&self.point), |b| extent(q, b, d));
        out[0] = (self.length * (self.length + far), self.length);
    }
    /// A rod pulls its ends together with the tension `λ |q_a − r|`.
    fn force_per_multiplier(&self, q: &[f64], d: usize) -> f64 {
        let u = difference3(q, self.a, self.b, &self.point, d);
        dot3(u, u).sqrt()
    }
}
