//! The scene's `M = [[0, I], [−I, K − R]]` as a [`StructureMatrix`]: the magnetic field's
//! skew part `K` and the damping `R` (per body, and the dashpots between bodies).

use super::SceneModel;
use crate::linalg::Sink;
use crate::real::Real;
use crate::system::StructureMatrix;
use crate::vector::Vector;
use std::sync::Arc;

impl<T: Real, V: Vector<Real = T>> StructureMatrix<V> for Arc<SceneModel<T>> {
    /// `out = M v`, written directly (no zero fill and add).
    #[inline(always)]
    fn apply(&self, _x: &V, v: &V, out: &mut V) {
        let v = v.as_slice();
        let out = out.as_mut_slice();
        let nq = v.len() / 2;
        let (oq, op) = out.split_at_mut(nq);
        let (vq, vp) = v.split_at(nq);
        for (o, x) in oq.iter_mut().zip(vp) {
            *o = *x;
        }
        for (o, x) in op.iter_mut().zip(vq) {
            *o = -*x;
        }
        self.apply_dissipative_and_magnetic(vp, T::one(), op);
    }

    #[inline(always)]
    fn apply_add(&self, _x: &V, v: &V, alpha: T, out: &mut V) {
        let v = v.as_slice();
        let out = out.as_mut_slice();
        let nq = v.len() / 2;
        let (oq, op) = out.split_at_mut(nq);
        let (vq, vp) = v.split_at(nq);
        for (o, x) in oq.iter_mut().zip(vp) {
            *o = *o + (alpha * *x);
        }
        for (o, x) in op.iter_mut().zip(vq) {
            *o = *o - (alpha * *x);
        }
        self.apply_dissipative_and_magnetic(vp, alpha, op);
    }

    fn is_constant(&self) -> bool {
        true
    }

    fn is_dissipative(&self) -> bool {
        SceneModel::is_dissipative(self)
    }

    /// `B = K − R`: the per-body damping `−c_b I`, the dashpots' `−c (e_a − e_b)(e_a − e_b)ᵀ`
    /// per axis, the magnetic field's skew `d × d` blocks.
    fn momentum_block(&self, n: usize, sink: &mut dyn Sink<T>) -> bool {
        let d = self.dim;
        if n != 2 * d * self.inv_masses.len() {
            return false;
        }
        if let Some(damping) = &self.damping {
            for (b, &c) in damping.per_body.iter().enumerate() {
                for k in 0..d {
                    sink.add(b * d + k, b * d + k, -c);
                }
            }
        }
        if let Some(dashpots) = &self.dashpots {
            for &(a, b, c) in &dashpots.pairs {
                for k in 0..d {
                    let (i, j) = (a * d + k, b * d + k);
                    sink.add(i, i, -c);
                    sink.add(i, j, c);
                    sink.add(j, i, c);
                    sink.add(j, j, -c);
                }
            }
        }
        if let Some(magnetic) = &self.magnetic {
            for (b, eb) in magnetic.per_body.iter().enumerate() {
                let i = b * d;
                if d == 2 {
                    sink.add(i, i + 1, eb[2]);
                    sink.add(i + 1, i, -eb[2]);
                } else {
                    // (v × e B)_x = v_y B_z − v_z B_y, …
                    sink.add(i, i + 1, eb[2]);
                    sink.add(i, i + 2, -eb[1]);
                    sink.add(i + 1, i + 2, eb[0]);
                    sink.add(i + 1, i, -eb[2]);
                    sink.add(i + 2, i, eb[1]);
                    sink.add(i + 2, i + 1, -eb[0]);
                }
            }
        }
        true
    }
}

impl<T: Real> SceneModel<T> {
    /// `op += α (−R_pp + J_B) vp`: the damping and magnetic blocks of `M` on the momenta.
    #[inline(always)]
    fn apply_dissipative_and_magnetic(&self, vp: &[T], alpha: T, op: &mut [T]) {
        let d = self.dim;
        if let Some(damping) = &self.damping {
            damping.counter.hit();
            for (b, c) in damping.per_body.iter().enumerate() {
                for k in 0..d {
                    op[b * d + k] = op[b * d + k] - (alpha * *c * vp[b * d + k]);
                }
            }
        }
        if let Some(dashpots) = &self.dashpots {
            dashpots.apply_add(vp, alpha, op, d);
        }
        if let Some(magnetic) = &self.magnetic {
            magnetic.counter.hit();
            // out_p += α v × (e B), written out per dimension (a stack temporary here costs a
            // store-forwarding stall per body).
            for (b, eb) in magnetic.per_body.iter().enumerate() {
                let i = b * d;
                if d == 2 {
                    op[i] = op[i] + (alpha * vp[i + 1] * eb[2]);
                    op[i + 1] = op[i + 1] - (alpha * vp[i] * eb[2]);
                } else {
                    let (vx, vy, vz) = (vp[i], vp[i + 1], vp[i + 2]);
                    op[i] = op[i] + (alpha * (vy * eb[2] - vz * eb[1]));
                    op[i + 1] = op[i + 1] + (alpha * (vz * eb[0] - vx * eb[2]));
                    op[i + 2] = op[i + 2] + (alpha * (vx * eb[1] - vy * eb[0]));
                }
            }
        }
    }
}
