//! The Petrov–Galerkin step's basis tables in the scalar of the run: the Gauss weights, the
//! Lagrange basis at the quadrature points and its integrals, and the tables of the eliminated
//! position rows.

use super::basis::Basis;
use crate::real::Real;

/// The basis tables in the scalar of the run.
#[derive(Debug, Clone)]
pub(crate) struct Tables<T> {
    pub(super) k: usize,
    pub(super) s: usize,
    pub(super) beta: Vec<T>,
    /// The quadrature nodes `e_r` and weights `b_r` on `[0, 1]`.
    pub(super) nodes: Vec<T>,
    pub(super) b: Vec<T>,
    pub(super) ell: Vec<T>,
    pub(super) a: Vec<T>,
    /// `Â_ij = (1/β_i) Σ_r b_r ℓ_i(e_r) A_rj` (`k × k`): for a mechanical model the position
    /// rows of (a) are `Y^q_i = h W⁻¹ (p_n + Σ_j Â_ij Y^p_j)` exactly.
    pub(super) ahat: Vec<T>,
    /// `Σ_j ℓ_j(e_r) Â_jl` (`s × k`): `h x'_q(e_r)` from the momentum increments.
    pub(super) ell_ahat: Vec<T>,
    /// The test weights `b_r ℓ_i(e_r) / β_i` (`s × k`): what quadrature point `r` adds to
    /// the rows of Gauss point `i`.
    pub(super) test: Vec<T>,
    /// `max_i Σ_r |b_r ℓ_i(e_r)|/β_i`: how many roundings of a constraint force at one
    /// quadrature point a state row of the residual sums.
    pub(super) rounding_weight: T,
}

impl<T: Real> Tables<T> {
    pub(super) fn new(k: usize, s: usize) -> Self {
        let basis = Basis::new(k, s);
        let cast = |v: &[f64]| v.iter().map(|&x| T::lit(x)).collect::<Vec<T>>();
        let (beta, b, ell, a) = (
            cast(&basis.beta),
            cast(&basis.b),
            cast(&basis.ell),
            cast(&basis.a),
        );
        // In the run's scalar from the cast tables, so that the eliminated rows agree with
        // the full residual's to rounding.
        let mut ahat = vec![T::zero(); k * k];
        for i in 0..k {
            for j in 0..k {
                let sum = (0..s).fold(T::zero(), |acc, r| {
                    acc + b[r] * ell[r * k + i] * a[r * k + j]
                });
                ahat[i * k + j] = sum / beta[i];
            }
        }
        let mut ell_ahat = vec![T::zero(); s * k];
        for r in 0..s {
            for l in 0..k {
                ell_ahat[r * k + l] =
                    (0..k).fold(T::zero(), |acc, j| acc + ell[r * k + j] * ahat[j * k + l]);
            }
        }
        let rounding_weight = (0..k).fold(T::zero(), |m, i| {
            m.max((0..s).fold(T::zero(), |acc, r| {
                acc + (b[r] * ell[r * k + i]).abs() / beta[i]
            }))
        });
        let test = (0..s * k)
            .map(|e| b[e / k] * ell[e] / beta[e % k])
            .collect();
        Self {
            test,
            nodes: cast(&basis.e),
            b,
            k: basis.k,
            s: basis.s,
            beta,
            ell,
            a,
            ahat,
            ell_ahat,
            rounding_weight,
        }
    }
}
