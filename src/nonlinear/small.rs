//! Full Newton for tiny systems (`k ≤ SMALL_MAX` unknowns) with a Jacobian in closed form.

use super::{NewtonOptions, NonlinearProblem, NonlinearSolver, SolveReport};
use crate::error::{LinearSolveError, NewtonError};
use crate::real::Real;

/// The largest system [`SmallNewton`] solves.
pub const SMALL_MAX: usize = 4;

/// Newton's method for `k ≤` [`SMALL_MAX`] unknowns, on fixed-size stack arrays, with the
/// Jacobian rebuilt at every iterate from the problem's closed-form columns
/// ([`NonlinearProblem::jacobian_column`]; forward differences for a problem that declines).
///
/// This is the loop one writes by hand for a multiplier system of a few unknowns: evaluate
/// `F(z)`, stop when `‖F(z)‖∞ ≤ ftol` (tested *before* any update, so a converged warm start
/// costs one evaluation), otherwise solve `J(z) Δz = −F(z)` by Gaussian elimination with partial
/// pivoting (a division when `k = 1`) and step. With exact columns the convergence is quadratic
/// (Deuflhard, *Newton Methods for Nonlinear Problems*, Springer 2004, §2.1); no Jacobian is
/// kept between solves, so nothing needs rescaling when the step size changes.
///
/// Stopping rules, the same as [`Newton`](super::Newton)'s: `‖F‖∞ ≤ ftol`; or, with
/// `‖F‖∞ ≤ 100 ftol` (the residual's round-off floor may lie above `ftol`), an update at
/// round-off (`‖Δz‖∞ ≤ xtol (1 + ‖z‖∞)`) or a residual that no longer halves. A step that
/// increases `‖F‖∞` above that floor is halved up to
/// [`max_halvings`](NewtonOptions::max_halvings) times (backtracking line search).
///
/// A closed-form Jacobian may be approximate (say, a model-derived guess at an inner flow's
/// tangent map): when an iteration with it contracts `‖F‖∞` by less than half above the
/// round-off floor, the rest of that solve builds the Jacobian by forward differences
/// (`δ = fd_step · max(|z_j|, ‖z‖∞, 1/|s|)`, `s` the problem's Jacobian scale).
///
/// Contract with the problem: `jacobian_column(z, j, …)` is called only right after
/// `residual(z, …)` at the same `z`, so a problem may take the Jacobian at the point its last
/// residual evaluation computed. Newton evaluates the residual last at the iterate it returns.
#[derive(Debug, Clone)]
pub struct SmallNewton<T> {
    k: usize,
    options: NewtonOptions<T>,
}

impl<T: Real> SmallNewton<T> {
    /// Newton for `k` unknowns; `None` when `k` is 0 or above [`SMALL_MAX`].
    pub fn new(k: usize, options: NewtonOptions<T>) -> Option<Self> {
        (1..=SMALL_MAX).contains(&k).then_some(Self { k, options })
    }

    /// The number of unknowns.
    pub fn dim(&self) -> usize {
        self.k
    }

    /// The options.
    pub fn options(&self) -> &NewtonOptions<T> {
        &self.options
    }
}

