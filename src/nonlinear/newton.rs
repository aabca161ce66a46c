use super::stopping::{NOISE_FACTOR, converged_after_update, effective_residual};
use super::{JacobianUpdate, NewtonOptions, SolveReport};
use super::{NonlinearProblem, NonlinearSolver};
use crate::error::{LinearSolveError, NewtonError};
use crate::linalg::{ColumnGroups, LinearSolver, Structure};
use crate::real::Real;
use crate::vector::{Vector, ops};
use num_traits::{Float as _, One, Zero};

mod affine;
mod broyden;

/// Newton's method with a closed-form, forward-difference or colored-difference Jacobian.
///
/// - Closed form when the problem has it ([`NonlinearProblem::jacobian_column`]).
/// - With a sparsity pattern ([`Newton::with_pattern`]): the columns are grouped so that no two
///   columns of a group share a row, and each group costs one residual evaluation (Curtis,
///   Powell & Reid, IMA J. Appl. Math. 13, 1974) — 3 for a tridiagonal Jacobian, whatever `k`.
///   The values go to the linear solver through its [`Sink`](crate::linalg::Sink), in the same
///   order every time, so a sparse solver keeps its symbolic analysis.
/// - Otherwise forward differences, `k` residual evaluations.
///
/// The linear solver `L` is reused, and the workspace (vectors of storage `V`) is allocated
/// once, at construction: a solve allocates nothing. Reference: Deuflhard, *Newton Methods for
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
    /// evaluations, so [`JacobianUpdate::Reuse`] rebuilds it at every iteration.
    analytic: bool,
    /// The last Jacobian was summed by the problem ([`NonlinearProblem::jacobian_assemble`]):
    /// [`JacobianUpdate::Reuse`] rebuilds it at the start of a solve unless the last solve
    /// converged in one update with it.
    summed: bool,
    /// The last solve converged after at most one update: a kept summed Jacobian is still
    /// good enough to start the next one with.
    one_update: bool,
    /// [`solve_affine`](Self::solve_affine)'s kept-Jacobian attempts: solves to skip before the
    /// next (`kept_wait`) and the wait after the next failure (`kept_backoff`, doubling to
    /// [`affine::KEPT_BACKOFF_MAX`]). A system whose matrix turns with the state (a spinning body's
    /// `G W⁻¹ Gᵀ`) fails them, and each failure costs an update and a residual.
    kept_wait: u8,
    kept_backoff: u8,
    /// The last solve that started from a kept summed Jacobian converged in two updates or
    /// fewer (see [`NonlinearSolver::solve`]).
    kept_converges: bool,
    /// Column groups for a sparse Jacobian.
    groups: Option<ColumnGroups>,
    /// Per row, the last group whose pattern covers it (scratch for the pattern check).
    mark: Vec<usize>,
    /// The row scales of the kept, equilibrated Jacobian (empty when not equilibrated).
    row_scale: Vec<V::Real>,
    /// The kept Jacobian's diagonal when the pattern is diagonal (independent unknowns; empty
    /// otherwise): its secant update is one division per unknown.
    diagonal: Vec<V::Real>,
}

impl<V: Vector, L: LinearSolver<V::Real>> Newton<V, L> {
    /// Newton for `k` unknowns with a Jacobian taken as dense. Allocates the workspace and the
    /// linear solver.
    pub fn new(k: usize, options: NewtonOptions<V::Real>) -> Result<Self, crate::LinearSolveError> {
        Self::with_pattern(k, options, None)
    }

