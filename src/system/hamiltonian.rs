use crate::vector::Vector;

/// A Hamiltonian `H: Rⁿ → R` with its gradient.
pub trait Hamiltonian<V: Vector> {
    /// `H(x)`.
    fn energy(&self, x: &V) -> V::Real;
    /// `out = ∇H(x)` (overwrites).
    fn gradient(&self, x: &V, out: &mut V);
    /// `H(y) − H(x)`. The default subtracts the two energies, which loses all accuracy when
    /// `y → x` (relative error `ε |H| / |H(y) − H(x)|`). Discrete-gradient flows divide this
    /// difference by `|y − x|²`; a model that overrides it with a cancellation-free formula
    /// (e.g. `(p'−p)(p'+p)/2` for `p²/2`, `2 sin((q+q')/2) sin((q'−q)/2)` for `cos q − cos q'`)
    /// makes them accurate down to the smallest steps.
    fn energy_difference(&self, x: &V, y: &V) -> V::Real {
        self.energy(y) - self.energy(x)
    }
    /// `out = ∇²H(x) v` and `true`, if the model provides its Hessian. Implicit flows then build
    /// their Newton matrices in closed form (exact, and no extra residual evaluations). The
    /// default returns `false`: the flows fall back to finite differences of their residual,
    /// which is slower (`n` evaluations per Jacobian) and accurate only to about `√ε`.
    fn hessian_apply(&self, x: &V, v: &V, out: &mut V) -> bool {
        let _ = (x, v, out);
        false
    }
    /// `true` when `H` is quadratic (a quadratic form plus an affine part), so that `∇²H` is
    /// the same at every state and [`hessian_apply`](Self::hessian_apply) answers. Then, with a
    /// constant structure matrix and position constraints, the hidden constraint
    /// `φ(y + (h/2) M Gᵀ λ)` is affine in `λ`, and a projection solves for `λ_{k+1}` with one
    /// linear solve instead of Newton iterations. Default `false` (always safe).
    fn is_quadratic(&self) -> bool {
        false
    }
    /// Writes the inverse masses `w` (`n/2` entries) and returns `true` when `H` has the
    /// mechanical form `H(q, p) = ½ Σᵢ wᵢ pᵢ² + V(q)` on `x = (q, p)`, `q, p ∈ R^{n/2}`: a
    /// constant diagonal mass matrix and a potential of the positions alone. Together with
    /// [`StructureMatrix::momentum_block`](crate::system::StructureMatrix::momentum_block)
    /// it lets implicit flows eliminate the momenta from their Newton systems (half the
    /// unknowns; see `ProjectedMidpoint`). The default returns `false` (always safe); flows
    /// check a `true` at construction against [`gradient`](Self::gradient) and
    /// [`hessian_apply`](Self::hessian_apply).
    fn kinetic_inverse_mass(&self, w: &mut [V::Real]) -> bool {
        let _ = w;
        false
    }
    /// Appends the positions `(row, col)` at which `∇²H` can be non-zero at some state (of a
    /// state of `n` entries) and returns `true`; the default returns `false` (dense). Implicit
    /// flows derive the sparsity of their Newton matrices from it, so that a Jacobian costs a
    /// few grouped Hessian products and a sparse factorization (Curtis, Powell & Reid 1974).
    /// A missing position makes Newton matrices inexact (slower convergence, the same answer);
    /// a closed-form Hessian product outside the pattern is reported as
    /// [`LinearSolveError::PatternIncomplete`](crate::LinearSolveError::PatternIncomplete).
    fn hessian_pattern(&self, n: usize, out: &mut Vec<(usize, usize)>) -> bool {
        let _ = (n, out);
        false
    }
}
