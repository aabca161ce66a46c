//! The scene's constraints `g(q) = 0` as a [`HolonomicConstraint`]: residuals, Jacobian
//! products and entries, per-term residuals, and the velocity curvature `vᵀ∇²g v`.

use super::{SceneModel, terms::ConstraintKind};
use crate::linalg::Sink;
use crate::real::Real;
use crate::system::HolonomicConstraint;
use crate::vector::Vector;
use std::sync::Arc;

/// A constraint's geometry at `q`: the vector `u` such that the row's gradient is `u` at the
/// first body and `−u` at the second (if any), or for a pin the unit rows.
impl<T: Real> SceneModel<T> {
    #[inline]
    /// `g` of constraint term `index` at positions `q`, for the single-row kinds (rod, sphere,
    /// plane); `None` for a pin.
    pub(crate) fn term_residual(&self, q: &[T], index: usize) -> Option<T> {
        self.single_row_residual(q, &self.constraints[index].kind)
    }

    /// `g` of a single-row constraint (rod, sphere, plane) at positions `q`; `None` for a pin.
    #[inline]
    pub(super) fn single_row_residual(&self, q: &[T], kind: &ConstraintKind<T>) -> Option<T> {
        let half = T::lit(0.5);
        match kind {
            ConstraintKind::Rod {
                a,
                b,
                point,
                length,
            } => {
                let u = self.rod_vector(q, *a, *b, point);
                Some(half * (dot3(u, u) - *length * *length))
            }
            ConstraintKind::Sphere {
                body,
                center,
                radius,
            } => {
                let u = self.rod_vector(q, *body, None, center);
                Some(half * (dot3(u, u) - *radius * *radius))
            }
            ConstraintKind::Plane {
                body,
                normal,
                offset,
            } => {
                let s =
                    (0..self.dim).fold(T::lit(0.0), |s, k| s + normal[k] * q[body * self.dim + k]);
                Some(s - *offset)
            }
            ConstraintKind::Pin { .. } => None,
        }
    }

    /// `q_a − q_b` (or `q_a − point`), built from values rather than written per coordinate
    /// into a stack array: a dot product that loads such an array as one vector stalls on
    /// store forwarding, which cost more than the rest of a rod's residual (inlined, so that the
    /// array is not returned through memory either).
    #[inline(always)]
    pub(super) fn rod_vector(&self, q: &[T], a: usize, b: Option<usize>, point: &[T; 3]) -> [T; 3] {
        let d = self.dim;
        let at = |k: usize| {
            q[a * d + k]
                - match b {
                    Some(b) => q[b * d + k],
                    None => point[k],
                }
        };
        if d == 3 {
            [at(0), at(1), at(2)]
        } else {
            [at(0), at(1), T::lit(0.0)]
        }
    }
}

#[allow(clippy::misnamed_getters)] // `dim` is the number of constraints `m`.
impl<T: Real, V: Vector<Real = T>> HolonomicConstraint<V> for Arc<SceneModel<T>> {
    fn dim(&self) -> usize {
        self.m
    }

    fn residual(&self, x: &V, out: &mut [T]) {
        let q = x.as_slice();
        let d = self.dim;
        self.timed(&self.constraint_counter, || {
            for c in &self.constraints {
                let r = c.row;
                match &c.kind {
                    ConstraintKind::Pin { body, point } => {
                        for k in 0..d {
                            out[r + k] = q[body * d + k] - point[k];
                        }
                    }
                    kind => {
                        out[r] = self
                            .single_row_residual(q, kind)
                            .expect("rods, spheres and planes are single rows");
                    }
                }
            }
        });
    }

    fn jacobian_apply(&self, x: &V, v: &V, out: &mut [T]) {
        let v = v.as_slice();
        let d = self.dim;
        self.timed(&self.constraint_counter, || {
            out.fill(T::lit(0.0));
            self.for_each_gradient(x.as_slice(), |row, body, coef| {
                for k in 0..d {
                    out[row] = out[row] + (coef[k] * v[body * d + k]);
                }
            });
        });
    }

    /// `φ = G_q W⁻¹ p`: a scene's `M = [[0, I], [−I, K − R]]` has `q' = ∂H/∂p = W⁻¹ p`, and its
    /// constraints act on positions (see the trait method).
    fn hidden_constraint_direct(&self, x: &V, out: &mut [T]) -> bool {
        let x = x.as_slice();
        let (d, nq) = (self.dim, x.len() / 2);
        let w = &self.inv_masses;
        self.timed(&self.constraint_counter, || {
            out.fill(T::lit(0.0));
            self.for_each_gradient(x, |row, body, coef| {
                for k in 0..d {
                    out[row] = out[row] + coef[k] * (w[body] * x[nq + body * d + k]);
                }
            });
        });
        true
    }