    /// Newton for `k` unknowns whose Jacobian is non-zero only at the positions of `pattern`
    /// (`(row, col)`, duplicates allowed). The Jacobian is then built by grouped differences
    /// (see the type docs) and stored in the sparsity the linear solver chooses
    /// ([`NewtonOptions::solver`]). A pattern that misses a non-zero makes the Jacobian inexact
    /// and Newton slower, never its answer wrong: convergence is tested on the residual.
    /// Positions outside `k × k` are an [`OutOfBounds`](crate::LinearSolveError::OutOfBounds)
    /// error.
    pub fn with_pattern(
        k: usize,
        options: NewtonOptions<V::Real>,
        pattern: Option<&[(usize, usize)]>,
    ) -> Result<Self, crate::LinearSolveError> {
        if let Some(&(row, col)) = pattern.and_then(|p| p.iter().find(|&&(r, c)| r >= k || c >= k))
        {
            return Err(crate::LinearSolveError::OutOfBounds { row, col, dim: k });
        }
        let groups = pattern.map(|p| ColumnGroups::new(k, p));
        // The solver from the pattern itself, which it may renumber into a band.
        let lin = match pattern {
            Some(p) => L::with_pattern(k, p, options.solver)?,
            None => L::with_structure(k, Structure::Dense, options.solver)?,
        };
        Ok(Self {
            k,
            lin,
            mark: if groups.is_some() {
                vec![usize::MAX; k]
            } else {
                Vec::new()
            },
            groups,
            options,
            f: V::zeros(k),
            fp: V::zeros(k),
            zp: V::zeros(k),
            dz: V::zeros(k),
            have_jacobian: false,
            jacobian_scale: V::Real::one(),
            j11: V::Real::zero(),
            analytic: false,
            summed: false,
            one_update: false,
            kept_wait: 0,
            kept_backoff: 0,
            kept_converges: true,
            row_scale: Vec::with_capacity(if options.equilibrate { k } else { 0 }),
            diagonal: match pattern {
                Some(p) if k > 1 && p.iter().all(|&(r, c)| r == c) => vec![V::Real::zero(); k],
                _ => Vec::new(),
            },
        })
    }

    /// The linear solver (for instance to see which backend [`crate::linalg::AutoLu`] chose).
    pub fn linear_solver(&self) -> &L {
        &self.lin
    }

    /// The number of column evaluations one Jacobian costs: the number of column groups with
    /// a pattern, `k` without. Each is one residual evaluation by forward differences, two by
    /// central differences, none when the problem answers it in closed form.
    pub fn evaluations_per_jacobian(&self) -> usize {
        self.groups.as_ref().map_or(self.k, ColumnGroups::groups)
    }

    /// The options.
    pub fn options(&self) -> &NewtonOptions<V::Real> {
        &self.options
    }

    /// The number of unknowns.
    pub fn dim(&self) -> usize {
        self.k
    }

    /// `rhs ← J⁻¹ rhs` with the kept, factored Jacobian `J` of the last solve (at the scale of
    /// that solve), and `true`; `false` when no Jacobian is kept (before the first solve, after
    /// a failure) or it is stored sparse. Lets a flow apply its tangent map, which for an
    /// implicit method is a function of its Newton matrix.
    pub fn apply_kept_inverse(&mut self, rhs: &mut [V::Real]) -> bool {
        if !self.have_jacobian || self.groups.is_some() {
            return false;
        }
        let k = self.k;
        if k == 1 {
            rhs[0] = rhs[0] / self.j11;
            return rhs[0].is_finite();
        }
        self.scale_rows(&mut rhs[..k]);
        self.lin.solve_in_place(&mut rhs[..k]).is_ok()
    }

    /// `rhs ← D rhs` with the kept Jacobian's row scales `D` (nothing when not equilibrated).
    fn scale_rows(&self, rhs: &mut [V::Real]) {
        for (r, &s) in rhs.iter_mut().zip(&self.row_scale) {
            *r = *r * s;
        }
    }

    /// Scales the rows of the dense Jacobian in `lin` to a largest entry in `[½, 1)` or so, by
    /// powers of two, and records the scales (see [`NewtonOptions::equilibrate`]).
    fn equilibrate(&mut self) {
        self.row_scale.clear();
        let k = self.k;
        if !self.options.equilibrate || k < 2 || self.lin.column_mut(0).is_none() {
            return;
        }
        self.row_scale.resize(k, V::Real::zero());
        for j in 0..k {
            if let Some(col) = self.lin.column_mut(j) {
                for (m, a) in self.row_scale.iter_mut().zip(col.iter()) {
                    *m = (*m).max(a.abs());
                }
            }
        }
        let two = V::Real::lit(2.0);
        for s in &mut self.row_scale {
            *s = if *s > V::Real::zero() && s.is_finite() {
                // 2^(−round(log₂ max)): exact, and within a factor √2 of 1/max.
                two.powi(-(s.to_f64_lossy().log2().round() as i32))
            } else {
                V::Real::one()
            };
        }
        for j in 0..k {
            if let Some(col) = self.lin.column_mut(j) {
                for (a, &s) in col.iter_mut().zip(&self.row_scale) {
                    *a = *a * s;
                }
            }
        }
    }

