//! The `k × k` stage blocks of a collocation-type step's Schur iteration
//! ([`SchurIteration`](super::schur::SchurIteration)): the pattern of `k` stages from that of
//! one, and the small dense inverses `D_d⁻¹ = (I_k − h w_d b_d Â)⁻¹` and their products.

use crate::real::Real;
use crate::vector::ops;

/// `k` from a `k × k` stage matrix.
pub(crate) fn stages_of<T>(stage: &[T]) -> usize {
    let k = stage.len().isqrt();
    debug_assert_eq!(k * k, stage.len(), "a stage matrix is square");
    k
}

/// The pattern of a `k`-stage system from the pattern of one stage: every entry `(r, c)`
/// becomes the `k × k` block at `(r k, c k)` (unknown `e` of stage `i` is at `e k + i`).
pub(crate) fn expand(pattern: &[(usize, usize)], k: usize) -> Vec<(usize, usize)> {
    if k == 1 {
        return pattern.to_vec();
    }
    pattern
        .iter()
        .flat_map(|&(r, c)| (0..k).flat_map(move |i| (0..k).map(move |j| (r * k + i, c * k + j))))
        .collect()
}

/// `inv = a⁻¹` (`k × k`, row-major) by Gauss–Jordan elimination with partial pivoting; `a`
/// is overwritten. `false` when a pivot vanishes or an entry is not finite.
pub(crate) fn invert<T: Real>(a: &mut [T], inv: &mut [T], k: usize) -> bool {
    ops::fill_zero(inv);
    for i in 0..k {
        inv[i * k + i] = T::one();
    }
    for col in 0..k {
        let Some(piv) = (col..k).max_by(|&x, &y| {
            a[x * k + col]
                .abs()
                .partial_cmp(&a[y * k + col].abs())
                .unwrap_or(core::cmp::Ordering::Equal)
        }) else {
            return false;
        };
        let p = a[piv * k + col];
        if !(p.is_finite() && p != T::zero()) {
            return false;
        }
        for j in 0..k {
            a.swap(col * k + j, piv * k + j);
            inv.swap(col * k + j, piv * k + j);
        }
        let scale = T::one() / p;
        for j in 0..k {
            a[col * k + j] = a[col * k + j] * scale;
            inv[col * k + j] = inv[col * k + j] * scale;
        }
        for r in (0..k).filter(|&r| r != col) {
            let f = a[r * k + col];
            for j in 0..k {
                a[r * k + j] = a[r * k + j] - f * a[col * k + j];
                inv[r * k + j] = inv[r * k + j] - f * inv[col * k + j];
            }
        }
    }
    inv.iter().all(|v| v.is_finite())
}

/// The max-row-sum norm of a `k × k` matrix.
pub(crate) fn inv_norm<T: Real>(a: &[T], k: usize) -> T {
    a.chunks_exact(k).fold(T::zero(), |m, row| {
        m.max(row.iter().fold(T::zero(), |s, &v| s + v.abs()))
    })
}

/// `v ← D⁻¹ v` with `D⁻¹` given by its `k × k` blocks `inv_d` (`block`: `k` entries of
/// scratch).
pub(crate) fn apply_blocks<T: Real>(k: usize, inv_d: &[T], block: &mut [T], v: &mut [T]) {
    match k {
        1 => {
            for (v, &inv) in v.iter_mut().zip(inv_d) {
                *v = *v * inv;
            }
        }
        // The stage counts of orders 4, 6 and 8: the products unrolled.
        2 => apply_blocks_k::<T, 2>(inv_d, v),
        3 => apply_blocks_k::<T, 3>(inv_d, v),
        4 => apply_blocks_k::<T, 4>(inv_d, v),
        _ => {
            for (chunk, inv) in v.chunks_exact_mut(k).zip(inv_d.chunks_exact(k * k)) {
                block.copy_from_slice(chunk);
                for (i, o) in chunk.iter_mut().enumerate() {
                    *o = ops::dot(&inv[i * k..(i + 1) * k], block);
                }
            }
        }
    }
}

/// [`apply_blocks`] with `k = K` known to the compiler (the same sums as `dot`).
fn apply_blocks_k<T: Real, const K: usize>(inv_d: &[T], v: &mut [T]) {
    for (chunk, inv) in v.chunks_exact_mut(K).zip(inv_d.chunks_exact(K * K)) {
        let b: [T; K] = core::array::from_fn(|i| chunk[i]);
        for (i, o) in chunk.iter_mut().enumerate() {
            let row = &inv[i * K..(i + 1) * K];
            let mut acc = T::zero();
            for j in 0..K {
                acc = acc + row[j] * b[j];
            }
            *o = acc;
        }
    }
}
