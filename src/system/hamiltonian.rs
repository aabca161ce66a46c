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
}