/// Solves the `K × K` system `a x = b` in place (`b` becomes `x`) by Gaussian elimination with
/// partial pivoting. Singular when a pivot is at most `K ε` times the largest entry of `a`.
#[inline(always)]
#[allow(clippy::needless_range_loop)] // index loops read best for elimination
pub(crate) fn solve_dense<T: Real, const K: usize>(
    a: &mut [[T; K]; K],
    b: &mut [T; K],
) -> Result<(), LinearSolveError> {
    if K == 1 {
        let p = a[0][0];
        if !p.is_finite() {
            return Err(LinearSolveError::NonFinite { row: 0, col: 0 });
        }
        if p == T::zero() {
            return Err(LinearSolveError::Singular {
                pivot: 0,
                magnitude: 0.0,
                ratio: 0.0,
            });
        }
        b[0] = b[0] / p;
        return Ok(());
    }
    let mut max = T::zero();
    for (i, row) in a.iter().enumerate() {
        for (j, &v) in row.iter().enumerate() {
            if !v.is_finite() {
                return Err(LinearSolveError::NonFinite { row: i, col: j });
            }
            max = max.max(v.abs());
        }
    }
    let tol = T::lit(K as f64) * T::epsilon() * max;
    for c in 0..K {
        let mut p = c;
        for i in c + 1..K {
            if a[i][c].abs() > a[p][c].abs() {
                p = i;
            }
        }
        let piv = a[p][c].abs();
        if piv <= tol || max == T::zero() {
            return Err(LinearSolveError::Singular {
                pivot: c,
                magnitude: piv.to_f64_lossy(),
                ratio: if max > T::zero() {
                    (piv / max).to_f64_lossy()
                } else {
                    0.0
                },
            });
        }
        a.swap(c, p);
        b.swap(c, p);
        for i in c + 1..K {
            let l = a[i][c] / a[c][c];
            for j in c + 1..K {
                a[i][j] = a[i][j] - l * a[c][j];
            }
            b[i] = b[i] - l * b[c];
        }
    }
    for c in (0..K).rev() {
        let mut s = b[c];
        for j in c + 1..K {
            s = s - a[c][j] * b[j];
        }
        b[c] = s / a[c][c];
    }
    Ok(())
}

/// The root `δ` of `F + J δ + ½ δᵀ∇²F δ = 0` nearest the Newton step `δ₀ = −J⁻¹F`, by Newton
/// on the model from `δ₀` (each iteration `O(K³)`, no evaluation of the problem), when the
/// problem gives its constant second derivatives ([`NonlinearProblem::second_derivative`]).
/// For a residual that is exactly quadratic in `z` this is its root to rounding: the solve
/// then takes one iteration where Newton takes two (its first step leaves the residual at
/// `½ δ₀ᵀ∇²F δ₀`). `None` when the problem has no second derivatives, or the model's
/// iteration does not settle in a few steps (no real root near `δ₀`), or when the Newton step
/// already leaves less than `ftol/2` (`½ C(δ₀, δ₀)`): the Newton step stands.
#[allow(clippy::needless_range_loop)] // Indices run across the three axes of `c` at once.
fn quadratic_root<T: Real, P: NonlinearProblem<T>, const K: usize>(
    problem: &mut P,
    z: &[T; K],
    jac: &[[T; K]; K],
    f: &[T; K],
    newton: &[T; K],
    ftol: T,
) -> ModelRoot<T, K> {
    // c[j][k][i] = ∂²F_i/∂z_j∂z_k (symmetric in j, k; indices across the three axes).
    let mut c = [[[T::zero(); K]; K]; K];
    for j in 0..K {
        for k in j..K {
            let mut col = [T::zero(); K];
            if !problem.second_derivative(z, j, k, &mut col) {
                return ModelRoot::Newton;
            }
            c[j][k] = col;
            c[k][j] = col;
        }
    }
    let half = T::lit(0.5);
    // The Newton step leaves `½ C(δ₀, δ₀)` (plus rounding): when that is below half the
    // tolerance, the next evaluation converges anyway and the model's iteration (a chain of
    // divisions) is not worth its latency.
    let mut left = T::zero();
    for i in 0..K {
        let mut q = T::zero();
        for j in 0..K {
            for k in 0..K {
                q = q + c[j][k][i] * newton[j] * newton[k];
            }
        }
        left = left.max((half * q).abs());
    }
    if left <= half * ftol {
        return ModelRoot::Newton;
    }
    if K == 1 {
        return scalar_root(f[0], jac[0][0], c[0][0][0], newton[0]);
    }
    let mut delta = *newton;
    let mut last = T::infinity();
    for _ in 0..6 {
        // The model's residual and Jacobian at δ: p = F + Jδ + ½ C(δ, δ), J_p = J + C(δ, ·).
        let mut p = *f;
        let mut jp = *jac;
        for i in 0..K {
            for j in 0..K {
                let mut cd = T::zero();
                for k in 0..K {
                    cd = cd + c[j][k][i] * delta[k];
                }
                jp[i][j] = jp[i][j] + cd;
                p[i] = p[i] + (jac[i][j] + half * cd) * delta[j];
            }
        }
        let mut step = p.map(|v| -v);
        if solve_dense(&mut jp, &mut step).is_err() {
            return ModelRoot::Newton;
        }
        for (d, &s) in delta.iter_mut().zip(&step) {
            *d = *d + s;
        }
        if !delta.iter().all(|d| d.is_finite()) {
            return ModelRoot::Newton;
        }
        last = norm_inf(&step);
        if last <= T::lit(4.0) * T::epsilon() * norm_inf(&delta) {
            return ModelRoot::Root(delta);
        }
    }
    // At the rounding floor of the model's residual the last correction need not fall below
    // 4ε|δ|; a settled iteration is still the root to working precision.
    if last <= T::epsilon().sqrt() * norm_inf(&delta) {
        ModelRoot::Root(delta)
    } else {
        ModelRoot::Newton
    }
}

