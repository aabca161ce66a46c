//! The Schur iteration of a reduced implicit step ([`Reduced`](super::reduced::Reduced)):
//! Newton's matrix on `(δq, ν)` with the force Jacobian left out, solved through the
//! multipliers' Schur complement.
//!
//! The reduced systems of the implicit midpoint rule and the constrained discrete gradient have
//! the Newton matrix
//!
//! ```text
//! J = [[A, C], [G, 0]],   A = I − (h/2) W⁻¹B + (h²/4) W⁻¹∇²V(q̄) (+ ½ W⁻¹ Σᵢ νᵢ ∇²gᵢ)
//! ```
//!
//! with `C` the multiplier columns (`W⁻¹ G_qᵀ` at the step's start or midpoint) and `G` the
//! constraint rows at the step's end. Its one expensive block is the force Jacobian `∇²V`: a
//! pair potential makes it dense, and a kept copy of the whole `J` goes stale as `G` turns with
//! the bodies (on ten particles on a sphere at `h = 0.01`, a kept `J` contracts by only 0.07 an
//! iteration: six iterations to round-off). The Schur iteration takes instead
//!
//! ```text
//! Ĵ = [[D, C], [G, 0]],   D = diag(I − (h/2) W⁻¹B)
//! ```
//!
//! built fresh at every step from the constraint alone: `S = G D⁻¹ C` (`m × m`, the pattern of
//! `G Gᵀ`, by grouped products), and an iteration is
//!
//! ```text
//! u = D⁻¹F₁,   S Δν = F₂ − G u,   Δq = −u − D⁻¹C Δν.
//! ```
//!
//! It is a simplified Newton iteration whose contraction is `‖Ĵ⁻¹(J − Ĵ)‖`, of the size of
//! `(h²/4)‖W⁻¹∇²V‖ + (h/2)‖W⁻¹B_off‖` (Ortega & Rheinboldt, *Iterative Solution of Nonlinear
//! Equations*, §10.1): for forces and damping that the step size resolves, it reaches round-off
//! in two or three iterations with no force Jacobian at all; stiff damping on the diagonal of `B`
//! is in `D` and costs nothing. When an iteration contracts by less than
//! [`NewtonOptions::max_contraction`] (stiff springs, strong coupling in `B`), the step goes on
//! with Newton on the full, kept `J` from where the iteration stands, and the Schur iteration
//! pauses for a number of steps that doubles with each consecutive failure.
//!
//! **Relaxation.** The error of the iteration propagates as `e ← T e`, `T = −Ĵ⁻¹(J − Ĵ)`, and
//! each update `Δ` with it. On a taut chain `J − Ĵ` is the constraints' curvature, and `T` is
//! similar to `−P W⁻¹ Σνᵢ∇²gᵢ` on the tangent space (`P` the projection of `Ĵ⁻¹`): a
//! geometric stiffness whose spectrum lies in `[μ, 0]`, `μ < 0` growing with the tension, so
//! the updates alternate and shrink by `|μ|` (0.24 on a hanging chain of 3000 links of 1 g at
//! `h = 10⁻⁴`). The relaxed update `ω Δ` propagates the error by `1 − ω + ω t` for each `t` in
//! the spectrum; for a spectrum in the real interval between `0` and `μ` (of either sign) the
//! factor that minimises the largest of them is `ω = 2/(2 − μ)`, with rate `|μ|/(2 − μ)`
//! (0.24 → 0.11: Hageman & Young, *Applied Iterative Methods*, 1981, ch. 2, the extrapolated
//! basic iterative method with `m = μ`, `M = 0`). `μ` is estimated from the last two unrelaxed
//! position updates, `Δₖ₊₁·Δₖ / Δₖ·Δₖ = 1 − ωₖ + ωₖ μ` (a power iteration on the slowest mode),
//! while the residual is above its noise, and clamped to `−2 ≤ μ ≤ ½`. The negative side
//! reaches as far as the relaxation helps: any real spectrum in `[μ, 0]` contracts at the rate
//! `|μ|/(2 − μ)`, which for `μ = −2` is the curved contraction bound 0.5 (a hanging chain of
//! 10⁴ links of 1 g at `h = 10⁻⁴` has `μ ≈ −0.8`: rate 0.29 where the clamp at `−½` gave 0.44).
//! The positive side over-relaxes (`ω` up to 4/3) and stays short. When the spectrum is
//! complex (the stage coupling of a collocation step) the estimate was measured small
//! (`|μ| ≲ 0.16` on chains), not guaranteed so: an estimate near the clamp on such a mode slows
//! the contraction, and the contraction test below hands the step to Newton as before.
//!
//! **Kept complement.** `S` depends on the step's points only through `G` and `C`, which
//! move by `O(h |q'| ‖∇²g‖)` from one step to the next. After a solve that converged in one
//! update, the next step's iteration runs on the same factored `S` and (for a problem that
//! fills them, [`ReducedBlocks::keep_matrix`]) the same `G` and `C`: a simplified Newton
//! iteration on a matrix kept across steps, as Radau5 keeps its Jacobian while the iteration
//! converges fast (Hairer & Wanner, *Solving ODEs II*, §IV.8). The staleness adds to the
//! contraction; a solve that needs a second update refactors at the next step, and one that
//! stalls on the kept `S` starts again from its predictor on a fresh one before anything is
//! handed to Newton.
//!
//! **Stages.** A collocation-type step with `k` stages (the Petrov–Galerkin scheme) has the
//! same blocks on `k` copies of the positions and multipliers, coupled through a `k × k` stage
//! matrix `Â`: position `d` of stage `i` at `d k + i`, constraint `a` of stage `i` at `a k + i`,
//! and `D` block-diagonal with the blocks `D_d = I_k − h wᵢ bᵢ Â` (`k = 1`, `Â = [½]`: the
//! midpoint rule's `D`). The Schur complement then has `k × k` blocks on the pattern of `G Gᵀ`
//! in this order (banded for a chain), and every product is as above.

