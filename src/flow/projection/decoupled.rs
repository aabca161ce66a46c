//! The decoupled and coupled steps of a projection: `λ_k` from `g(x_{k+1}) = 0`, then
//! `λ_{k+1}` from `φ(x_{k+1}) = 0` (RATTLE for any structure matrix), on the small stack path
//! or through Newton, and the guard that checks the decoupling still holds.

use super::small::{Columns, FirstHalf};
use super::small::{SecondHalf, fixed_mut, solve_second_half};
use super::stage::{Mode, Stage};
use super::{Base, Projected, STAGE_LAMBDA_K, STAGE_LAMBDA_K1, Work};
use crate::error::{NewtonError, StepError};
use crate::flow::{Flow, FlowStats};
use crate::linalg::LinearSolver;
use crate::nonlinear::{NonlinearSolver, SolveReport};
use crate::real::Real;
use crate::system::HolonomicConstraint;
use crate::system::Model;
use crate::vector::{Vector, ops};
use num_traits::Float as _;
use num_traits::Zero;

impl<V, F, Sys, L> Projected<V, F, Sys, L>
where
    V: Vector,
    F: Flow<V>,
    Sys: Model<V>,
    L: LinearSolver<V::Real>,
{
    /// Solves one multiplier system. Newton evaluates the residual last at the iterate it
    /// returns, so afterwards `y` and `x_{k+1}` in the workspace belong to the solution.
    pub(super) fn solve(
        &mut self,
        mode: Mode,
        h: V::Real,
        base: Base<'_, V>,
        stage: &'static str,
    ) -> Result<(), StepError> {
        let m = self.m;
        let range = match mode {
            Mode::LambdaK | Mode::Symmetric => 0..m,
            Mode::LambdaK1 => m..2 * m,
            Mode::Coupled => 0..2 * m,
        };
        let Work {
            y,
            g_y,
            x_next,
            t1,
            t2,
            z,
            a_cached,
            y_valid,
            hess_v,
            m_hess_v,
            indicator,
            prev,
            ledger_in,
            ledger_y,
            ..
        } = &mut self.w;
        let x = base.resolve(prev);
        if let Some(gram) = self.gram.as_mut() {
            if mode == Mode::LambdaK {
                gram.forget_x();
            }
            // The base or `y` may have moved since the last fill (a fused stage swaps them).
            gram.forget_y();
        }
        let mut problem = Stage {
            mode,
            h,
            m,
            x,
            inner: &mut self.inner,
            ledger_in: *ledger_in,
            ledger_y,
            system: &self.system,
            y,
            x_next,
            t1,
            t2,
            a_cached,
            y_valid,
            hess_v,
            m_hess_v,
            indicator,
            g_y,
            fixed_point_max_iterations: self.fixed_point_max_iterations,
            fixed_point_tol: self.fixed_point_tol,
            tangent: false,
            inverse_mass: self.inverse_mass.as_deref(),
            gram: self.gram.as_mut(),
        };
        let z = &mut z.as_mut_slice()[range];
        let active = self.diagonal_active;
        let diagonal = self.diagonal.as_mut().filter(|_| active);
        let result = match (mode, diagonal, self.newton_k1.as_mut()) {
            // Mechanical form: affine, one division, `x_{k+1}` formed at the solution.
            (Mode::LambdaK1, Some(d), _) if problem.inverse_mass.is_some() => {
                let result = d.solve_affine(&mut problem, z);
                if result.is_ok() {
                    problem.end_point_explicit(z);
                }
                result
            }
            (Mode::LambdaK | Mode::LambdaK1, Some(d), _) => {
                // The quadratic model's root is exact from any start: from zero, the first
                // evaluation needs no constraint force.
                if mode == Mode::LambdaK && self.quadratic_k {
                    ops::fill_zero(z);
                }
                let result = d.solve(&mut problem, z);
                if mode == Mode::LambdaK {
                    self.quadratic_k = matches!(&result, Ok(r) if r.quadratic_steps > 0);
                }
                // Without closed-form diagonals the kept, secant-updated Jacobians of `newton`
                // and `newton_k1` cost less: from the next solve on.
                if d.needs_differences() {
                    self.diagonal_active = false;
                }
                result
            }
            // Mechanical form with the Jacobian summed in closed form: affine, one solve,
            // `x_{k+1}` formed at the solution.
            (Mode::LambdaK1, None, Some(n)) if problem.affine_k1() => {
                let result = n.solve_affine(&mut problem, z);
                if result.is_ok() {
                    problem.end_point_explicit(z);
                }
                result
            }
            (Mode::LambdaK1, None, Some(n)) => n.solve(&mut problem, z),
            _ => self.newton.solve(&mut problem, z),
        };
        Self::finish_solve(&mut self.stats, result, stage)
    }

    /// Counts a successful multiplier solve in `stats`; turns a failed one into the step's error.
    #[inline(always)]
    pub(super) fn finish_solve(
        stats: &mut FlowStats,
        result: Result<SolveReport<V::Real>, NewtonError<StepError>>,
        stage: &'static str,
    ) -> Result<(), StepError> {
        match result {
            Ok(report) => {
                stats.record(&report);
                Ok(())
            }
            Err(e) => Err(StepError::from_newton(stage, e)),
        }
    }

    /// Solves one decoupled multiplier system on the small path (`K = m` multipliers). As
    /// with [`Self::solve`], `y` (for `λ_k`) or `x_{k+1}` (for `λ_{k+1}`) in the workspace
    /// belong to the solution.
    #[inline(always)]
    pub(super) fn solve_small<const K: usize>(
        &mut self,
        second: bool,
        h: V::Real,
        base: Base<'_, V>,
        tally: &mut FlowStats,
    ) -> Result<(), StepError> {
        let Some(small) = self.small.as_mut() else {
            unreachable!("solve_small without a small path");
        };
        let w = &mut self.w;
        let x = base.resolve(&w.prev);
        let half = h * V::Real::lit(0.5);
        // Directions and Jacobian columns: local arrays for stack states (kept in registers
        // across the solve), the preallocated workspace otherwise.
        let (mut d_local, mut w_local, mut t_local): ([V; K], [V; K], [V; 2]);
        let (d, cols, t): (&mut [V; K], &mut [V; K], [&mut V; 2]) = if V::CLONE_IS_COPY {
            d_local = core::array::from_fn(|_| x.clone());
            w_local = core::array::from_fn(|_| x.clone());
            t_local = core::array::from_fn(|_| x.clone());
            let [t1, t2] = &mut t_local;
            (&mut d_local, &mut w_local, [t1, t2])
        } else {
            (
                fixed_mut(&mut small.d),
                fixed_mut(&mut small.w),
                [&mut w.t1, &mut w.t2],
            )
        };
        let [t1, t2] = t;
        // The directions of this half-step, fixed for the whole solve: `(h/2) M Gᵀ e_j` at
        // `x` for the first half-step, at `y` for the second, so that Newton forms
        // `x + Σ λ_j d_j` without scaling `λ` first (one multiplication less on the latency
        // chain of every evaluation).
        let base = if second { &w.y } else { x };
        let mut unit = [V::Real::zero(); K];
        for (j, dj) in d.iter_mut().enumerate() {
            unit[j] = half;
            self.system.constraint_force(base, &unit, t1, dj);
            unit[j] = V::Real::zero();
        }
        let d: &[V; K] = d;
        let (result, stage) = if second {
            let mut problem = SecondHalf {
                h,
                y: &w.y,
                system: &self.system,
                d,
                x_next: &mut w.x_next,
                t1: &mut w.t1,
                t2: &mut w.t2,
            };
            let z: &mut [V::Real; K] = fixed_mut(&mut w.z.as_mut_slice()[K..]);
            let result = solve_second_half(&small.newton_k1, small.affine_k1, &mut problem, z);
            (result, STAGE_LAMBDA_K1)
        } else {
            // The columns' directions `w_j = d_j + h M ∇²H d_j` are formed by the problem
            // only if the inner flow has no tangent map.
            let mut problem = FirstHalf {
                h,
                x,
                inner: &mut self.inner,
                ledger_in: w.ledger_in,
                ledger_y: &mut w.ledger_y,
                system: &self.system,
                d,
                w: cols,
                w_state: Columns::Unformed,
                y: &mut w.y,
                g: fixed_mut(&mut small.g_y),
                scratch: t1,
                scratch2: t2,
                quadratic: small.quadratic,
            };
            let z: &mut [V::Real; K] = fixed_mut(w.z.as_mut_slice());
            let result = small.newton_k.solve_fixed(&mut problem, z);
            if let Ok(report) = &result {
                small.quadratic = report.quadratic_steps > 0 || report.iterations >= 2;
            }
            (result, STAGE_LAMBDA_K)
        };
        Self::finish_solve(tally, result, stage)
    }

    /// The `λ_k` system from `base`: on the small path for `K = m`, the general one for `K = 0`.
    /// The small path counts its work in `tally` (a local of the step, kept in registers), the
    /// general one in the flow's statistics.
    ///
    /// Inlined into its one call site, the stage loop of `step_fused`.
    #[inline(always)]
    pub(super) fn solve_lambda_k<const K: usize>(
        &mut self,
        h: V::Real,
        base: Base<'_, V>,
        tally: &mut FlowStats,
    ) -> Result<(), StepError> {
        if K == 0 {
            self.solve(Mode::LambdaK, h, base, STAGE_LAMBDA_K)?;
        } else {
            self.solve_small::<K>(false, h, base, tally)?;
        }
        // The system was solved on the inner flow's lead; its tail (a trailing kick, which
        // leaves g as it is) completes y once. The decoupling guard checks that it did.
        let w = &mut self.w;
        w.y_valid = false;
        self.inner.step_tail(&mut w.ledger_y, h, &mut w.y)
    }

    /// The `λ_{k+1}` system from `y`: on the small path for `K = m`, the general one for `K = 0`
    /// (`tally` as for [`Self::solve_lambda_k`]). Not inlined: one function per flow and
    /// multiplier count (inlining it at its one call site measured no faster).
    #[inline(never)]
    pub(super) fn solve_lambda_k1<const K: usize>(
        &mut self,
        h: V::Real,
        x: &V,
        tally: &mut FlowStats,
    ) -> Result<(), StepError> {
        if K == 0 {
            self.solve(Mode::LambdaK1, h, Base::Given(x), STAGE_LAMBDA_K1)
        } else {
            self.solve_small::<K>(true, h, Base::Given(x), tally)
        }
    }

    /// The decoupling assumption: the second half-step did not move `g` (for position
    /// constraints and a momentum-only direction, `g(x_{k+1})` and `g(y)` are the same
    /// floating-point numbers).
    #[inline(always)]
    pub(super) fn decoupling_guard<const K: usize>(&mut self, m: usize) -> Result<(), StepError> {
        let w = &mut self.w;
        // A model of mechanical form whose second half-step moved momenta only (as it does
        // through the gram's values): its constraint reads positions alone (the gram's
        // pattern lists no momentum), so `g(x_{k+1}) = g(y)` exactly.
        if let (Some(mass), Some(_)) = (self.inverse_mass.as_ref(), self.gram.as_ref()) {
            let nq = mass.len();
            if w.x_next.as_slice()[..nq] == w.y.as_slice()[..nq] {
                return Ok(());
            }
        }
        let gx = &mut w.r.as_mut_slice()[..m];
        self.system.constraint().residual(&w.x_next, gx);
        // g(y) is the λ_k system's last residual.
        let change = match self.small.as_ref() {
            Some(small) if K > 0 => ops::dist_inf(gx, &small.g_y[..m]),
            _ => ops::dist_inf(gx, &w.g_y.as_slice()[..m]),
        };
        if change.is_nan() || change > self.guard_tol {
            return Err(StepError::CouplingViolated {
                residual: change.to_f64_lossy(),
            });
        }
        Ok(())
    }
}
