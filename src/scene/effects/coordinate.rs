//! What the potentials on a joint coordinate (a hinge's angle, a slider's displacement:
//! [`JointCoordinate`]) share: the Hessian product of a spring on it and the slots it couples.

use crate::real::Real;
use crate::rigid::JointCoordinate;

/// `out += k (∇c·v) ∇c + k s ∇²c v`: the Hessian product of `V = k/2 s²` along `v`, with
/// `s = c(q) − c₀` the stretch of the coordinate `c` (`∇s = ∇c`).
pub(super) fn spring_hessian_add<C: JointCoordinate, T: Real>(
    c: &C,
    q: &[T],
    v: &[T],
    k: T,
    s: T,
    out: &mut [T],
) {
    let cv = c.derivative(q, v);
    c.gradient_add(q, k * cv, out);
    c.hessian_apply_add(q, v, k * s, out);
}

/// Every pair of `slots`: the blocks of the Hessian a potential on the coordinate fills.
pub(super) fn slot_pairs(slots: &[usize], out: &mut Vec<(usize, usize)>) {
    for &a in slots {
        out.extend(slots.iter().map(|&b| (a, b)));
    }
}