use super::contraction::ContractionEstimate;
use super::stage_blocks::{apply_blocks, expand, inv_norm, invert, stages_of};
use crate::error::{NewtonError, StepError};
use crate::linalg::{ColumnGroups, LinearSolver, Sink, SolverChoice, Structure};
use crate::nonlinear::{NewtonOptions, NonlinearProblem, SolveReport, effective_residual};
use crate::real::Real;
use crate::system::HolonomicConstraint;
use crate::vector::{Vector, ops};

/// A reduced step problem whose Newton matrix has the blocks `[[A, C], [G, 0]]` on
/// `(δq, ν)` (`n_q` positions first): the products with `C` and `G` at the `z` of the last
/// [`residual`](NonlinearProblem::residual), which cost no force derivative.
pub(crate) trait ReducedBlocks<T: Real>: NonlinearProblem<T> {
    /// `out += C v`: the multiplier columns applied to `v` (`m` entries; `out` has `n_q`).
    fn multiplier_columns_add(&mut self, v: &[T], out: &mut [T]);
    /// `out = G v`: the constraint rows applied to positions `v` (`n_q` entries; `out` has `m`).
    fn constraint_rows(&mut self, v: &[T], out: &mut [T]);
    /// Adds `S = G D⁻¹ C` to `sink` directly, `D⁻¹` given by its `k × k` blocks `inv_d`
    /// (position after position), and returns `true`; or adds nothing and returns `false`
    /// (the default), and the iteration assembles `S` by grouped products.
    fn schur_complement_add(&mut self, inv_d: &[T], sink: &mut dyn Sink<T>) -> bool {
        let _ = (inv_d, sink);
        false
    }
    /// Whether the products with `C` and `G` keep the matrices of their last fill while the
    /// points move (`true`: the iteration runs on a kept Schur complement, and its matrix stays
    /// one matrix), or fill them again at the next residual's points (`false`). The default
    /// keeps nothing: its products are taken at the current points either way.
    fn keep_matrix(&mut self, keep: bool) {
        let _ = keep;
    }
}

/// `out = G(y) (v, 0)`: the rows of a constraint on positions applied to the positions `v`
/// (`t`: a state-sized scratch), the [`ReducedBlocks::constraint_rows`] of both reduced
/// problems.
pub(crate) fn position_rows<V, C>(
    constraint: &C,
    y: &V,
    v: &[V::Real],
    t: &mut V,
    out: &mut [V::Real],
) where
    V: Vector,
    C: HolonomicConstraint<V>,
{
    let (q, p) = t.as_mut_slice().split_at_mut(v.len());
    q.copy_from_slice(v);
    ops::fill_zero(p);
    constraint.jacobian_apply(y, t, out);
}

