//! A consistent re-projection onto the constraint manifold after an external change of the
//! state (an impulse from a contact model, a reset by a supervisor).

use super::{HolonomicConstraint, Model};
use crate::real::Real;
use crate::vector::Vector;
use nalgebra::DMatrix;

/// The largest number of constraints [`reproject`] handles (its solves are dense, `O(m³)`).
pub const MAX_REPROJECT_CONSTRAINTS: usize = 2000;

/// What a re-projection did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reprojection {
    /// `max |x_after − x_before|`: how far the state was moved.
    pub moved: f64,
    /// `max |g|` before and after.
    pub g_before: f64,
    /// `max |g|` after.
    pub g_after: f64,
    /// `max |φ|` before (the hidden constraint; 0 when not projected).
    pub phi_before: f64,
    /// `max |φ|` after.
    pub phi_after: f64,
    /// Newton iterations for `g`, then for `φ`.
    pub iterations: (usize, usize),
}

/// A re-projection that did not reach the manifold.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ReprojectError {
    /// More constraints than the dense solves take.
    #[error("{m} constraints: re-projection takes at most {max}")]
    TooManyConstraints {
        /// Constraints of the model.
        m: usize,
        /// [`MAX_REPROJECT_CONSTRAINTS`].
        max: usize,
    },
    /// Newton did not reduce the residual below the tolerance (the state is left unchanged).
    #[error(
        "re-projection onto {what} = 0 did not converge: residual {residual:e} after {iterations} iterations (the change moved the state too far from the manifold, or the constraints are singular there)"
    )]
    NotConverged {
        /// `"g"` or `"phi"`.
        what: &'static str,
        /// `max |residual|` at the last iterate.
        residual: f64,
        /// Iterations taken.
        iterations: usize,
    },
}

