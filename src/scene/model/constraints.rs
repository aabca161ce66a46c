//! The scene's constraints `g(q) = 0` as a [`HolonomicConstraint`]: one loop over the declared
//! terms, each dispatched statically to its file in `scene/constraints/` (residuals, Jacobian
//! products and entries, the Hessian form and the velocity curvature `vᵀ∇²g v`).

use super::SceneModel;
use crate::linalg::Sink;
use crate::real::Real;
use crate::system::HolonomicConstraint;
use crate::vector::Vector;
use std::sync::Arc;

impl<T: Real> SceneModel<T> {
    /// `g` of constraint term `index` at positions `q` if it is a single row (rods, spheres,
    /// planes); `None` for a term of several rows (a pin).
    pub(crate) fn term_residual(&self, q: &[T], index: usize) -> Option<T> {
        let c = &self.constraints[index].kind;
        (c.rows(self.dim) == 1).then(|| {
            let mut g = [T::lit(0.0)];
            c.residual(q, self.dim, &mut g);
            g[0]
        })
    }

    /// Calls `f(row, body, c)` for every body a row of `G(q)` touches, with `c` the row's
    /// gradient with respect to that body's position (see
    /// [`ConstraintOps::gradients`](crate::scene::constraints::ConstraintOps::gradients)).
    /// `G v`, `Gᵀ μ` and the Jacobian entries are all written through the same terms, so
    /// they cannot disagree.
    /// Calls `f(row, column, value)` for every entry of `G` a term can make non-zero (see
    /// [`ConstraintOps::entries`](crate::scene::constraints::ConstraintOps::entries)): the
    /// sparsity pattern and its values.
    #[inline]
    pub(crate) fn for_each_entry(&self, q: &[T], mut f: impl FnMut(usize, usize, T)) {
        for c in &self.constraints {
            let r = c.row;
            c.kind.entries(q, self.dim, |i, col, v| f(r + i, col, v));
        }
    }

    #[inline]
    pub(crate) fn for_each_gradient(&self, q: &[T], mut f: impl FnMut(usize, usize, [T; 3])) {
        for c in &self.constraints {
            let r = c.row;
            c.kind.gradients(q, self.dim, |i, b, g| f(r + i, b, g));
        }
    }

    /// Calls `f(row, G_row(q) · v)` for every row of `G(q)`, with body `b`'s part of `v`
    /// (stride `d`) scaled by `scale[b]` when given (`W⁻¹ p` for the hidden constraint),
    /// summed per row in registers.
    #[inline(always)]
    pub(crate) fn for_each_row_dot(
        &self,
        q: &[T],
        v: &[T],
        scale: Option<&[T]>,
        mut f: impl FnMut(usize, T),
    ) {
        for c in &self.constraints {
            let r = c.row;
            c.kind.row_dots(q, v, self.dim, scale, |i, s| f(r + i, s));
        }
    }

    /// `out += α G(q)ᵀ μ` on positions (`out` of length `d N`).
    #[inline(always)]
    pub(crate) fn gradient_transpose_add(&self, q: &[T], mu: &[T], alpha: T, out: &mut [T]) {
        for c in &self.constraints {
            c.kind
                .gradient_transpose_add(q, &mu[c.row..], alpha, self.dim, out);
        }
    }

    /// `out_i += vᵀ ∇²g_i v` for velocities `v = W⁻¹ p` (length `d N`): the term of
    /// `d²g/dt² = G q̈ + vᵀ ∇²g v` that does not depend on the acceleration — `|v_a − v_b|²`
    /// for a rod, `|v_b|²` for a sphere, zero for planes and pins (their `g` is affine). It
    /// does not depend on `q`: every constraint's Hessian is constant.
    pub fn velocity_curvature_add(&self, v: &[T], out: &mut [T]) {
        for c in &self.constraints {
            c.kind
                .velocity_curvature_add(v, self.dim, &mut out[c.row..]);
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
        let _timer = self.timer(&self.constraint_counter);
        for c in &self.constraints {
            c.kind.residual(q, self.dim, &mut out[c.row..]);
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

    /// `G_q W⁻¹ d_p` for a direction `d` with zero positions (see the trait method): `φ` is
    /// linear in `p`.
    #[inline(always)]
    fn hidden_derivative_direct(&self, x: &V, d: &V, out: &mut [T]) -> bool {
        let (x, d) = (x.as_slice(), d.as_slice());
        let nq = x.len() / 2;
        let (dq, dp) = d.split_at(nq);
        if dq.iter().any(|&v| v != T::lit(0.0)) {
            return false;
        }
        let _timer = self.timer(&self.constraint_counter);
        self.for_each_row_dot(&x[..nq], dp, Some(&self.inv_masses), |row, s| out[row] = s);
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

    /// Every scene constraint is at most quadratic in `q`: `uᵀ∇²g v` on the position parts of
    /// `u` and `v`, per term.
    fn hessian_form(&self, _x: &V, u: &V, v: &V, out: &mut [T]) -> bool {
        let (u, v) = (u.as_slice(), v.as_slice());
        for c in &self.constraints {
            c.kind.hessian_form(u, v, self.dim, &mut out[c.row..]);
        }
        true
    }

    fn jacobian_entries(&self, x: &V, sink: &mut dyn Sink<T>) -> bool {
        if !self.sparse {
            return false;
        }
        self.for_each_entry(x.as_slice(), |row, col, v| sink.add(row, col, v));
        true
    }

    /// The same walk as [`jacobian_entries`](Self::jacobian_entries), the values alone.
    fn jacobian_values(&self, x: &V, out: &mut [T]) -> bool {
        if !self.sparse {
            return false;
        }
        let mut next = 0;
        self.for_each_entry(x.as_slice(), |_, _, v| {
            if let Some(o) = out.get_mut(next) {
                *o = v;
            }
            next += 1;
        });
        next == out.len()
    }
}