    /// `M Gᵀλ = (0, −G_qᵀλ)`: the scene's constraints read positions and its `M` is
    /// `[[0, I], [−I, K − R]]` (see the trait's docs).
    fn constraint_force_direct(&self, x: &V, lambda: &[T], out: &mut V) -> bool {
        let out = out.as_mut_slice();
        let d = self.dim;
        let nq = out.len() / 2;
        out.fill(T::lit(0.0));
        let p = &mut out[nq..];
        self.timed(&self.constraint_counter, || {
            self.for_each_gradient(x.as_slice(), |row, body, coef| {
                let s = lambda[row];
                for k in 0..d {
                    p[body * d + k] = p[body * d + k] - (s * coef[k]);
                }
            });
        });
        true
    }

    fn jacobian_transpose_apply_add(&self, x: &V, mu: &[T], alpha: T, out: &mut V) {
        let out = out.as_mut_slice();
        let d = self.dim;
        self.timed(&self.constraint_counter, || {
            self.for_each_gradient(x.as_slice(), |row, body, coef| {
                let s = alpha * mu[row];
                for k in 0..d {
                    out[body * d + k] = out[body * d + k] + (s * coef[k]);
                }
            });
        });
    }

    fn jacobian_entries(&self, x: &V, sink: &mut dyn Sink<T>) -> bool {
        if !self.sparse {
            return false;
        }
        let d = self.dim;
        self.for_each_gradient(x.as_slice(), |row, body, coef| {
            for k in 0..d {
                sink.add(row, body * d + k, coef[k]);
            }
        });
        true
    }
}

impl<T: Real> SceneModel<T> {
    /// Calls `f(row, body, c)` for every body a row of `G(q)` touches, with `c` the row's
    /// gradient with respect to that body's position: a rod `(|u|² − L²)/2` gives `u` and `−u`
    /// (`u = q_a − q_b`), a sphere `u = q − c`, a plane `n`, a pin the unit vectors. `G v`,
    /// `Gᵀ μ` and the Jacobian entries are all written through it, so they cannot disagree.
    #[inline]
    pub(crate) fn for_each_gradient(&self, q: &[T], mut f: impl FnMut(usize, usize, [T; 3])) {
        for c in &self.constraints {
            let r = c.row;
            match &c.kind {
                ConstraintKind::Pin { body, .. } => {
                    for k in 0..self.dim {
                        let mut e = [T::lit(0.0); 3];
                        e[k] = T::lit(1.0);
                        f(r + k, *body, e);
                    }
                }
                ConstraintKind::Rod { a, b, point, .. } => {
                    let u = self.rod_vector(q, *a, *b, point);
                    f(r, *a, u);
                    if let Some(b) = b {
                        f(r, *b, u.map(|x| -x));
                    }
                }
                ConstraintKind::Sphere { body, center, .. } => {
                    f(r, *body, self.rod_vector(q, *body, None, center));
                }
                ConstraintKind::Plane { body, normal, .. } => f(r, *body, *normal),
            }
        }
    }
}

#[inline]
pub(super) fn dot3<T: Real>(a: [T; 3], b: [T; 3]) -> T {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

impl<T: Real> SceneModel<T> {
    /// `out_i += vᵀ ∇²g_i(q) v` for velocities `v = W⁻¹ p` (length `d N`): the term of
    /// `d²g/dt² = G q̈ + vᵀ ∇²g v` that does not depend on the acceleration — `|v_a − v_b|²` for
    /// a rod, `|v_b|²` for a sphere, zero for planes and pins (their `g` is affine). It does not
    /// depend on `q`: every constraint's Hessian is constant.
    pub fn velocity_curvature_add(&self, v: &[T], out: &mut [T]) {
        let d = self.dim;
        for c in &self.constraints {
            let add = match c.kind {
                ConstraintKind::Rod { a, b, .. } => (0..d).fold(T::lit(0.0), |acc, k| {
                    let dv = v[a * d + k] - b.map_or(T::lit(0.0), |b| v[b * d + k]);
                    acc + dv * dv
                }),
                ConstraintKind::Sphere { body, .. } => (0..d).fold(T::lit(0.0), |acc, k| {
                    acc + v[body * d + k] * v[body * d + k]
                }),
                ConstraintKind::Pin { .. } | ConstraintKind::Plane { .. } => continue,
            };
            out[c.row] = out[c.row] + add;
        }
    }
}
