//! A model as one type: its structure matrix, Hamiltonian and constraint together, so that the
//! flows and helpers that need all three are generic over one parameter.

use super::{Hamiltonian, HolonomicConstraint, StructureMatrix, System};
use crate::vector::Vector;

/// A constrained generalized Hamiltonian system `x' = M(x)(∇H(x) + G(x)ᵀλ)`, `g(x) = 0`, as one
/// type: the three parts by reference, and the products every constrained flow forms from them.
/// Implemented for [`System`]; a model type that holds its parts differently implements it
/// directly.
pub trait Model<V: Vector> {
    /// The structure matrix `M(x)`.
    type Structure: StructureMatrix<V>;
    /// The Hamiltonian `H(x)`.
    type Hamiltonian: Hamiltonian<V>;
    /// The holonomic constraints `g(x) = 0`.
    type Constraint: HolonomicConstraint<V>;

    /// `M`.
    fn structure(&self) -> &Self::Structure;
    /// `H`.
    fn hamiltonian(&self) -> &Self::Hamiltonian;
    /// `g`.
    fn constraint(&self) -> &Self::Constraint;

    /// `out = M(x) G(x)ᵀ λ`, the direction of a projection half-step (Prop. 2 of Zhang & Deng).
    /// `tmp` is workspace of the state's length.
    #[inline(always)]
    fn constraint_force(&self, x: &V, lambda: &[V::Real], tmp: &mut V, out: &mut V) {
        if self.constraint().constraint_force_direct(x, lambda, out) {
            return;
        }
        self.constraint().jacobian_transpose_apply(x, lambda, tmp);
        self.structure().apply(x, tmp, out);
    }

    /// The hidden constraint `φ(x) = ⟨g, H⟩ = G(x) M(x) ∇H(x)` (m entries).
    /// `t1`, `t2` are workspace of the state's length.
    #[inline(always)]
    fn hidden_constraint(&self, x: &V, t1: &mut V, t2: &mut V, out: &mut [V::Real]) {
        if self.constraint().hidden_constraint_direct(x, out) {
            return;
        }
        self.hamiltonian().gradient(x, t1);
        self.structure().apply(x, t1, t2);
        self.constraint().jacobian_apply(x, t2, out);
    }

    /// `M(x) ∇H(x)`, the unconstrained vector field.
    #[inline]
    fn vector_field(&self, x: &V, tmp: &mut V, out: &mut V) {
        self.hamiltonian().gradient(x, tmp);
        self.structure().apply(x, tmp, out);
    }
}

impl<V, Ms, H, C> Model<V> for System<Ms, H, C>
where
    V: Vector,
    Ms: StructureMatrix<V>,
    H: Hamiltonian<V>,
    C: HolonomicConstraint<V>,
{
    type Structure = Ms;
    type Hamiltonian = H;
    type Constraint = C;

    #[inline(always)]
    fn structure(&self) -> &Ms {
        &self.structure
    }
    #[inline(always)]
    fn hamiltonian(&self) -> &H {
        &self.hamiltonian
    }
    #[inline(always)]
    fn constraint(&self) -> &C {
        &self.constraint
    }
}