/// The largest `μ` taken for the relaxation `ω = 2/(2 − μ)` (`ω ≤ 4/3`): over-relaxation on an
/// estimate beyond it is more likely to amplify a mode it misjudged than to speed up a
/// monotone one.
const MAX_MU: f64 = 0.5;

/// The most negative `μ` taken (`ω ≥ 1/2`): a real spectrum in `[μ, 0]` contracts at
/// `|μ|/(2 − μ)` under its relaxation, which at `μ = −2` is the curved contraction bound 0.5;
/// an alternating mode slower than that hands the step to Newton in any case.
const MIN_MU: f64 = -2.0;

/// The longest pause (in steps) after which the Schur iteration is tried again.
const MAX_PAUSE: usize = 1024;

/// How much the first update of a solve may grow the residual before the iteration gives up
/// (it must then contract by `max_contraction` from the second update on).
const FIRST_GROWTH: f64 = 1e3;

/// The Schur iteration's matrices and workspace (allocated at construction).
pub(crate) struct SchurIteration<T: Real, L> {
    /// `k n_q`: the position unknowns of all stages.
    nq: usize,
    /// `k`.
    k: usize,
    /// `Â`, `k × k` row-major.
    stage: Vec<T>,
    /// `diag W⁻¹`.
    w: Vec<T>,
    /// `diag B`.
    b: Vec<T>,
    /// The step size of `inv_d` (`0`: none).
    h: T,
    /// `D_d⁻¹` (`k × k` row-major) for each position `d`; empty when some `D_d` is not safely
    /// invertible at this `h`.
    inv_d: Vec<T>,
    /// `k` entries of scratch for the blocks, and `2k²` for their inverses.
    block: Vec<T>,
    square: Vec<T>,
    /// `S`, factored.
    lin: L,
    groups: ColumnGroups,
    options: NewtonOptions<T>,
    f: Vec<T>,
    dz: Vec<T>,
    /// `z` where the solve began.
    start: Vec<T>,
    u: Vec<T>,
    unit: Vec<T>,
    col: Vec<T>,
    /// Steps left before the next try, and the pause the next failure sets.
    pause: usize,
    backoff: usize,
    /// The last unrelaxed position update `Δq`.
    last: Vec<T>,
    /// The contraction of the first update, for solves that may stop on its prediction.
    contraction: ContractionEstimate<T>,
    /// Whether the next solve runs on the factored `S` of an earlier one (which converged in
    /// one update).
    kept: bool,
}

/// How a run of the iteration ended.
enum Outcome {
    /// Newton's tests passed after this many updates.
    Converged(usize),
    /// It contracted too slowly or could not run; `true`: the solve should start again from
    /// where it began (its first update grew the residual for nothing).
    Stalled(bool),
}

impl<T: Real, L: LinearSolver<T>> SchurIteration<T, L> {
    /// For `n_q` positions with `diag W⁻¹ = w`, the entries of `B`, and `m` constraints whose
    /// rows touch the positions `g_pattern` (`(constraint, position)`; `None`: all), with the
    /// `k × k` stage matrix `stage` (`[½]` for the midpoint rule). With `m = 0` there is no `S`
    /// and each update is `Δq = −D⁻¹F₁`.
    pub(crate) fn new(
        w: &[T],
        momentum_block: &[(usize, usize, T)],
        m: usize,
        g_pattern: Option<&[(usize, usize)]>,
        options: NewtonOptions<T>,
        stage: &[T],
    ) -> Result<Self, crate::LinearSolveError> {
        let nq = w.len();
        let k = stages_of(stage);
        let mut b = vec![T::zero(); nq];
        for &(r, c, v) in momentum_block {
            if r == c && r < nq {
                b[r] = b[r] + v;
            }
        }
        // S = G D⁻¹ C couples two constraints that share a position.
        let pattern: Vec<(usize, usize)> = match g_pattern {
            Some(p) => {
                let mut of_position: Vec<Vec<usize>> = vec![Vec::new(); nq];
                for &(r, c) in p {
                    if c < nq && r < m {
                        of_position[c].push(r);
                    }
                }
                let mut pairs: Vec<(usize, usize)> = (0..m).map(|r| (r, r)).collect();
                for rows in &of_position {
                    pairs.extend(rows.iter().flat_map(|&a| rows.iter().map(move |&b| (a, b))));
                }
                pairs.sort_unstable();
                pairs.dedup();
                pairs
            }
            None => (0..m).flat_map(|r| (0..m).map(move |c| (r, c))).collect(),
        };
        let pattern = expand(&pattern, k);
        let (nq, m) = (k * nq, k * m);
        let structure = Structure::of_pattern(&pattern);
        Ok(Self {
            nq,
            k,
            stage: stage.to_vec(),
            w: w.to_vec(),
            b,
            h: T::zero(),
            inv_d: Vec::with_capacity(nq * k),
            block: vec![T::zero(); k],
            square: vec![T::zero(); 2 * k * k],
            lin: L::with_structure(m, structure, SolverChoice::Auto)?,
            groups: ColumnGroups::new(m, &pattern),
            options,
            f: vec![T::zero(); nq + m],
            dz: vec![T::zero(); nq + m],
            start: vec![T::zero(); nq + m],
            u: vec![T::zero(); nq],
            unit: vec![T::zero(); m],
            col: vec![T::zero(); m],
            pause: 0,
            backoff: 1,
            last: vec![T::zero(); nq],
            contraction: ContractionEstimate::new(),
            kept: false,
        })
    }

