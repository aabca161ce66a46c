//! Describing a model: the structure matrix `M(x)`, the Hamiltonian `H`, holonomic constraints
//! `g(x) = 0`, and the pseudo-Poisson brackets built from them.
//!
//! The constrained generalized Hamiltonian system is
//!
//! ```text
//! x' = M(x) (∇H(x) + G(x)ᵀ λ),     g(x) = 0,     G = ∂g/∂x.
//! ```

mod analysis;
mod bracket;
mod check;
mod constraint;
mod dependent;
mod hamiltonian;
mod mechanical;
mod model;
mod modified;
mod reproject;
mod structure;

pub use analysis::MAX_BRACKET_CONSTRAINTS;
pub(crate) use analysis::{
    InitialChecks, check_initial_state, half_step_keeps_jacobian, probe_decoupled,
};
pub use bracket::{Brackets, Case, bracket};
pub use check::{Hints, ModelCheck, ModelReport, check_model};
pub use constraint::{HolonomicConstraint, Unconstrained};
pub use dependent::DropDependent;
pub use hamiltonian::Hamiltonian;
pub use mechanical::MechanicalForm;
pub use model::Model;
pub use modified::ModifiedHamiltonian;
pub use reproject::{MAX_REPROJECT_CONSTRAINTS, ReprojectError, Reprojection, reproject};
pub use structure::{
    Canonical, Constant, JMinusR, LiePoissonSo3, MomentumDamping, StructureMatrix,
};

use crate::vector::Vector;

/// A constrained generalized Hamiltonian system: structure matrix, Hamiltonian and constraint.
#[derive(Debug, Clone)]
pub struct System<Ms, H, C> {
    /// The structure matrix `M(x)`.
    pub structure: Ms,
    /// The Hamiltonian `H(x)`.
    pub hamiltonian: H,
    /// The holonomic constraints `g(x) = 0`.
    pub constraint: C,
}

impl<Ms, H, C> System<Ms, H, C> {
    /// Bundles the three parts of a model.
    pub fn new(structure: Ms, hamiltonian: H, constraint: C) -> Self {
        Self {
            structure,
            hamiltonian,
            constraint,
        }
    }

    /// `out = M(x) G(x)ᵀ λ`, the direction of a projection half-step (Prop. 2 of Zhang & Deng).
    /// `tmp` is workspace of the state's length.
    #[inline(always)]
    pub fn constraint_force<V>(&self, x: &V, lambda: &[V::Real], tmp: &mut V, out: &mut V)
    where
        V: Vector,
        Ms: StructureMatrix<V>,
        C: HolonomicConstraint<V>,
    {
        self.constraint.jacobian_transpose_apply(x, lambda, tmp);
        self.structure.apply(x, tmp, out);
    }

    /// The hidden constraint `φ(x) = ⟨g, H⟩ = G(x) M(x) ∇H(x)` (m entries).
    /// `t1`, `t2` are workspace of the state's length.
    #[inline]
    pub fn hidden_constraint<V>(&self, x: &V, t1: &mut V, t2: &mut V, out: &mut [V::Real])
    where
        V: Vector,
        Ms: StructureMatrix<V>,
        H: Hamiltonian<V>,
        C: HolonomicConstraint<V>,
    {
        if self.constraint.hidden_constraint_direct(x, out) {
            return;
        }
        self.hamiltonian.gradient(x, t1);
        self.structure.apply(x, t1, t2);
        self.constraint.jacobian_apply(x, t2, out);
    }

    /// `M(x) ∇H(x)`, the unconstrained vector field.
    #[inline]
    pub fn vector_field<V>(&self, x: &V, tmp: &mut V, out: &mut V)
    where
        V: Vector,
        Ms: StructureMatrix<V>,
        H: Hamiltonian<V>,
    {
        self.hamiltonian.gradient(x, tmp);
        self.structure.apply(x, tmp, out);
    }
}