/// Projects `x` onto `g(x) = 0` and, with `hidden`, onto the hidden constraint
/// `φ(x) = G M ∇H = 0`, consistently (so that a projected flow accepts the state):
///
/// 1. positions: Gauss–Newton `x ← x − Gᵀ (G Gᵀ)⁻¹ g(x)`, the nearest point of the manifold
///    in the Euclidean norm (for a mechanical model `G` has no momentum columns, so only the
///    positions move);
/// 2. hidden constraint: `x ← x + M Gᵀ ν` with `φ(x + M Gᵀ ν) = 0` by Newton (for a mechanical
///    model with `M` canonical, `M Gᵀ` moves only the momenta: the velocity's normal
///    component is removed, as after an inelastic impact, Hairer, Lubich & Wanner, GNI
///    §VII.1).
///
/// On error the state is unchanged. Allocates (dense `m × m` solves): for events and resets,
/// not for every step.
///
/// # Errors
/// [`ReprojectError`].
pub fn reproject<V, Sys>(
    system: &Sys,
    x: &mut V,
    tol: V::Real,
    hidden: bool,
) -> Result<Reprojection, ReprojectError>
where
    V: Vector,
    V::Real: nalgebra::RealField,
    Sys: Model<V>,
{
    let zero = <V::Real as num_traits::Zero>::zero();
    let one = <V::Real as num_traits::One>::one();
    let c = system.constraint();
    let m = c.dim();
    if m > MAX_REPROJECT_CONSTRAINTS {
        return Err(ReprojectError::TooManyConstraints {
            m,
            max: MAX_REPROJECT_CONSTRAINTS,
        });
    }
    let start = x.clone();
    let (mut t1, mut t2) = (x.zeros_like(), x.zeros_like());
    let mut r = vec![zero; m];
    let norm = |r: &[V::Real]| r.iter().fold(0.0f64, |s, v| s.max(v.to_f64_lossy().abs()));
    c.residual(x, &mut r);
    let g_before = norm(&r);
    let mut report = Reprojection {
        moved: 0.0,
        g_before,
        g_after: g_before,
        phi_before: 0.0,
        phi_after: 0.0,
        iterations: (0, 0),
    };
    // 1. Positions.
    let mut e = vec![zero; m];
    let mut columns = vec![x.zeros_like(); m];
    let max_iter = 30;
    while norm(&r) > tol.to_f64_lossy() {
        if report.iterations.0 == max_iter {
            x.copy_from(&start);
            return Err(ReprojectError::NotConverged {
                what: "g",
                residual: norm(&r),
                iterations: max_iter,
            });
        }
        // A = G Gᵀ from the columns Gᵀ e_j.
        for (j, col) in columns.iter_mut().enumerate() {
            e.iter_mut().for_each(|v| *v = zero);
            e[j] = one;
            c.jacobian_transpose_apply(x, &e, col);
        }
        let a = gram(c, x, &columns, &mut e);
        let Some(mu) = a.lu().solve(&nalgebra::DVector::from_column_slice(&r)) else {
            x.copy_from(&start);
            return Err(ReprojectError::NotConverged {
                what: "g",
                residual: norm(&r),
                iterations: report.iterations.0,
            });
        };
        for (col, &mj) in columns.iter().zip(mu.iter()) {
            crate::vector::ops::axpy(x.as_mut_slice(), -mj, col.as_slice());
        }
        c.residual(x, &mut r);
        report.iterations.0 += 1;
    }
    report.g_after = norm(&r);
    // 2. The hidden constraint, along M Gᵀ (columns d_j = M Gᵀ e_j at the projected x).
    if hidden {
        system.hidden_constraint(x, &mut t1, &mut t2, &mut r);
        report.phi_before = norm(&r);
        let mut d = vec![x.zeros_like(); m];
        for (j, dj) in d.iter_mut().enumerate() {
            e.iter_mut().for_each(|v| *v = zero);
            e[j] = one;
            system.constraint_force(x, &e, &mut t1, dj);
        }
        let mut y = x.clone();
        let mut rp = vec![zero; m];
        while norm(&r) > tol.to_f64_lossy() {
            if report.iterations.1 == max_iter {
                x.copy_from(&start);
                return Err(ReprojectError::NotConverged {
                    what: "phi",
                    residual: norm(&r),
                    iterations: max_iter,
                });
            }
            // J_ij = ∂φ_i/∂ν_j by central differences along d_j (exact for a φ linear in ν).
            let scale = ops_norm(x).max(1.0);
            let delta = V::Real::lit(1e-6 * scale);
            let mut jac = DMatrix::<V::Real>::zeros(m, m);
            for (j, dj) in d.iter().enumerate() {
                y.copy_from(x);
                crate::vector::ops::axpy(y.as_mut_slice(), delta, dj.as_slice());
                system.hidden_constraint(&y, &mut t1, &mut t2, &mut rp);
                y.copy_from(x);
                crate::vector::ops::axpy(y.as_mut_slice(), -delta, dj.as_slice());
                system.hidden_constraint(&y, &mut t1, &mut t2, &mut e);
                for i in 0..m {
                    jac[(i, j)] = (rp[i] - e[i]) / (delta + delta);
                }
            }
            let Some(nu) = jac.lu().solve(&nalgebra::DVector::from_column_slice(&r)) else {
                x.copy_from(&start);
                return Err(ReprojectError::NotConverged {
                    what: "phi",
                    residual: norm(&r),
                    iterations: report.iterations.1,
                });
            };
            for (dj, &nj) in d.iter().zip(nu.iter()) {
                crate::vector::ops::axpy(x.as_mut_slice(), -nj, dj.as_slice());
            }
            system.hidden_constraint(x, &mut t1, &mut t2, &mut r);
            report.iterations.1 += 1;
        }
        report.phi_after = norm(&r);
        c.residual(x, &mut r);
        report.g_after = norm(&r);
    }
    report.moved = x
        .as_slice()
        .iter()
        .zip(start.as_slice())
        .fold(0.0f64, |s, (a, b)| s.max((*a - *b).to_f64_lossy().abs()));
    Ok(report)
}

/// `max |x|`.
fn ops_norm<V: Vector>(x: &V) -> f64 {
    x.as_slice()
        .iter()
        .fold(0.0f64, |s, v| s.max(v.to_f64_lossy().abs()))
}

/// `G Gᵀ` from the columns `Gᵀ e_j` (`out`: scratch of `m` entries).
fn gram<V: Vector, C: HolonomicConstraint<V>>(
    c: &C,
    x: &V,
    columns: &[V],
    out: &mut [V::Real],
) -> DMatrix<V::Real>
where
    V::Real: nalgebra::RealField,
{
    let m = columns.len();
    let mut a = DMatrix::<V::Real>::zeros(m, m);
    for (j, col) in columns.iter().enumerate() {
        c.jacobian_apply(x, col, out);
        for i in 0..m {
            a[(i, j)] = out[i];
        }
    }
    a
}
