//! What a projection is asked to do: the case, the coupling, Newton's options and the
//! initial checks ([`ProjectionOptions`]), and the scheme it settles on ([`Scheme`]).

use crate::nonlinear::NewtonOptions;
use crate::real::Real;
use crate::system::{Case, InitialChecks};

/// How the two multiplier systems of the degenerate case are solved.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Coupling {
    /// `λ_k` then `λ_{k+1}`, each an `m × m` Newton solve. Valid when the second half-step changes
    /// neither `g` nor `M Gᵀ` (checked after every step).
    Decoupled,
    /// One `2m × 2m` Newton solve for `(λ_k, λ_{k+1})` with `x_{k+1}` implicit.
    Coupled,
}

/// The variant a [`Projected`](super::Projected) flow runs, resolved at construction.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scheme {
    /// Degenerate case, decoupled solves (RATTLE-like).
    Decoupled,
    /// Degenerate case, coupled solve.
    Coupled,
    /// Non-degenerate case: Hairer's symmetric projection.
    Symmetric,
}

/// Options of [`Projected`](super::Projected).
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub struct ProjectionOptions<T> {
    /// The case; `None` decides from the brackets at the initial state.
    pub case: Option<Case>,
    /// The coupling in the degenerate case; `None` probes the model at the initial state.
    pub coupling: Option<Coupling>,
    /// Newton options for the multiplier systems.
    pub newton: NewtonOptions<T>,
    /// `⟨g,g⟩` counts as zero when `‖⟨g,g⟩‖∞ ≤ degeneracy_tol · n ‖Gᵀ‖ ‖M Gᵀ‖`. Default `√ε`.
    pub degeneracy_tol: T,
    /// A bracket matrix counts as singular when its smallest LU pivot is below `rcond` times its
    /// largest entry. Default `1e-8` (the brackets with `φ` are finite differences).
    pub rcond: T,
    /// Iteration limit of the fixed point for the implicit end point. Default 50.
    pub fixed_point_max_iterations: usize,
    /// The initial state must satisfy `‖g(x₀)‖∞ ≤ manifold_tol` (and `‖φ(x₀)‖∞ ≤ manifold_tol` in
    /// the degenerate case), or construction fails with [`SetupError::OffManifold`](crate::error::SetupError::OffManifold): the
    /// scheme's symmetry and invariants hold on the manifold. So must every state a step starts
    /// from that is not the flow's own last result (a state changed between steps by the
    /// caller), or the step fails with [`StepError::OffManifold`](crate::StepError::OffManifold)
    /// instead of silently projecting it back. `None` skips both checks (a step then projects
    /// onto `g = 0`, `φ = 0`: an explicit opt-in). Default `√ε`.
    pub manifold_tol: Option<T>,
}

impl<T: Real> Default for ProjectionOptions<T> {
    fn default() -> Self {
        Self {
            case: None,
            coupling: None,
            newton: NewtonOptions::default(),
            degeneracy_tol: T::epsilon().sqrt(),
            rcond: T::lit(1e-8),
            fixed_point_max_iterations: 50,
            manifold_tol: Some(T::epsilon().sqrt()),
        }
    }
}

impl<T: Real> ProjectionOptions<T> {
    /// Forces the case instead of deciding it from the brackets.
    pub fn with_case(mut self, case: Case) -> Self {
        self.case = Some(case);
        self
    }
    /// Forces the coupling of the degenerate case.
    pub fn with_coupling(mut self, coupling: Coupling) -> Self {
        self.coupling = Some(coupling);
        self
    }
    /// Sets the Newton options.
    pub fn with_newton(mut self, newton: NewtonOptions<T>) -> Self {
        self.newton = newton;
        self
    }
    /// The initial-state checks these options ask for.
    pub(crate) fn initial_checks(&self) -> InitialChecks<T> {
        InitialChecks {
            case: self.case,
            degeneracy_tol: self.degeneracy_tol,
            rcond: self.rcond,
            manifold_tol: self.manifold_tol,
            solver: self.newton.solver,
        }
    }
    /// Sets (or with `None` disables) the check that the initial state is on the manifold.
    pub fn with_manifold_tol(mut self, tol: Option<T>) -> Self {
        self.manifold_tol = tol;
        self
    }
}
