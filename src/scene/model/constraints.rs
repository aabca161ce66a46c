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
    #[inline(always)]
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

    #[inline(always)]
    fn residual(&self, x: &V, out: &mut [T]) {
        let q = x.as_slice();
        let d = self.dim;
        let _timer = self.timer(&self.constraint_counter);
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
    }

    /// `out = G(q) v`, one row at a time (each row written once: no fill, no accumulation in
    /// memory).
    #[inline(always)]
    fn jacobian_apply(&self, x: &V, v: &V, out: &mut [T]) {
        let v = v.as_slice();
        let _timer = self.timer(&self.constraint_counter);
        self.for_each_row_dot(x.as_slice(), v, None, |row, s| out[row] = s);
    }

    /// `φ = G_q W⁻¹ p`: a scene's `M = [[0, I], [−I, K − R]]` has `q' = ∂H/∂p = W⁻¹ p`, and its
    /// constraints act on positions (see the trait method).
    #[inline(always)]
    fn hidden_constraint_direct(&self, x: &V, out: &mut [T]) -> bool {
        let x = x.as_slice();
        let (q, p) = x.split_at(x.len() / 2);
        let _timer = self.timer(&self.constraint_counter);
        self.for_each_row_dot(q, p, Some(&self.inv_masses), |row, s| out[row] = s);
        true
    }

    /// `M Gᵀλ = (0, −G_qᵀλ)`: the scene's constraints read positions and its `M` is
    /// `[[0, I], [−I, K − R]]` (see the trait's docs).
    #[inline(always)]
    fn constraint_force_direct(&self, x: &V, lambda: &[T], out: &mut V) -> bool {
        let out = out.as_mut_slice();
        let nq = out.len() / 2;
        out.fill(T::lit(0.0));
        let p = &mut out[nq..];
        let _timer = self.timer(&self.constraint_counter);
        self.gradient_transpose_add(x.as_slice(), lambda, -T::one(), p);
        true
    }

    fn jacobian_transpose_apply_add(&self, x: &V, mu: &[T], alpha: T, out: &mut V) {
        let out = out.as_mut_slice();
        let _timer = self.timer(&self.constraint_counter);
        self.gradient_transpose_add(x.as_slice(), mu, alpha, out);
    }

    /// Every scene constraint is quadratic in `q` (rods and spheres) or affine (planes, pins):
    /// `uᵀ∇²g v` is `(u_a − u_b)·(v_a − v_b)` for a rod, `u_b·v_b` for a sphere, zero otherwise,
    /// on the position parts of `u` and `v`.
    fn hessian_form(&self, _x: &V, u: &V, v: &V, out: &mut [T]) -> bool {
        let (u, v) = (u.as_slice(), v.as_slice());
        let d = self.dim;
        for c in &self.constraints {
            let r = c.row;
            match &c.kind {
                ConstraintKind::Pin { .. } => {
                    for k in 0..d {
                        out[r + k] = T::lit(0.0);
                    }
                }
                ConstraintKind::Plane { .. } => out[r] = T::lit(0.0),
                ConstraintKind::Rod { a, b, .. } => {
                    let (ua, va) = (body3(u, *a, d, None), body3(v, *a, d, None));
                    let (du, dv) = match b {
                        Some(b) => {
                            let (ub, vb) = (body3(u, *b, d, None), body3(v, *b, d, None));
                            (
                                [ua[0] - ub[0], ua[1] - ub[1], ua[2] - ub[2]],
                                [va[0] - vb[0], va[1] - vb[1], va[2] - vb[2]],
                            )
                        }
                        None => (ua, va),
                    };
                    out[r] = dot3(du, dv);
                }
                ConstraintKind::Sphere { body, .. } => {
                    out[r] = dot3(body3(u, *body, d, None), body3(v, *body, d, None));
                }
            }
        }
        true
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
                        f(r, *b, [-u[0], -u[1], -u[2]]);
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

impl<T: Real> SceneModel<T> {
    /// Calls `f(row, G_row(q) · v)` for every row of `G(q)`, with body `b`'s part of `v`
    /// (stride `d`) scaled by `scale[b]` when given (`W⁻¹ p` for the hidden constraint): a rod
    /// gives `u · (v_a − v_b)`, a sphere `u · v_b`, a plane `n · v_b`, a pin `v_b` itself. The
    /// same gradients as [`for_each_gradient`](Self::for_each_gradient), summed per row in
    /// registers. (Plain functions rather than a closure per body: a closure called from
    /// several arms is outlined, and its 3-vector returned through memory.)
    #[inline(always)]
    pub(crate) fn for_each_row_dot(
        &self,
        q: &[T],
        v: &[T],
        scale: Option<&[T]>,
        mut f: impl FnMut(usize, T),
    ) {
        let d = self.dim;
        for c in &self.constraints {
            let r = c.row;
            match &c.kind {
                ConstraintKind::Pin { body, .. } => {
                    let v = body3(v, *body, d, scale);
                    for k in 0..d {
                        f(r + k, v[k]);
                    }
                }
                ConstraintKind::Rod { a, b, point, .. } => {
                    let u = self.rod_vector(q, *a, *b, point);
                    let va = body3(v, *a, d, scale);
                    let dv = match b {
                        Some(b) => {
                            let vb = body3(v, *b, d, scale);
                            [va[0] - vb[0], va[1] - vb[1], va[2] - vb[2]]
                        }
                        None => va,
                    };
                    f(r, dot3(u, dv));
                }
                ConstraintKind::Sphere { body, center, .. } => {
                    let u = self.rod_vector(q, *body, None, center);
                    f(r, dot3(u, body3(v, *body, d, scale)));
                }
                ConstraintKind::Plane { body, normal, .. } => {
                    f(r, dot3(*normal, body3(v, *body, d, scale)));
                }
            }
        }
    }
}

impl<T: Real> SceneModel<T> {
    /// `out += α G(q)ᵀ μ` on positions (`out` of length `d N`): a rod adds `α μ u` to body `a`
    /// and subtracts it from `b`, a sphere adds `α μ u`, a plane `α μ n`, a pin `α μ_k` per
    /// axis. The same gradients as [`for_each_gradient`](Self::for_each_gradient), written as
    /// plain code (see [`for_each_row_dot`](Self::for_each_row_dot)).
    #[inline(always)]
    pub(crate) fn gradient_transpose_add(&self, q: &[T], mu: &[T], alpha: T, out: &mut [T]) {
        let d = self.dim;
        for c in &self.constraints {
            let r = c.row;
            match &c.kind {
                ConstraintKind::Pin { body, .. } => {
                    for k in 0..d {
                        out[body * d + k] = out[body * d + k] + alpha * mu[r + k];
                    }
                }
                ConstraintKind::Rod { a, b, point, .. } => {
                    let u = self.rod_vector(q, *a, *b, point);
                    let s = alpha * mu[r];
                    add3(out, *a, d, s, u);
                    if let Some(b) = b {
                        add3(out, *b, d, -s, u);
                    }
                }
                ConstraintKind::Sphere { body, center, .. } => {
                    let u = self.rod_vector(q, *body, None, center);
                    add3(out, *body, d, alpha * mu[r], u);
                }
                ConstraintKind::Plane { body, normal, .. } => {
                    add3(out, *body, d, alpha * mu[r], *normal);
                }
            }
        }
    }
}

/// `out_b += s u` on body `b`'s `d` components (stride `d`).
#[inline(always)]
fn add3<T: Real>(out: &mut [T], b: usize, d: usize, s: T, u: [T; 3]) {
    let i = b * d;
    out[i] = out[i] + s * u[0];
    out[i + 1] = out[i + 1] + s * u[1];
    if d == 3 {
        out[i + 2] = out[i + 2] + s * u[2];
    }
}

/// Body `b`'s `d` components of `v` (stride `d`) times `scale[b]` if given, zero-padded to
/// three, built from values (see `rod_vector`).
#[inline(always)]
fn body3<T: Real>(v: &[T], b: usize, d: usize, scale: Option<&[T]>) -> [T; 3] {
    let i = b * d;
    let x = if d == 3 {
        [v[i], v[i + 1], v[i + 2]]
    } else {
        [v[i], v[i + 1], T::lit(0.0)]
    };
    match scale {
        Some(w) => [w[b] * x[0], w[b] * x[1], w[b] * x[2]],
        None => x,
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