    /// Forgets the step size and the pauses: the next [`begin`](Self::begin) starts afresh
    /// (a restored checkpoint continues as the run that saved it).
    pub(crate) fn forget(&mut self) {
        self.h = T::zero();
        self.kept = false;
        self.contraction.forget();
    }

    /// Lets a solve stop after its first update on the contraction measured by an earlier one
    /// ([`ContractionEstimate`]): for a problem whose caller needs nothing from the residual at
    /// the solution.
    pub(crate) fn trust_contraction(&mut self) {
        self.contraction.enable();
    }

    /// Forgets the measured contraction (a step that does not continue the last one starts
    /// from a poorer predictor).
    pub(crate) fn forget_contraction(&mut self) {
        self.kept = false;
        self.contraction.forget();
    }

    /// Starts a step of size `h`: `D` for a new size (and the pauses forgotten).
    pub(crate) fn begin(&mut self, h: T) {
        if self.h == h {
            return;
        }
        self.h = h;
        self.pause = 0;
        self.backoff = 1;
        self.kept = false;
        self.contraction.forget();
        self.inv_d.clear();
        let k = self.k;
        let (a, inv) = self.square.split_at_mut(k * k);
        for (&w, &b) in self.w.iter().zip(&self.b) {
            // D_d = I − h w b Â.
            let c = h * w * b;
            for (e, &s) in a.iter_mut().zip(&self.stage) {
                *e = -(c * s);
            }
            for i in 0..k {
                a[i * k + i] = a[i * k + i] + T::one();
            }
            // A block that is nearly singular (energy supplied at the rate 2/h, for the
            // midpoint rule) would amplify every update: no Schur iteration at this size.
            if !invert(a, inv, k) || inv_norm(inv, k) > T::lit(8.0) {
                self.inv_d.clear();
                return;
            }
            self.inv_d.extend_from_slice(inv);
        }
    }

    /// Whether this step tries the Schur iteration (counts the pause down).
    pub(crate) fn ready(&mut self) -> bool {
        if self.inv_d.is_empty() {
            return false;
        }
        if self.pause > 0 {
            self.pause -= 1;
            return false;
        }
        true
    }

    /// Records a failure: the next `backoff` steps go to Newton, and the next pause is twice
    /// as long.
    fn pause(&mut self) {
        self.kept = false;
        self.contraction.forget();
        self.pause = self.backoff;
        self.backoff = (2 * self.backoff).min(MAX_PAUSE);
    }

    /// Iterates on `problem` from `z`. `Ok(true)`: converged by Newton's tests; `Ok(false)`: the
    /// iteration contracted too slowly (or could not run), `z` left at its best iterate for
    /// Newton to go on from. Counts into `report`. After a solve that converged in one update,
    /// the next one runs on the same factored `S` (module docs, *Kept complement*), and starts
    /// again on a fresh one if that stalls.
    pub(crate) fn solve<P>(
        &mut self,
        problem: &mut P,
        z: &mut [T],
        report: &mut SolveReport<T>,
    ) -> Result<bool, NewtonError<StepError>>
    where
        P: ReducedBlocks<T, Error = StepError>,
    {
        let reuse = self.kept;
        self.kept = false;
        problem.keep_matrix(reuse);
        let mut outcome = self.iterate(problem, z, report, !reuse)?;
        if reuse && matches!(outcome, Outcome::Stalled(_)) {
            // The kept complement went stale: once more from where the solve began, with `S`
            // and the products at the points of its first residual.
            z.copy_from_slice(&self.start);
            problem.keep_matrix(false);
            outcome = self.iterate(problem, z, report, true)?;
        }
        match outcome {
            Outcome::Converged(updates) => {
                self.kept = updates <= 1;
                Ok(true)
            }
            Outcome::Stalled(restart) => {
                self.hand_over(z, restart);
                Ok(false)
            }
        }
    }

