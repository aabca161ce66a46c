//! The energy account of one Petrov–Galerkin step.

use crate::real::Real;

/// The energy of one step: `H(x_{n+1}) − H(x_n) = −D_n + S_n` to the Newton tolerance (and the
/// quadrature of a non-polynomial `H`), `S_n` the work the inputs supplied (zero without).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DiscreteDissipation<T> {
    /// `H(x_n)`.
    pub before: T,
    /// `H(x_{n+1})`: the step's end energy less the energy the projection removed (for a
    /// model of mechanical form the kinetic difference, so equal to `H(x_{n+1})` to rounding).
    pub after: T,
    /// `h ∫₀¹ zᵀ R z dτ ≥ 0`, by the quadrature: what the damping removed.
    pub damping: T,
    /// The kinetic energy the hidden-constraint projection removed, `≥ 0`.
    pub projection: T,
    /// `S_n = h Σ_r b_r z(e_r)ᵀ B(x_r) u(t_r)`: the work of the inputs, by the quadrature
    /// (`supplied.rs`); zero without inputs.
    pub supplied: T,
}

impl<T: Real> DiscreteDissipation<T> {
    /// `D_n = damping + projection`.
    pub fn total(&self) -> T {
        self.damping + self.projection
    }
}
