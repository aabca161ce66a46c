use super::{NonlinearProblem, NonlinearSolver};
use crate::error::{LinearSolveError, NewtonError};
use crate::linalg::LinearSolver;
use crate::real::Real;
use crate::vector::{Vector, ops};
use num_traits::{Float as _, One, Zero};

/// When Newton rebuilds its (finite-difference) Jacobian.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[non_exhaustive]
pub enum JacobianUpdate {
    /// Every iteration: full Newton, quadratic convergence, `k + 1` residual evaluations per
    /// iteration.
    EveryIteration,
    /// Once per solve, at the starting guess: simplified Newton.
    OncePerSolve,
    /// Kept across solves and rebuilt only when an iteration contracts the residual by less
    /// than [`NewtonOptions::max_contraction`] (or diverges): simplified Newton with the
    /// Jacobian of an earlier step, the standard choice for implicit integrators (Hairer &
    /// Wanner, *Solving ODEs II*, §IV.8). In a time-stepping loop the Jacobian changes by
    /// `O(h)` per step, so most solves need no Jacobian at all. A Jacobian the problem provides
    /// in closed form ([`NonlinearProblem::jacobian_column`]) costs no residual evaluations and
    /// is rebuilt at the start of every solve instead.
    #[default]
    Reuse,
}

/// Options of [`Newton`].
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub struct NewtonOptions<T> {
    /// Converged when `‖F(z)‖∞ ≤ ftol`. Default `2 ε` (4.4e-16 for `f64`).
    pub ftol: T,
    /// Also converged when `‖F‖∞ ≤ 100 ftol` (the round-off floor of a residual can lie above
    /// `ftol`) and, right after a freshly built Jacobian, either the update is at round-off,
    /// `‖Δz‖∞ ≤ xtol (1 + ‖z‖∞)`, or the residual stopped decreasing (by at least half).
    /// Default `16 ε`.
    pub xtol: T,
    /// Iteration limit. Default 25.
    pub max_iterations: usize,
    /// Relative forward-difference step for the Jacobian,
    /// `δ_j = fd_step · max(|z_j|, ‖z‖∞, 1/|s|)` with `s` the problem's
    /// [`jacobian_scale`](super::NonlinearProblem::jacobian_scale). Default `√ε`.
    pub fd_step: T,
    /// When to rebuild the Jacobian.
    pub jacobian: JacobianUpdate,
    /// With [`JacobianUpdate::Reuse`]: rebuild when `‖F(z_{i+1})‖ > max_contraction ‖F(z_i)‖`.
    /// Default `0.1`.
    pub max_contraction: T,
    /// Between rebuilds, improve the kept Jacobian with Broyden's secant update after every
    /// iteration (superlinear instead of linear convergence, no extra residual evaluations).
    /// Default `true`; ignored with [`JacobianUpdate::EveryIteration`].
    pub broyden: bool,
}

impl<T: Real> Default for NewtonOptions<T> {
    fn default() -> Self {
        Self {
            ftol: T::lit(2.0) * T::epsilon(),
            xtol: T::lit(16.0) * T::epsilon(),
            max_iterations: 25,
            fd_step: T::epsilon().sqrt(),
            jacobian: JacobianUpdate::default(),
            max_contraction: T::lit(0.1),
            broyden: true,
        }
    }
}

impl<T: Real> NewtonOptions<T> {
    /// Sets the residual tolerance.
    pub fn with_ftol(mut self, ftol: T) -> Self {
        self.ftol = ftol;
        self
    }
    /// Sets the update tolerance.
    pub fn with_xtol(mut self, xtol: T) -> Self {
        self.xtol = xtol;
        self
    }
    /// Sets the iteration limit.
    pub fn with_max_iterations(mut self, n: usize) -> Self {
        self.max_iterations = n;
        self
    }
    /// Sets the relative finite-difference step of the Jacobian.
    pub fn with_fd_step(mut self, fd_step: T) -> Self {
        self.fd_step = fd_step;
        self
    }
    /// Sets the Jacobian update policy.
    pub fn with_jacobian(mut self, j: JacobianUpdate) -> Self {
        self.jacobian = j;
        self
    }
}

