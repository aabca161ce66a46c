use crate::linalg::Sink;
use crate::vector::{Vector, ops};
use num_traits::One as _;

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
    /// `out = G(x)ᵀ μ`. The default zeroes `out` and calls
    /// [`jacobian_transpose_apply_add`](Self::jacobian_transpose_apply_add); a model that writes
    /// the entries directly saves that pass and, for a small state, the additions to zero on
    /// the latency chain of a projection's half-step direction `M Gᵀ μ` (the compiler may not
    /// drop `0 + a`, which is `+0` for `a = −0`).
    #[inline]
    fn jacobian_transpose_apply(&self, x: &V, mu: &[V::Real], out: &mut V) {
        ops::fill_zero(out.as_mut_slice());
        self.jacobian_transpose_apply_add(x, mu, V::Real::one(), out);
    }
    /// Writes `out_i = uᵀ ∇²g_i v` and returns `true` when every component of `g` is quadratic
    /// in `x` (constant Hessians: rods and spheres `(|q_a − q_b|² − L²)/2`, planes, pins), so
    /// that `g(x + δ) = g(x) + G(x) δ + ½ δᵀ∇²g δ` exactly; the default returns `false`. A
    /// projection around an affine inner flow then solves its `λ_k` system from the exact
    /// quadratic model (see [`NonlinearProblem::second_derivative`](crate::nonlinear::NonlinearProblem::second_derivative)).
    fn hessian_form(&self, x: &V, u: &V, v: &V, out: &mut [V::Real]) -> bool {
        let _ = (x, u, v, out);
        false
    }
    /// Writes the structurally non-zero entries of `G(x)` — `(constraint, state index, value)` —
    /// into `sink` and returns `true`; the same positions in the same order for every `x`.
    /// The default returns `false`: `G` is then treated as dense.
    ///
    /// A model with many constraints should provide it: the projection derives the sparsity of
    /// its multiplier systems from it (constraints `i`, `j` couple when their gradients share a
    /// state variable), which makes their Jacobians cost a few residual evaluations and a
    /// sparse LU, and checks at construction that the constraints are not redundant.
    fn jacobian_entries(&self, x: &V, sink: &mut dyn Sink<V::Real>) -> bool {
        let _ = (x, sink);
        false
    }
    /// Writes the values of the entries [`jacobian_entries`](Self::jacobian_entries) lists, in
    /// its order, into `out` and returns `true`; `false` (the default) when the model does not
    /// offer them this way or `out` does not hold exactly that many. The numeric half of the
    /// pattern without a [`Sink`] call per entry: a projection that sums its multiplier
    /// Jacobians from `G`'s entries refills them at every Jacobian.
    fn jacobian_values(&self, x: &V, out: &mut [V::Real]) -> bool {
        let _ = (x, out);
        false
    }
    /// Writes the hidden constraint `φ(x) = G(x) M(x) ∇H(x)` into `out` and returns `true`, for
    /// a model that knows it without `∇H`; the default returns `false` and `φ` is computed from
    /// `∇H`, `M` and `G`.
    ///
    /// The case it is for: constraints on positions `q` under a structure matrix whose position
    /// rows are `q' = ∂H/∂p` (`J` canonical in its `qp` blocks; dissipation and gyroscopic terms
    /// act on momenta). Then `φ = G_q ∂H/∂p`, and for `H = ½ pᵀW⁻¹p + V(q)` that is the
    /// constraint velocity `G_q W⁻¹ p` — no evaluation of `∇V`, which for pair potentials is the
    /// expensive part and which the multiplier solves of a projection would otherwise evaluate at
    /// every Newton iteration of `λ_{k+1}`. Only a type that implements the constraint, the
    /// structure and the Hamiltonian of one model (as a compiled scene does) can know this.
    fn hidden_constraint_direct(&self, x: &V, out: &mut [V::Real]) -> bool {
        let _ = (x, out);
        false
    }
    /// Writes the derivative of the hidden constraint along a direction `d` that moves momenta
    /// only, `G M ∇²H d`, into `out` and returns `true`, for a model whose `φ` is
    /// [`hidden_constraint_direct`](Self::hidden_constraint_direct)'s `G_q W⁻¹ p`: linear in
    /// `p`, so the derivative is the same map applied to `d`'s momenta, `G_q W⁻¹ d_p`, without
    /// `∇²H` or `M`. The default returns `false` (a model must also for a `d` whose positions are
    /// not all zero): the derivative is then formed from `∇²H`, `M` and `G`.
    ///
    /// The case it is for: a projection's `λ_{k+1}` system moves `x_{k+1}` along
    /// `(h/2) M Gᵀ e_j = (0, −(h/2) G_qᵀ e_j)`, so its Jacobian's columns are these derivatives
    /// (and the system is affine in `λ_{k+1}`).
    fn hidden_derivative_direct(&self, x: &V, d: &V, out: &mut [V::Real]) -> bool {
        let _ = (x, d, out);
        false
    }
    /// Writes the constraint force `M(x) G(x)ᵀ λ` into `out` and returns `true`, for a model
    /// that knows it without applying `M` (see
    /// [`hidden_constraint_direct`](Self::hidden_constraint_direct)); the default returns
    /// `false` and the force is `M` applied to `Gᵀλ`.
    ///
    /// The same case: position constraints under `M = [[0, I], [−I, K − R]]`, where `Gᵀλ =
    /// (G_qᵀλ, 0)` and so `M Gᵀλ = (0, −G_qᵀλ)` whatever the damping `R` and gyroscopic `K`,
    /// which act on the momentum part `Gᵀλ` does not have. A projection forms this direction at
    /// every residual of its multiplier systems.
    fn constraint_force_direct(&self, x: &V, lambda: &[V::Real], out: &mut V) -> bool {
        let _ = (x, lambda, out);
        false
    }
}

/// No constraints (`m = 0`): a [`System`](super::System) of an unconstrained model, e.g. to
/// check its derivatives with [`check_model`](super::check_model) or to run it through a scene.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Unconstrained;

impl<V: Vector> HolonomicConstraint<V> for Unconstrained {
    fn dim(&self) -> usize {
        0
    }
    fn residual(&self, _x: &V, _out: &mut [V::Real]) {}
    fn jacobian_apply(&self, _x: &V, _v: &V, _out: &mut [V::Real]) {}
    fn jacobian_transpose_apply_add(&self, _x: &V, _mu: &[V::Real], _alpha: V::Real, _out: &mut V) {
    }
}