    /// Forgets a kept Jacobian (the next solve builds a new one).
    pub fn invalidate_jacobian(&mut self) {
        self.have_jacobian = false;
        self.kept_wait = 0;
        self.kept_backoff = 0;
        self.kept_converges = true;
    }

    /// Writes column `j` (`col`, `k` entries) into the linear solver: directly into dense
    /// storage, through the sink otherwise (all `k` entries, so the pattern never changes).
    fn store_column(lin: &mut L, j: usize, col: &[V::Real]) {
        match lin.column_mut(j) {
            Some(c) => c.copy_from_slice(col),
            None => {
                for (i, &v) in col.iter().enumerate() {
                    lin.add(i, j, v);
                }
            }
        }
    }

    /// `z ← z + dz`, `dz = −ratio · J⁻¹ F(z)` with the kept, factored Jacobian (`self.f =
    /// F(z)`); the update stays in `dz`.
    fn newton_step<E>(&mut self, z: &mut [V::Real], ratio: V::Real) -> Result<(), NewtonError<E>> {
        let k = self.k;
        let dz = &mut self.dz.as_mut_slice()[..k];
        for (d, &fi) in dz.iter_mut().zip(&self.f.as_slice()[..k]) {
            *d = -fi;
        }
        if k == 1 {
            // One unknown: the linear solver's machinery costs more than the division.
            dz[0] = dz[0] / self.j11;
        } else {
            for (d, &s) in dz.iter_mut().zip(&self.row_scale) {
                *d = *d * s;
            }
            self.lin.solve_in_place(dz)?;
        }
        if ratio != V::Real::one() {
            dz.iter_mut().for_each(|d| *d = *d * ratio);
        }
        ops::axpy(z, V::Real::one(), dz);
        Ok(())
    }