/// What one Newton solve did.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SolveReport<T> {
    /// Newton updates applied.
    pub iterations: usize,
    /// Residual evaluations (including those for the finite-difference Jacobian).
    pub residual_evaluations: usize,
    /// Jacobian factorizations.
    pub factorizations: usize,
    /// `‖F(z)‖∞` at the returned `z`.
    pub residual: T,
}

/// Newton's method with a forward-difference Jacobian, for small dense systems.
///
/// Each Jacobian costs `k` extra residual evaluations (`k` = number of unknowns); the linear
/// solver `L` is reused, and the workspace (vectors of storage `V`) is allocated once, in
/// [`Newton::new`]: a solve allocates nothing. Reference: Deuflhard, *Newton Methods for
/// Nonlinear Problems*, Springer 2004, ch. 2.
#[derive(Debug)]
pub struct Newton<V: Vector, L = <V as Vector>::Solver> {
    k: usize,
    lin: L,
    options: NewtonOptions<V::Real>,
    f: V,
    fp: V,
    zp: V,
    dz: V,
    have_jacobian: bool,
    /// The problem's [`jacobian_scale`](NonlinearProblem::jacobian_scale) when the kept
    /// Jacobian was built.
    jacobian_scale: V::Real,
    /// The Jacobian when `k = 1` (kept here instead of in the linear solver).
    j11: V::Real,
    /// The last Jacobian came in closed form from the problem: rebuilding it costs no residual
    /// evaluations, so [`JacobianUpdate::Reuse`] rebuilds it at the start of every solve.
    analytic: bool,
}

impl<V: Vector, L: LinearSolver<V::Real>> Newton<V, L> {
    /// Newton for `k` unknowns. Allocates the workspace and the linear solver.
    pub fn new(k: usize, options: NewtonOptions<V::Real>) -> Result<Self, crate::LinearSolveError> {
        Ok(Self {
            k,
            lin: L::with_dim(k)?,
            options,
            f: V::zeros(k),
            fp: V::zeros(k),
            zp: V::zeros(k),
            dz: V::zeros(k),
            have_jacobian: false,
            jacobian_scale: V::Real::one(),
            j11: V::Real::zero(),
            analytic: false,
        })
    }

    /// The options.
    pub fn options(&self) -> &NewtonOptions<V::Real> {
        &self.options
    }

    /// The number of unknowns.
    pub fn dim(&self) -> usize {
        self.k
    }

    /// Forgets a kept Jacobian (the next solve builds a new one).
    pub fn invalidate_jacobian(&mut self) {
        self.have_jacobian = false;
    }

    /// Broyden's rank-one secant update `J += F(z_new) Δzᵀ / (Δzᵀ Δz)` (the "good" update,
    /// simplified because `J Δz = −F(z_old)`), then refactors. Broyden, Math. Comp. 19 (1965).
    /// `ratio = s₀/s` converts the update to the scale the Jacobian is kept at.
    fn broyden_update(&mut self, ratio: V::Real) -> Result<(), NewtonError> {
        let k = self.k;
        if k == 1 {
            // The secant slope: J += ratio f / Δz.
            let j = self.j11 + ratio * self.f.as_slice()[0] / self.dz.as_slice()[0];
            if j.is_finite() && j != V::Real::zero() {
                self.j11 = j;
            } else {
                self.have_jacobian = false;
            }
            return Ok(());
        }
        let dz = &self.dz.as_slice()[..k];
        let denom = dz.iter().fold(V::Real::zero(), |s, &d| s + d * d);
        if denom.is_nan() || denom <= V::Real::zero() {
            return Ok(());
        }
        let f = &self.f.as_slice()[..k];
        for (j, &dzj) in dz.iter().enumerate() {
            let c = ratio * dzj / denom;
            for (a, &fi) in self.lin.column_mut(j).iter_mut().zip(f) {
                *a = *a + fi * c;
            }
        }
        if self.lin.factor().is_err() {
            // The secant matrix went singular: rebuild by differences next iteration.
            self.have_jacobian = false;
        }
        Ok(())
    }

