//! The end of an implicit step (Petrov–Galerkin, the constrained discrete gradient): the
//! hidden-constraint projection `x = x_e + M Gᵀν`, `φ(x) = 0`, and the kinetic energy it
//! removes (counted in the step's dissipated energy `D_n`).

use crate::error::{NewtonError, StepError};
use crate::flow::projection::HiddenSolver;
use crate::nonlinear::{SMALL_MAX, SolveReport};
use crate::real::Real;
use crate::system::{Hamiltonian, Model};
use crate::vector::Vector;
use num_traits::Zero;

/// `x ← x_e + M Gᵀν` with `φ(x) = 0`, by the solver sized for the `ν.len()` multipliers (on
/// the stack up to [`SMALL_MAX`]).
pub(crate) fn project<V: Vector, Sys: Model<V>>(
    hidden: &mut HiddenSolver<V>,
    system: &Sys,
    xe: &V,
    x: &mut V,
    tmp: &mut V,
    t2: &mut V,
    nu: &mut [V::Real],
) -> Result<SolveReport<V::Real>, NewtonError<StepError>> {
    match nu.len() {
        1 => hidden.project::<1, _>(system, xe, x, tmp, t2, nu),
        2 => hidden.project::<2, _>(system, xe, x, tmp, t2, nu),
        3 => hidden.project::<3, _>(system, xe, x, tmp, t2, nu),
        4 => hidden.project::<SMALL_MAX, _>(system, xe, x, tmp, t2, nu),
        _ => hidden.project::<0, _>(system, xe, x, tmp, t2, nu),
    }
}

/// `H(x_e) − H(x)`, the energy the projection removed (`≥ 0` in the kinetic metric). For a
/// mechanical form (`(n_q, diag W⁻¹)`) only the momenta moved (`M Gᵀν` has no position rows):
/// the kinetic energy `Σ ½ w_d (p_d − p'_d)(p_d + p'_d)`, without a second potential.
pub(crate) fn removed_energy<V: Vector, Sys: Model<V>>(
    system: &Sys,
    mechanical: Option<(usize, &[V::Real])>,
    xe: &V,
    x: &V,
) -> V::Real {
    match mechanical {
        Some((nq, w)) => {
            let (pe, p) = (&xe.as_slice()[nq..], &x.as_slice()[nq..]);
            let half = V::Real::lit(0.5);
            w.iter()
                .zip(pe)
                .zip(p)
                .fold(V::Real::zero(), |acc, ((&w, &a), &b)| {
                    acc + half * w * (a - b) * (a + b)
                })
        }
        None => {
            let energy = system.hamiltonian();
            energy.energy(xe) - energy.energy(x)
        }
    }
}