/// What [`quadratic_root`] found.
#[derive(Debug, Clone, Copy, PartialEq)]
enum ModelRoot<T, const K: usize> {
    /// The model's root nearest the Newton step.
    Root([T; K]),
    /// No second derivatives, a Newton step that leaves less than the tolerance, or a model
    /// iteration that did not settle: the Newton step stands.
    Newton,
    /// One unknown, a residual exactly quadratic in it, and no real root: `F` never vanishes,
    /// wherever Newton would go. Carries the discriminant `J² − 2cF` relative to `J²`.
    Unreachable(T),
}

/// The root of `f + j δ + ½ c δ² = 0` nearest the Newton step `δ₀ = −f/j`, in the form that
/// does not cancel, `δ = −2f / (j + sign(j) √(j² − 2cf))` (it tends to `δ₀` as `c → 0`;
/// Press et al., *Numerical Recipes*, §5.6). A discriminant below `−8ε j²` (not rounding at a
/// double root) proves there is no real root; between that and zero the double root `−j/c`.
#[inline(always)]
fn scalar_root<T: Real, const K: usize>(f: T, j: T, c: T, newton: T) -> ModelRoot<T, K> {
    let two = T::lit(2.0);
    let disc = j * j - two * c * f;
    let root = if disc >= T::zero() {
        -two * f / (j + disc.sqrt().copysign(j))
    } else if disc >= -T::lit(8.0) * T::epsilon() * j * j {
        -j / c
    } else {
        return ModelRoot::Unreachable(disc / (j * j));
    };
    let mut out = [T::zero(); K];
    out[0] = if root.is_finite() { root } else { newton };
    ModelRoot::Root(out)
}

/// `max |v_i|`, NaN-propagating (a NaN entry makes the norm NaN).
#[inline(always)]
fn norm_inf<T: Real, const K: usize>(v: &[T; K]) -> T {
    let mut m = T::zero();
    for &x in v {
        let a = x.abs();
        if a > m || a.is_nan() {
            m = a;
        }
    }
    m
}

#[inline(always)]
fn evaluate<T: Real, P: NonlinearProblem<T>, const K: usize>(
    problem: &mut P,
    z: &[T; K],
    f: &mut [T; K],
    report: &mut SolveReport<T>,
) -> Result<T, NewtonError<P::Error>> {
    problem.residual(z, f).map_err(NewtonError::Residual)?;
    report.residual_evaluations += 1;
    Ok(norm_inf(f))
}

