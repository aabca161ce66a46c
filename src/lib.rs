//! # lieflow
//!
//! Lie group integrators with projection for **constrained generalized Hamiltonian systems with
//! dissipation**,
//!
//! ```text
//! x' = M(x) (∇H(x) + G(x)ᵀ λ),     g(x) = 0,     G = ∂g/∂x,
//! ```
//!
//! where the structure matrix `M` may be non-canonical, state-dependent and dissipative
//! (port-Hamiltonian `J − R`). The method is that of Zhang & Deng (2004): a Lie group flow
//! `exp(h D_K)` (a closed-form sub-flow or a composition of them) between two projection
//! half-steps `x + (h/2) M Gᵀ λ` whose multipliers Newton finds so that the constraint and its
//! hidden constraint `φ = ⟨g, H⟩ = G M ∇H` hold; symmetric composition (Yoshida and others)
//! raises the order.
//!
//! ## Quickstart: the paper's example
//!
//! ```
//! use lieflow::prelude::*;
//! use lieflow::models::paper;
//! use nalgebra::SVector;
//!
//! let mut x: SVector<f64, 4> = paper::initial_state();
//! // exp(h D_H) is a drift; project around it; compose to order 4.
//! let mut flow = paper::drift()
//!     .projected(paper::system(), &x, ProjectionOptions::default())?
//!     .triple_jump();
//! for _ in 0..1000 {
//!     flow.step(0.1, &mut x)?;
//! }
//! let mut g = [0.0];
//! HolonomicConstraint::<SVector<f64, 4>>::residual(&paper::Circle, &x, &mut g);
//! assert!(g[0].abs() < 1e-14);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! ## Modules
//!
//! - [`system`]: the model traits [`StructureMatrix`], [`Hamiltonian`], [`HolonomicConstraint`],
//!   built-in structures, and the pseudo-Poisson [brackets](system::Brackets).
//! - [`flow`]: the [`Flow`] trait, closed-form sub-flows, composition tables, projection.
//! - [`nonlinear`], [`linalg`]: Newton and the linear solvers behind it.
//! - [`integrate()`]: the fixed-step driver with observers.
//! - [`models`]: ready-made models.
//! - [`Vector`]: one API over stack (`nalgebra::SVector`) and heap (`faer::Col`) storage.
//!
//! Reference: Zhang Su-ying, Deng Zi-chen, *Lie group integration for constrained generalized
//! Hamiltonian system with dissipation by projection method*, Applied Mathematics and Mechanics
//! 25(4), 2004.
#![forbid(unsafe_code)]
#![warn(missing_docs)]

#[cfg(feature = "autodiff")]
pub mod autodiff;
pub mod error;
pub mod flow;
pub mod integrate;
pub mod linalg;
pub mod models;
pub mod nonlinear;
pub mod observe;
pub mod port;
mod real;
pub mod rigid;
#[cfg(feature = "scene")]
pub mod scene;
pub mod stepper;
pub mod system;
mod vector;

pub use error::{IntegrateError, LinearSolveError, NewtonError, SetupError, StepError};
pub use flow::{Flow, FlowExt, FlowStats};
pub use integrate::integrate;
pub use observe::Observer;
pub use real::Real;
pub use stepper::Stepper;
pub use system::{Hamiltonian, HolonomicConstraint, StructureMatrix, System};
pub use vector::{Vector, ops};

/// The README's code blocks, compiled and run as doctests so the quickstart cannot rot.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;

/// The names most programs need.
pub mod prelude {
    pub use crate::error::{IntegrateError, SetupError, StepError};
    pub use crate::flow::{
        ConstrainedDiscreteGradient, Coupling, DiscreteGradient, Flow, FlowExt, ImplicitMidpoint,
        LinearFlow, ProjectedMidpoint, ProjectionOptions, Scheme, coefficients, from_fn,
        from_fn_with_order,
    };
    pub use crate::integrate::integrate;
    pub use crate::observe::{InvariantError, MaxResidual, Observer, Trajectory};
    pub use crate::stepper::Stepper;
    pub use crate::system::{
        Canonical, Case, Constant, Hamiltonian, HolonomicConstraint, JMinusR, ModifiedHamiltonian,
        MomentumDamping, StructureMatrix, System,
    };
    pub use crate::{Real, Vector};
}
