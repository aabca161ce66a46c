use crate::vector::Vector;

/// Holonomic constraints `g: Rⁿ → Rᵐ`, `g(x) = 0`, with their Jacobian `G = ∂g/∂x` (m × n)
/// applied to vectors. Multipliers and residuals are plain slices of length `m`.
pub trait HolonomicConstraint<V: Vector> {
    /// The number of constraints `m`.
    fn dim(&self) -> usize;
    /// `out = g(x)` (`m` entries).
    fn residual(&self, x: &V, out: &mut [V::Real]);
    /// `out = G(x) v` (`m` entries).
    fn jacobian_apply(&self, x: &V, v: &V, out: &mut [V::Real]);
    /// `out += α G(x)ᵀ μ`.
    fn jacobian_transpose_apply_add(&self, x: &V, mu: &[V::Real], alpha: V::Real, out: &mut V);
}
