//! How many Gauss points the Petrov–Galerkin step integrates with: the fewest that make its
//! integrals exact when they are polynomials.

use crate::system::HolonomicConstraint;
use crate::vector::Vector;
use num_traits::Zero;

/// The fewest Gauss points `s` for which every integral of the Petrov–Galerkin step of `k`
/// stages is exact, given whether `H` and the `m` constraints are quadratic; `k + 2` when
/// one of them is not (then the integrals are not polynomials, and the two points beyond `k`
/// put the energy balance's quadrature error `O(h^{2k+5})` far below the step's error).
///
/// With `∇H` and `G` affine and `x ∈ P_k`, `z, λ, v, w, μ ∈ P_{k−1}`, the integrands have the
/// degrees `2k − 2` (`⟨x' − Mz, v⟩`), `2k − 1` (`⟨z − ∇H(x), w⟩`) and `3k − 2`
/// (`⟨M G(x)ᵀλ, v⟩`, `⟨G(x) x', μ⟩`); a Gauss rule of `s` points is exact to degree `2s − 1`
/// (Abramowitz & Stegun 25.4.29). So `s = ⌈(3k − 1)/2⌉ = ⌊3k/2⌋` with constraints (1, 3, 4, 6
/// for `k = 1 … 4`) and `s = k` without: the equations, and so the step, are those of every
/// larger `s`.
pub fn exact_quadrature(k: usize, m: usize, h_quadratic: bool, g_quadratic: bool) -> usize {
    if !h_quadratic || (m > 0 && !g_quadratic) {
        k + 2
    } else if m == 0 {
        k
    } else {
        3 * k / 2
    }
}

/// Whether every component of `g` is quadratic (or affine) in `x`: the constraint says so by
/// answering [`HolonomicConstraint::hessian_form`] (its Hessians are then constant).
pub(super) fn constraint_is_quadratic<V: Vector, C: HolonomicConstraint<V>>(
    constraint: &C,
    x0: &V,
) -> bool {
    let m = constraint.dim();
    if m == 0 {
        return true;
    }
    let mut out = vec![V::Real::zero(); m];
    constraint.hessian_form(x0, x0, x0, &mut out)
}