    /// The Jacobian at `z` (where `self.f = F(z)`), factored.
    ///
    /// Forward differences `J e_j ≈ (F(z + δ_j e_j) − F(z)) / δ_j` with
    /// `δ_j = fd_step · max(|z_j|, ‖z‖∞, 1/|s|)`, `s` the problem's Jacobian scale: when `F`
    /// depends on `z` through `s z` (a multiplier times `h` or `h²`), the perturbation of `s z`
    /// stays at `fd_step` relative, so the difference is accurate for every step size. With
    /// column groups, all columns of a group are perturbed at once.
    fn jacobian<P: NonlinearProblem<V::Real>>(
        &mut self,
        problem: &mut P,
        z: &[V::Real],
        scale: V::Real,
        report: &mut SolveReport<V::Real>,
    ) -> Result<(), NewtonError<P::Error>> {
        let k = self.k;
        self.row_scale.clear();
        let one = V::Real::one();
        let inv = one / scale.abs();
        let floor = if inv.is_finite() { inv } else { one };
        let zmax = ops::norm_inf(z).max(floor);
        let fd_step = self.options.fd_step;
        let delta_of = |zj: V::Real| fd_step * zj.abs().max(zmax);
        let residual = |p: &mut P, zp: &[V::Real], fp: &mut [V::Real]| {
            p.residual(zp, fp).map_err(NewtonError::Residual)
        };
        self.summed = false;
        if let (Some(groups), true) = (self.groups.as_ref(), k > 1) {
            self.analytic = false;
            self.lin.clear();
            self.diagonal.iter_mut().for_each(|d| *d = V::Real::zero());
            // Summed in closed form by the problem: every entry at once (a diagonal pattern
            // keeps its diagonal for the secant update, which the sum does not report).
            if self.diagonal.is_empty() && problem.jacobian_assemble(z, &mut self.lin) {
                self.summed = true;
                report.factorizations += 1;
                self.lin.factor()?;
                return Ok(());
            }
            let central = self.options.central_differences;
            for c in 0..groups.groups() {
                let cols = &groups.cols[groups.col_ptr[c]..groups.col_ptr[c + 1]];
                if problem.jacobian_group(z, cols, &mut self.fp.as_mut_slice()[..k]) {
                    let fp = &self.fp.as_slice()[..k];
                    let entries = &groups.entries[groups.entry_ptr[c]..groups.entry_ptr[c + 1]];
                    let mut max = V::Real::zero();
                    for &(i, j) in entries {
                        self.lin.add(i, j, fp[i]);
                        if let Some(d) = self.diagonal.get_mut(i) {
                            *d = *d + fp[i];
                        }
                        self.mark[i] = c;
                        max = max.max(fp[i].abs());
                    }
                    // A closed-form product is exactly zero outside the rows the group covers
                    // (up to rounding); anything else would be added to a wrong entry.
                    let tol = V::Real::lit(64.0) * V::Real::epsilon() * max;
                    if let Some(row) = (0..k).find(|&i| self.mark[i] != c && fp[i].abs() > tol) {
                        return Err(LinearSolveError::PatternIncomplete {
                            row,
                            column: cols.first().copied().unwrap_or(0),
                        }
                        .into());
                    }
                    continue;
                }
                let zp = &mut self.zp.as_mut_slice()[..k];
                zp.copy_from_slice(z);
                for &j in cols {
                    zp[j] = z[j] + delta_of(z[j]);
                }
                residual(problem, zp, &mut self.fp.as_mut_slice()[..k])?;
                report.residual_evaluations += 1;
                if central {
                    // F(z − δ) into `dz`, free until the update is computed.
                    for &j in cols {
                        zp[j] = z[j] - delta_of(z[j]);
                    }
                    residual(problem, zp, &mut self.dz.as_mut_slice()[..k])?;
                    report.residual_evaluations += 1;
                }
                let (fp, f) = (self.fp.as_slice(), self.f.as_slice());
                let fm = self.dz.as_slice();
                for &(i, j) in &groups.entries[groups.entry_ptr[c]..groups.entry_ptr[c + 1]] {
                    // The steps actually taken, exactly representable.
                    let d = delta_of(z[j]);
                    let v = if central {
                        (fp[i] - fm[i]) / ((z[j] + d) - (z[j] - d))
                    } else {
                        (fp[i] - f[i]) / ((z[j] + d) - z[j])
                    };
                    self.lin.add(i, j, v);
                    if let Some(d) = self.diagonal.get_mut(i) {
                        *d = *d + v;
                    }
                }
            }
            report.factorizations += 1;
            self.lin.factor()?;
            return Ok(());
        }
        let dense = k == 1 || self.lin.column_mut(0).is_some();
        if !dense {
            self.lin.clear();
        }
        // A closed-form Jacobian when the problem has one, column by column.
        let mut analytic = true;
        for j in 0..k {
            let col = &mut self.fp.as_mut_slice()[..k];
            if !problem.jacobian_column(z, j, col) {
                analytic = false;
                break;
            }
            if k == 1 {
                self.j11 = col[0];
            } else {
                Self::store_column(&mut self.lin, j, col);
            }
        }
        if !analytic && !dense {
            // Columns already added through the sink must not be added twice.
            self.lin.clear();
        }
        self.analytic = analytic;
        for j in (0..k).filter(|_| !analytic) {
            let zp = &mut self.zp.as_mut_slice()[..k];
            zp.copy_from_slice(z);
            zp[j] = z[j] + delta_of(z[j]);
            // The step actually taken, exactly representable.
            let delta = zp[j] - z[j];
            let fp = &mut self.fp.as_mut_slice()[..k];
            residual(problem, zp, fp)?;
            report.residual_evaluations += 1;
            for (c, &b) in fp.iter_mut().zip(&self.f.as_slice()[..k]) {
                *c = (*c - b) / delta;
            }
            if k == 1 {
                self.j11 = fp[0];
            } else {
                Self::store_column(&mut self.lin, j, fp);
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
        self.equilibrate();
        self.lin.factor()?;
        Ok(())
    }
}

impl<V: Vector, L: LinearSolver<V::Real>> NonlinearSolver<V::Real> for Newton<V, L> {
    fn solve<P: NonlinearProblem<V::Real>>(
        &mut self,
        problem: &mut P,
        z: &mut [V::Real],
    ) -> Result<SolveReport<V::Real>, NewtonError<P::Error>> {
        let started_kept = self.have_jacobian && self.summed && self.one_update;
        let result = self.iterate(problem, z);
        // A summed Jacobian is also kept after two updates while a kept one last converged in
        // two without a rebuild: that costs less than rebuilding it (a free body's rows),
        // unless the kept one then needs more or is rebuilt anyway (a fast top's).
        if started_kept && let Ok(r) = &result {
            self.kept_converges = r.factorizations == 0 && r.iterations <= 2;
        }
        let updates = if self.summed && self.kept_converges {
            2
        } else {
            1
        };
        self.one_update = matches!(&result, Ok(r) if r.iterations <= updates);
        result
    }
}

impl<V: Vector, L: LinearSolver<V::Real>> Newton<V, L> {
    /// Newton's iteration from `z` (see [`NonlinearSolver::solve`]).
    fn iterate<P: NonlinearProblem<V::Real>>(
        &mut self,
        problem: &mut P,
        z: &mut [V::Real],
    ) -> Result<SolveReport<V::Real>, NewtonError<P::Error>> {
        let k = self.k;
        debug_assert_eq!(problem.dim(), k, "problem and solver dimensions differ");
        let z = &mut z[..k];
        let mut report = SolveReport::default();
        // Each evaluation gives the plain ‖F‖∞ (`report.residual`, the finiteness test) and the
        // effective residual, which does not count rows within the problem's noise floor and on
        // which every decision is made (convergence, damping, stalls, contraction): a step that
        // brings the exact rows down while the noisy ones move within their noise is progress,
        // not growth to be halved away.
        let eval = |p: &mut P, z: &[V::Real], f: &mut V, r: &mut SolveReport<V::Real>| {
            let f = &mut f.as_mut_slice()[..k];
            p.residual(z, f).map_err(NewtonError::Residual)?;
            r.residual_evaluations += 1;
            Ok::<_, NewtonError<P::Error>>((ops::norm_inf(f), effective_residual(p, f)))
        };
        let (mut raw, mut r) = eval(problem, z, &mut self.f, &mut report)?;
        if !raw.is_finite() {
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
            report.residual = raw;
            if r <= opts.ftol {
                return Ok(report);
            }
            let fresh = !self.have_jacobian
                || match opts.jacobian {
                    JacobianUpdate::EveryIteration => true,
                    JacobianUpdate::OncePerSolve => it == 0,
                    // A summed Jacobian costs one pass: fresh at a solve's start unless the
                    // last solve needed a single update, kept through the solve's iterations.
                    JacobianUpdate::Reuse => {
                        self.analytic || (self.summed && it == 0 && !self.one_update)
                    }
                };
            if fresh {
                self.have_jacobian = false;
                self.jacobian(problem, z, scale, &mut report)?;
                self.have_jacobian = true;
                self.jacobian_scale = scale;
                ratio = one;
            }
            self.newton_step(z, ratio)?;
            report.iterations += 1;
            let mut r_new;
            (raw, r_new) = eval(problem, z, &mut self.f, &mut report)?;
            let noise = V::Real::lit(NOISE_FACTOR) * opts.ftol;
            // Damping: with a fresh Jacobian the direction is a descent direction of ‖F‖, so a
            // short enough step decreases the residual; halve until it does.
            let mut halvings = 0;
            if fresh && r > noise {
                let half = V::Real::lit(0.5);
                while (r_new.is_nan() || r_new >= r) && halvings < opts.max_halvings {
                    let dz = &mut self.dz.as_mut_slice()[..k];
                    dz.iter_mut().for_each(|d| *d = *d * half);
                    ops::axpy(z, -one, dz);
                    halvings += 1;
                    report.halvings += 1;
                    (raw, r_new) = eval(problem, z, &mut self.f, &mut report)?;
                }
            }
            let dz = &self.dz.as_slice()[..k];
            if !raw.is_finite() && fresh {
                return Err(NewtonError::NonFinite { iteration: it + 1 });
            }
            report.residual = raw;
            if r_new <= opts.ftol {
                return Ok(report);
            }
            if converged_after_update(&opts, r, r_new, halvings, fresh, dz, z) {
                return Ok(report);
            }
            if !fresh && (r_new.is_nan() || r_new >= r) {
                // A kept Jacobian made things worse (or non-finite): go back, rebuild it there.
                ops::axpy(z, -one, &self.dz.as_slice()[..k]);
                (raw, r) = eval(problem, z, &mut self.f, &mut report)?;
                self.have_jacobian = false;
                continue;
            }
            if opts.jacobian != JacobianUpdate::EveryIteration && r_new > opts.max_contraction * r {
                self.have_jacobian = false;
            } else if opts.broyden
                && halvings == 0
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
            residual: raw.to_f64_lossy(),
        })
    }
}
