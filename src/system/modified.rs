//! The modified Hamiltonian `H_N1 = H + μ(x)ᵀ g(x)` of Zhang & Deng (2004, §1–2).

use super::{Hamiltonian, HolonomicConstraint};
use crate::vector::{Vector, ops};
use core::cell::RefCell;
use num_traits::One;

/// The modified Hamiltonian `K = H_N1 = H + μ(x)ᵀ g(x)` whose flow keeps the constraint
/// manifold weakly invariant (Zhang & Deng 2004, §1): `μ = −⟨g,g⟩⁻¹⟨g,H⟩` in the
/// non-degenerate case, `μ = −⟨φ,g⟩⁻¹⟨φ,H⟩` in the degenerate case
/// ([`Brackets::modified_multiplier`](super::Brackets::modified_multiplier) computes either by
/// finite differences, for checking a model's closed form).
///
/// `mu(x, out)` writes `μ(x)` (`m` entries). The gradient is taken as
///
/// ```text
/// ∇K(x) = ∇H(x) + G(x)ᵀ μ(x)          (the term (∂μ/∂x)ᵀ g(x) is dropped),
/// ```
///
/// which is exact on the manifold `g = 0`, where the flow of `K` lives, and keeps a model from
/// having to differentiate `μ` (itself a ratio of brackets). Off the manifold the difference is
/// `O(|g|)`; inside the projection half-steps of the paper's §2 scheme, `g` is `O(h³)` there.
/// `M ∇K = M(∇H + Gᵀμ)` is then the vector field of the constrained system itself, so use
/// `K` with a general flow ([`ImplicitMidpoint`](crate::flow::ImplicitMidpoint)), not with a
/// discrete gradient (whose energy differences would not match this gradient off `g = 0`).
pub struct ModifiedHamiltonian<H, C, F, T> {
    hamiltonian: H,
    constraint: C,
    mu: F,
    work: RefCell<Vec<T>>,
}

impl<H, C, F, T> core::fmt::Debug for ModifiedHamiltonian<H, C, F, T> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("ModifiedHamiltonian")
            .field("m", &self.work.borrow().len())
            .finish_non_exhaustive()
    }
}

impl<H, C, F, T: Clone + num_traits::Zero> ModifiedHamiltonian<H, C, F, T> {
    /// `K = H + μᵀ g` for `m = constraint.dim()` constraints, `μ` given by `mu(x, out)`.
    pub fn new<V>(hamiltonian: H, constraint: C, mu: F) -> Self
    where
        V: Vector<Real = T>,
        C: HolonomicConstraint<V>,
        F: Fn(&V, &mut [T]),
    {
        let m = constraint.dim();
        Self {
            hamiltonian,
            constraint,
            mu,
            work: RefCell::new(vec![T::zero(); 2 * m]),
        }
    }
}

impl<V, H, C, F> Hamiltonian<V> for ModifiedHamiltonian<H, C, F, V::Real>
where
    V: Vector,
    H: Hamiltonian<V>,
    C: HolonomicConstraint<V>,
    F: Fn(&V, &mut [V::Real]),
{
    fn energy(&self, x: &V) -> V::Real {
        let mut work = self.work.borrow_mut();
        let (mu, g) = work.split_at_mut(self.constraint.dim());
        (self.mu)(x, mu);
        self.constraint.residual(x, g);
        self.hamiltonian.energy(x) + ops::dot(mu, g)
    }
    fn gradient(&self, x: &V, out: &mut V) {
        let mut work = self.work.borrow_mut();
        let (mu, _) = work.split_at_mut(self.constraint.dim());
        (self.mu)(x, mu);
        self.hamiltonian.gradient(x, out);
        self.constraint
            .jacobian_transpose_apply_add(x, mu, V::Real::one(), out);
    }
}