    /// Forward differences `J e_j ≈ (F(z + δ_j e_j) − F(z)) / δ_j` with
    /// `δ_j = fd_step · max(|z_j|, ‖z‖∞, 1/|s|)`, `s` the problem's Jacobian scale: when `F`
    /// depends on `z` through `s z` (a multiplier times `h` or `h²`), the perturbation of `s z`
    /// stays at `fd_step` relative, so the difference is accurate for every step size.
    fn jacobian<P: NonlinearProblem<V::Real>>(
        &mut self,
        problem: &mut P,
        z: &[V::Real],
        scale: V::Real,
        report: &mut SolveReport<V::Real>,
    ) -> Result<(), NewtonError> {
        let k = self.k;
        let one = V::Real::one();
        let inv = one / scale.abs();
        let floor = if inv.is_finite() { inv } else { one };
        let zmax = ops::norm_inf(z).max(floor);
        let f = &self.f.as_slice()[..k];
        // A closed-form Jacobian when the problem has one, column by column.
        let analytic = if k == 1 {
            let mut c = [V::Real::zero()];
            let ok = problem.jacobian_column(z, 0, &mut c);
            self.j11 = c[0];
            ok
        } else {
            problem.jacobian_column(z, 0, self.lin.column_mut(0))
                && (1..k).all(|j| problem.jacobian_column(z, j, self.lin.column_mut(j)))
        };
        self.analytic = analytic;
        for j in (0..k).filter(|_| !analytic) {
            let zp = &mut self.zp.as_mut_slice()[..k];
            zp.copy_from_slice(z);
            let delta = self.options.fd_step * z[j].abs().max(zmax);
            zp[j] = z[j] + delta;
            // The step actually taken, exactly representable.
            let delta = zp[j] - z[j];
            problem
                .residual(zp, &mut self.fp.as_mut_slice()[..k])
                .map_err(|e| NewtonError::Residual(Box::new(e)))?;
            report.residual_evaluations += 1;
            if k == 1 {
                self.j11 = (self.fp.as_slice()[0] - f[0]) / delta;
                continue;
            }
            let col = self.lin.column_mut(j);
            for ((c, &a), &b) in col.iter_mut().zip(&self.fp.as_slice()[..k]).zip(f) {
                *c = (a - b) / delta;
            }
        }
        report.factorizations += 1;
        if k == 1 {
            let j = self.j11;
            if !j.is_finite() {
                return Err(LinearSolveError::NonFinite { row: 0, col: 0 }.into());
            }
            if j == V::Real::zero() {
                return Err(LinearSolveError::Singular {
                    pivot: 0,
                    magnitude: 0.0,
                    ratio: 0.0,
                }
                .into());
            }
            return Ok(());
        }
        self.lin.factor()?;
        Ok(())
    }
}

/// Residuals below `NOISE_FACTOR · ftol` are treated as possibly at their round-off floor.
const NOISE_FACTOR: f64 = 100.0;

/// The residual as the convergence test sees it: the rows the problem's noise floor applies to
/// count as zero while within `4 · noise_floor`; the other rows count as they are.
fn effective_residual<T: Real, P: NonlinearProblem<T>>(problem: &P, f: &[T]) -> T {
    let (noisy, exact) = f.split_at(problem.noisy_rows().min(f.len()));
    let r_noisy = ops::norm_inf(noisy);
    let r_exact = ops::norm_inf(exact);
    let r_noisy = if r_noisy <= T::lit(4.0) * problem.noise_floor() {
        T::zero()
    } else {
        r_noisy
    };
    r_noisy.max(r_exact)
}