    /// One run of the iteration from `z`, on a newly factored `S` when `fresh` (else on the
    /// kept one).
    fn iterate<P>(
        &mut self,
        problem: &mut P,
        z: &mut [T],
        report: &mut SolveReport<T>,
        fresh: bool,
    ) -> Result<Outcome, NewtonError<StepError>>
    where
        P: ReducedBlocks<T, Error = StepError>,
    {
        let nq = self.nq;
        let opts = self.options;
        let one = T::one();
        problem
            .residual(z, &mut self.f)
            .map_err(NewtonError::Residual)?;
        report.residual_evaluations += 1;
        let mut raw = ops::norm_inf(&self.f);
        if !raw.is_finite() {
            return Err(NewtonError::NonFinite { iteration: 0 });
        }
        let mut r = effective_residual(problem, &self.f);
        report.residual = raw;
        if r <= opts.ftol {
            return Ok(Outcome::Converged(0));
        }
        if fresh {
            if !self.factor_schur(problem) {
                return Ok(Outcome::Stalled(false));
            }
            report.factorizations += 1;
        }
        let noise = T::lit(crate::nonlinear::NOISE_FACTOR) * opts.ftol;
        // Whether an iteration of this solve has contracted by `max_contraction`, and whether
        // the first one was let grow the residual (then `start` holds where it began).
        let mut contracted = false;
        let mut grew = false;
        self.start.copy_from_slice(z);
        let r_start = r;
        // The relaxation factor ω and |Δq|² of the last unrelaxed update (`last`).
        let mut omega = one;
        let mut last_n2 = T::zero();
        for iteration in 0..opts.max_iterations {
            // u = D⁻¹F₁;  S Δν = F₂ − G u;  Δq = −u − D⁻¹C Δν.
            self.u.copy_from_slice(&self.f[..nq]);
            apply_blocks(self.k, &self.inv_d, &mut self.block, &mut self.u);
            let f2 = &self.f[nq..];
            let (dq, dnu) = self.dz.split_at_mut(nq);
            problem.constraint_rows(&self.u, dnu);
            for (d, &f) in dnu.iter_mut().zip(f2) {
                *d = f - *d;
            }
            if !dnu.is_empty() && self.lin.solve_in_place(dnu).is_err() {
                return Ok(Outcome::Stalled(false));
            }
            ops::fill_zero(dq);
            problem.multiplier_columns_add(dnu, dq);
            apply_blocks(self.k, &self.inv_d, &mut self.block, &mut self.dz[..nq]);
            for (d, &u) in self.dz[..nq].iter_mut().zip(&self.u) {
                *d = -(u + *d);
            }
            // Relaxed by the iteration's own spectrum, estimated from the last two updates
            // while the residual is above its noise (module docs).
            let d = &self.dz[..nq];
            let n2 = ops::dot(d, d);
            if iteration > 0 && last_n2 > T::zero() && r > noise {
                let ratio = ops::dot(d, &self.last) / last_n2;
                let mu = (one + (ratio - one) / omega)
                    .max(T::lit(MIN_MU))
                    .min(T::lit(MAX_MU));
                omega = T::lit(2.0) / (T::lit(2.0) - mu);
            }
            self.last.copy_from_slice(d);
            last_n2 = n2;
            if omega != one {
                self.dz.iter_mut().for_each(|v| *v = *v * omega);
            }
            ops::axpy(z, one, &self.dz);
            report.iterations += 1;
            if iteration == 0
                && let Some(predicted) =
                    self.contraction
                        .accepts(raw, ops::norm_inf(&self.dz), ops::norm_inf(z), &opts)
            {
                report.residual = predicted;
                return Ok(Outcome::Converged(1));
            }
            let raw_before = raw;
            let evaluated = problem.residual(z, &mut self.f);
            report.residual_evaluations += 1;
            let r_new = match evaluated {
                Ok(()) => {
                    raw = ops::norm_inf(&self.f);
                    effective_residual(problem, &self.f)
                }
                Err(_) => T::nan(),
            };
            let finite = raw.is_finite();
            if iteration == 0 {
                // A failed evaluation (`r_new` NaN) leaves `raw` at the start's.
                let after = if finite && !r_new.is_nan() {
                    raw
                } else {
                    T::nan()
                };
                self.contraction.measured(raw_before, after);
            }
            if finite && contracted && r_new <= noise && r_new >= T::lit(0.5) * r {
                // An iteration that contracted by `max_contraction` a step ago and now does not
                // halve a residual below the noise level has met the residual's round-off floor
                // (a long chain's: its rows sum tensions that grow with its length), as with a
                // fresh Newton matrix: no representable iterate does better.
                report.residual = raw;
                return Ok(Outcome::Converged(iteration + 1));
            }
            // The first update is not judged by the residual: a predictor that satisfies some
            // rows exactly (the explicit Euler start of a Petrov–Galerkin step without past
            // steps satisfies the momentum rows, not the constraint rows) can see them grow on
            // the way to a root the iteration then converges to. The next one must contract.
            let lenient = iteration == 0 && finite && r_new <= T::lit(FIRST_GROWTH) * r;
            let improved = finite && r_new < r;
            if !(improved || lenient) {
                // Worse: back to the last iterate, whose residual Newton evaluates again. Not
                // finite: subtracting the update may not give the last iterate back (an
                // overflowed entry stays infinite), so Newton starts where the solve began.
                ops::axpy(z, -one, &self.dz);
                return Ok(Outcome::Stalled(!finite || (grew && r > r_start)));
            }
            report.residual = raw;
            if r_new <= opts.ftol {
                return Ok(Outcome::Converged(iteration + 1));
            }
            let step = ops::norm_inf(&self.dz);
            if improved && r_new <= noise && step <= opts.xtol * (one + ops::norm_inf(z)) {
                // The update is at the round-off of z and the residual within its noise: as
                // for Newton with a kept matrix, no representable z does better.
                return Ok(Outcome::Converged(iteration + 1));
            }
            if r_new > opts.max_contraction * r {
                if !lenient {
                    return Ok(Outcome::Stalled(grew && r_new > r_start));
                }
                grew = r_new > r;
            } else {
                contracted = true;
            }
            r = r_new;
        }
        Ok(Outcome::Stalled(grew && r > r_start))
    }