impl<T: Real> SmallNewton<T> {
    /// [`NonlinearSolver::solve`] with the number of unknowns `K` known at compile time, so
    /// that every loop over the unknowns unrolls. `K` must equal [`dim`](Self::dim).
    #[inline(always)]
    pub fn solve_fixed<const K: usize, P: NonlinearProblem<T>>(
        &self,
        problem: &mut P,
        z: &mut [T; K],
    ) -> Result<SolveReport<T>, NewtonError<P::Error>> {
        debug_assert_eq!(problem.dim(), K, "problem and solver dimensions differ");
        debug_assert_eq!(self.k, K, "solver built for another dimension");
        let opts = &self.options;
        let one = T::one();
        let noise = T::lit(super::stopping::NOISE_FACTOR) * opts.ftol;
        let mut report = SolveReport::default();
        let mut f = [T::zero(); K];
        let mut r = evaluate(problem, z, &mut f, &mut report)?;
        if !r.is_finite() {
            return Err(NewtonError::NonFinite { iteration: 0 });
        }
        // The residual before the last update, and that update (none yet: r_prev = ∞).
        let mut r_prev = T::infinity();
        let mut dz_last = [T::zero(); K];
        // Closed-form columns until they fail to contract the residual.
        let mut closed_form = true;
        let half = T::lit(0.5);
        for it in 0..=opts.max_iterations {
            // Converged; or at the round-off floor with a stalled residual or an update at
            // round-off (the norms only on this rare path).
            if r <= opts.ftol
                || (r <= noise
                    && (r >= half * r_prev
                        || (r_prev.is_finite()
                            && norm_inf(&dz_last) <= opts.xtol * (one + norm_inf(z)))))
            {
                report.residual = r;
                return Ok(report);
            }
            if it == opts.max_iterations {
                break;
            }
            // The Jacobian at z, where the residual was just evaluated: closed-form columns;
            // once the problem declines one, the rest by differences (which move the
            // problem's state away from z: evaluated there again after).
            let mut jac = [[T::zero(); K]; K];
            let mut col = [T::zero(); K];
            let mut differenced = !closed_form;
            for j in 0..K {
                if differenced || !problem.jacobian_column(z, j, &mut col) {
                    differenced = true;
                    forward_difference(problem, z, &f, j, opts.fd_step, &mut col, &mut report)?;
                }
                for (row, &c) in jac.iter_mut().zip(&col) {
                    row[j] = c;
                }
            }
            if differenced {
                let mut again = [T::zero(); K];
                evaluate(problem, z, &mut again, &mut report)?;
            }
            report.factorizations += 1;
            let jac0 = jac;
            let mut dz = f.map(|fi| -fi);
            solve_dense(&mut jac, &mut dz)?;
            // A residual quadratic in z (closed-form second derivatives): the root of its
            // exact quadratic model nearest the Newton step instead.
            if !differenced {
                match quadratic_root(problem, z, &jac0, &f, &dz, opts.ftol) {
                    ModelRoot::Root(root) => {
                        dz = root;
                        report.quadratic_steps += 1;
                    }
                    ModelRoot::Newton => {}
                    // No iterate can meet the tolerance: fail now, not after every iteration
                    // and halving Newton allows (an adaptive caller shrinks the step at once).
                    ModelRoot::Unreachable(discriminant) => {
                        return Err(NewtonError::NoRoot {
                            residual: r.to_f64_lossy(),
                            discriminant: discriminant.to_f64_lossy(),
                        });
                    }
                }
            }
            for (zi, &d) in z.iter_mut().zip(&dz) {
                *zi = *zi + d;
            }
            report.iterations += 1;
            // The problem may form the residual at the new iterate from the last one (an
            // affine inner map): no full evaluation. Differences moved its state: evaluate.
            let shifted = !differenced
                && problem
                    .residual_after_shift(z, &dz, &mut f)
                    .map_err(NewtonError::Residual)?;
            let mut r_new = if shifted {
                report.residual_evaluations += 1;
                norm_inf(&f)
            } else {
                evaluate(problem, z, &mut f, &mut report)?
            };
            // The common case contracts by at least half; anything else (slow contraction,
            // growth, NaN) takes this branch.
            if r_new.is_nan() || r_new > half * r {
                // Backtracking: the Newton direction descends ‖F‖, so a short enough step
                // helps.
                if r > noise && (r_new.is_nan() || r_new >= r) {
                    let mut halvings = 0;
                    while (r_new.is_nan() || r_new >= r) && halvings < opts.max_halvings {
                        for (zi, d) in z.iter_mut().zip(dz.iter_mut()) {
                            *d = *d * half;
                            *zi = *zi - *d;
                        }
                        halvings += 1;
                        report.halvings += 1;
                        r_new = evaluate(problem, z, &mut f, &mut report)?;
                    }
                }
                if !r_new.is_finite() {
                    return Err(NewtonError::NonFinite { iteration: it + 1 });
                }
                // A closed-form Jacobian that only approximates the true one (a model-derived
                // guess at an inner flow's tangent map, say) shows itself by slow contraction:
                // finish this solve with differences.
                if closed_form && !differenced && r_new > noise {
                    closed_form = false;
                }
            }
            dz_last = dz;
            r_prev = r;
            r = r_new;
        }
        report.residual = r;
        Err(NewtonError::NotConverged {
            iterations: report.iterations,
            residual: r.to_f64_lossy(),
        })
    }
}