impl<V: Vector, L: LinearSolver<V::Real>> NonlinearSolver<V::Real> for Newton<V, L> {
    fn solve<P: NonlinearProblem<V::Real>>(
        &mut self,
        problem: &mut P,
        z: &mut [V::Real],
    ) -> Result<SolveReport<V::Real>, NewtonError> {
        let k = self.k;
        debug_assert_eq!(problem.dim(), k, "problem and solver dimensions differ");
        let z = &mut z[..k];
        let mut report = SolveReport::default();
        let eval = |p: &mut P, z: &[V::Real], f: &mut V, r: &mut SolveReport<V::Real>| {
            p.residual(z, &mut f.as_mut_slice()[..k])
                .map_err(|e| NewtonError::Residual(Box::new(e)))?;
            r.residual_evaluations += 1;
            Ok::<_, NewtonError>(ops::norm_inf(&f.as_slice()[..k]))
        };
        let mut r = eval(problem, z, &mut self.f, &mut report)?;
        if !r.is_finite() {
            return Err(NewtonError::NonFinite { iteration: 0 });
        }
        let opts = self.options;
        let one = V::Real::one();
        let scale = problem.jacobian_scale();
        // The kept Jacobian J₀ was built at scale s₀; here J ≈ (s/s₀) J₀, so steps are J₀⁻¹
        // steps times s₀/s.
        let mut ratio = self.jacobian_scale / scale;
        if !(ratio.is_finite() && ratio != V::Real::zero()) {
            self.have_jacobian = false;
        }
        for it in 0..opts.max_iterations {
            report.residual = r;
            if effective_residual(problem, &self.f.as_slice()[..k]) <= opts.ftol {
                return Ok(report);
            }
            let fresh = !self.have_jacobian
                || match opts.jacobian {
                    JacobianUpdate::EveryIteration => true,
                    JacobianUpdate::OncePerSolve => it == 0,
                    JacobianUpdate::Reuse => it == 0 && self.analytic,
                };
            if fresh {
                self.have_jacobian = false;
                self.jacobian(problem, z, scale, &mut report)?;
                self.have_jacobian = true;
                self.jacobian_scale = scale;
                ratio = one;
            }
            let dz = &mut self.dz.as_mut_slice()[..k];
            for (d, &fi) in dz.iter_mut().zip(&self.f.as_slice()[..k]) {
                *d = -fi;
            }
            if k == 1 {
                // One unknown: the linear solver's machinery costs more than the division.
                dz[0] = dz[0] / self.j11;
            } else {
                self.lin.solve_in_place(dz)?;
            }
            if ratio != one {
                dz.iter_mut().for_each(|d| *d = *d * ratio);
            }
            ops::axpy(z, one, dz);
            report.iterations += 1;
            let step = ops::norm_inf(dz);
            let r_new = eval(problem, z, &mut self.f, &mut report)?;
            if !r_new.is_finite() && fresh {
                return Err(NewtonError::NonFinite { iteration: it + 1 });
            }
            report.residual = r_new;
            let r_eff = effective_residual(problem, &self.f.as_slice()[..k]);
            if r_eff <= opts.ftol {
                return Ok(report);
            }
            // Below `noise` the residual is dominated by its own round-off: an update at
            // round-off, or a step with a fresh Jacobian that no longer decreases it, means the
            // root is reached. With a kept Jacobian, slow progress is not evidence of that.
            let noise = V::Real::lit(NOISE_FACTOR) * opts.ftol;
            if r_eff <= noise
                && fresh
                && (step <= opts.xtol * (one + ops::norm_inf(z)) || r_new >= V::Real::lit(0.5) * r)
            {
                return Ok(report);
            }
            if !fresh && (r_new.is_nan() || r_new >= r) {
                // A kept Jacobian made things worse (or non-finite): go back, rebuild it there.
                ops::axpy(z, -one, &self.dz.as_slice()[..k]);
                r = eval(problem, z, &mut self.f, &mut report)?;
                self.have_jacobian = false;
                continue;
            }
            if opts.jacobian != JacobianUpdate::EveryIteration && r_new > opts.max_contraction * r {
                self.have_jacobian = false;
            } else if opts.broyden
                && opts.jacobian != JacobianUpdate::EveryIteration
                && r_new > noise
            {
                // A secant through round-off noise would corrupt the kept Jacobian.
                self.broyden_update(ratio)?;
            }
            r = r_new;
        }
        Err(NewtonError::NotConverged {
            iterations: report.iterations,
            residual: r.to_f64_lossy(),
        })
    }
}
