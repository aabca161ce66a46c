use crate::vector::Vector;

/// A Hamiltonian `H: Rⁿ → R` with its gradient.
pub trait Hamiltonian<V: Vector> {
    /// `H(x)`.
    fn energy(&self, x: &V) -> V::Real;
    /// `out = ∇H(x)` (overwrites).
    fn gradient(&self, x: &V, out: &mut V);
}