    /// Hands the solve over to Newton: from where it began when `restart` (the first update
    /// grew the residual and the iteration did not bring it below the start's), and pauses.
    fn hand_over(&mut self, z: &mut [T], restart: bool) {
        if restart {
            z.copy_from_slice(&self.start);
        }
        self.pause();
    }

    /// `S = G D⁻¹ C` at the last residual's `z`, by groups of columns that share no row, and
    /// its factorization; `false` when it is singular.
    fn factor_schur<P: ReducedBlocks<T>>(&mut self, problem: &mut P) -> bool {
        if self.unit.is_empty() {
            // No constraints: `S` is empty and an update is `Δq = −D⁻¹F₁`.
            return true;
        }
        self.lin.clear();
        if problem.schur_complement_add(&self.inv_d, &mut self.lin) {
            return self.lin.factor().is_ok();
        }
        let groups = &self.groups;
        for c in 0..groups.groups() {
            ops::fill_zero(&mut self.unit);
            for &j in &groups.cols[groups.col_ptr[c]..groups.col_ptr[c + 1]] {
                self.unit[j] = T::one();
            }
            ops::fill_zero(&mut self.u);
            problem.multiplier_columns_add(&self.unit, &mut self.u);
            apply_blocks(self.k, &self.inv_d, &mut self.block, &mut self.u);
            problem.constraint_rows(&self.u, &mut self.col);
            for &(i, j) in &groups.entries[groups.entry_ptr[c]..groups.entry_ptr[c + 1]] {
                self.lin.add(i, j, self.col[i]);
            }
        }
        self.lin.factor().is_ok()
    }
}

#[cfg(test)]
#[path = "schur_tests.rs"]
mod tests;