impl<T: Real> SmallNewton<T> {
    /// Solves an *affine* problem `F(z) = F(z₀) + J (z − z₀)` with one evaluation and one
    /// linear solve: `z = z₀ − J⁻¹ F(z₀)` is the root up to rounding, so no evaluation at the
    /// returned `z` follows (unlike [`solve_fixed`](Self::solve_fixed)) — the caller updates
    /// whatever state the problem keeps. Returns `Ok` at once when `‖F(z₀)‖∞ ≤ ftol`. A problem
    /// that declines a closed-form column, or that is not affine after all, is the caller's
    /// responsibility: this falls back to [`solve_fixed`](Self::solve_fixed) only for the
    /// former. `report.residual` is `‖F(z₀)‖∞`.
    #[inline(always)]
    pub fn solve_affine_fixed<const K: usize, P: NonlinearProblem<T>>(
        &self,
        problem: &mut P,
        z: &mut [T; K],
    ) -> Result<SolveReport<T>, NewtonError<P::Error>> {
        let mut report = SolveReport::default();
        let mut f = [T::zero(); K];
        let r = evaluate(problem, z, &mut f, &mut report)?;
        report.residual = r;
        if !r.is_finite() {
            return Err(NewtonError::NonFinite { iteration: 0 });
        }
        if r <= self.options.ftol {
            return Ok(report);
        }
        let mut jac = [[T::zero(); K]; K];
        let mut col = [T::zero(); K];
        for j in 0..K {
            if !problem.jacobian_column(z, j, &mut col) {
                return self.solve_fixed(problem, z);
            }
            for (row, &c) in jac.iter_mut().zip(&col) {
                row[j] = c;
            }
        }
        report.factorizations = 1;
        let mut dz = f.map(|fi| -fi);
        solve_dense(&mut jac, &mut dz)?;
        for (zi, &d) in z.iter_mut().zip(&dz) {
            *zi = *zi + d;
        }
        report.iterations = 1;
        Ok(report)
    }
}

/// `&mut z[..K]` as an array (`z` has at least `K` entries: the caller sliced it to `dim`).
fn fixed<T, const K: usize>(z: &mut [T]) -> &mut [T; K] {
    match <&mut [T; K]>::try_from(&mut z[..K]) {
        Ok(a) => a,
        Err(_) => unreachable!("a slice of length K converts to [T; K]"),
    }
}

impl<T: Real> NonlinearSolver<T> for SmallNewton<T> {
    fn solve<P: NonlinearProblem<T>>(
        &mut self,
        problem: &mut P,
        z: &mut [T],
    ) -> Result<SolveReport<T>, NewtonError<P::Error>> {
        match self.k {
            1 => self.solve_fixed::<1, P>(problem, fixed(z)),
            2 => self.solve_fixed::<2, P>(problem, fixed(z)),
            3 => self.solve_fixed::<3, P>(problem, fixed(z)),
            _ => self.solve_fixed::<4, P>(problem, fixed(z)),
        }
    }
}

/// Column `j` of the Jacobian by a forward difference, `δ = fd_step · max(|z_j|, ‖z‖∞, 1/|s|)`
/// with `s` the problem's Jacobian scale (see [`Newton`](super::Newton)). Leaves the problem's
/// state at `z + δ e_j`.
#[inline]
fn forward_difference<T: Real, P: NonlinearProblem<T>, const K: usize>(
    problem: &mut P,
    z: &mut [T; K],
    f: &[T; K],
    j: usize,
    fd_step: T,
    col: &mut [T; K],
    report: &mut SolveReport<T>,
) -> Result<(), NewtonError<P::Error>> {
    let inv = T::one() / problem.jacobian_scale().abs();
    let floor = if inv.is_finite() { inv } else { T::one() };
    let zj = z[j];
    let delta = fd_step * zj.abs().max(norm_inf(z)).max(floor);
    z[j] = zj + delta;
    let taken = z[j] - zj;
    let res = problem.residual(z, col);
    z[j] = zj;
    res.map_err(NewtonError::Residual)?;
    report.residual_evaluations += 1;
    for (c, &b) in col.iter_mut().zip(f) {
        *c = (*c - b) / taken;
    }
    Ok(())
}
