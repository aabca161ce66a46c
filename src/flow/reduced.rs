//! Newton on the positions of a model of mechanical form ([`MechanicalForm`]): the implicit
//! schemes whose momentum rows can be solved exactly (the implicit midpoint rule of
//! [`ProjectedMidpoint`](super::ProjectedMidpoint), the constrained discrete gradient) eliminate
//! the momenta and solve for `(δq, ν)`, `ν = (h²/2) λ`, `n_q + m` unknowns, with a sparse Newton
//! matrix kept across steps and a predictor extrapolated from the last steps ([`Predictor`]).

use super::predictor::Predictor;
use super::schur::{ReducedBlocks, SchurIteration};
use crate::error::{LinearSolveError, NewtonError, StepError};
use crate::linalg::LinearSolver;
use crate::nonlinear::{Newton, NewtonOptions, NonlinearSolver, SolveReport};
use crate::real::Real;
use crate::system::MechanicalForm;
use nalgebra::DVector;

/// The reduced system's solver and workspace (allocated at construction), in fields a step
/// borrows separately: the problem reads `w` and writes `scaled` while `solver` solves for `z`.
pub(crate) struct Reduced<T: Real, L> {
    /// `n_q`.
    pub(crate) nq: usize,
    /// `diag W⁻¹`.
    pub(crate) w: Vec<T>,
    /// `(δq, ν)`.
    pub(crate) z: Vec<T>,
    /// The entries of `B` (the momentum rows' `B Y^q` of the Petrov–Galerkin residual).
    pub(crate) momentum_block: Vec<(usize, usize, T)>,
    /// Multiplier-sized scratch for the problems' residuals and columns.
    pub(crate) scaled: Vec<T>,
    pub(crate) solver: KeptNewton<T, L>,
}

/// Newton on `(δq, ν)`, `n_q + m` unknowns: first the [`SchurIteration`] (no force Jacobian),
/// and when it contracts too slowly Newton with the pattern of `B`, `∇²V` and `G_q` (and of
/// the constraint Hessians when asked for): grouped closed-form columns, factored by `L` (for
/// `f64`, [`AutoLu`](crate::linalg::AutoLu): dense, banded or sparse by this pattern), the
/// matrix kept across steps of the same size. The predictor from past steps.
pub(crate) struct KeptNewton<T: Real, L> {
    schur: SchurIteration<T, L>,
    newton: Newton<DVector<T>, L>,
    /// The step size of the kept Newton matrix and of `past` (`0`: none).
    h: T,
    /// The extrapolation of `(δq, ν)` from the last consecutive steps of size `h`, each ending
    /// where the next one starts.
    past: Predictor<T>,
}

/// The contraction a Schur iteration goes on with when the constraints' curvature enters the
/// step (the discrete gradient, the Petrov–Galerkin scheme), and below which the kept Newton
/// matrix is rebuilt. The curvature, `h² Â Σλ∇²g/m` — a taut chain of light links' geometric
/// stiffness — is outside the iteration's matrix and slows it as the tension grows without
/// stopping it, while what it hands over to costs a difference Jacobian (a residual per column
/// group) and a sparse LU that fills in on a long chain: 0.5 instead of the default 0.1 took a
/// Petrov–Galerkin step on a 1000-link chain of 1 g links from 11.7 to 2.6 ms, a discrete
/// gradient step on 3000 links from 3.11 to 2.06 ms (docs/method.md §5c, §11).
const CURVED_MAX_CONTRACTION: f64 = 0.5;

impl<T: Real, L: LinearSolver<T>> Reduced<T, L> {
    /// The solver for `form` with `m` constraints. Its Jacobian pattern: the diagonal, `B`,
    /// `∇²V` (dense without a declared pattern) in the `δq` block, `G_qᵀ` in the `ν` columns
    /// and `G_q` in the constraint rows (dense without entries); with `curvature`, also the
    /// pattern of `Σᵢ νᵢ ∇²gᵢ` (the positions each constraint couples) in the `δq` block, and
    /// the looser contraction bound [`CURVED_MAX_CONTRACTION`].
    ///
    /// With a `k × k` stage matrix `stage` the system has `k` stages (see [`SchurIteration`]):
    /// `k (n_q + m)` unknowns, unknown `e` of stage `i` at `e k + i`, and the pattern above
    /// with a dense `k × k` block for each entry. The midpoint rule and the discrete gradient
    /// take `[½]`.
    pub(crate) fn new(
        form: MechanicalForm<T>,
        m: usize,
        options: NewtonOptions<T>,
        curvature: bool,
        stage: &[T],
    ) -> Result<Self, LinearSolveError> {
        let nq = form.positions;
        let k = super::stage_blocks::stages_of(stage);
        let mut pattern: Vec<(usize, usize)> = (0..nq).map(|i| (i, i)).collect();
        pattern.extend(form.momentum_block.iter().map(|&(r, c, _)| (r, c)));
        match &form.hessian_pattern {
            Some(p) => pattern.extend_from_slice(p),
            None => pattern.extend((0..nq).flat_map(|i| (0..nq).map(move |j| (i, j)))),
        }
        let dense;
        let g: &[(usize, usize)] = match &form.constraint_pattern {
            Some(p) => p,
            None => {
                dense = (0..m)
                    .flat_map(|r| (0..nq).map(move |c| (r, c)))
                    .collect::<Vec<_>>();
                &dense
            }
        };
        for &(r, c) in g {
            pattern.push((nq + r, c));
            pattern.push((c, nq + r));
        }
        if curvature {
            let mut rows: Vec<Vec<usize>> = vec![Vec::new(); m];
            for &(r, c) in g {
                rows[r].push(c);
            }
            for cols in &rows {
                pattern.extend(cols.iter().flat_map(|&a| cols.iter().map(move |&b| (a, b))));
            }
        }
        pattern.sort_unstable();
        pattern.dedup();
        let pattern = super::stage_blocks::expand(&pattern, k);
        let unknowns = k * (nq + m);
        // Simplified Newton: the matrix is kept while the iteration contracts, not updated by
        // secants (a rank-one update refactors a dense matrix; sparse storage has none).
        // The backend by this matrix's own structure (a solver forced for a projection's
        // multiplier systems fits those, not this one).
        let mut options = options.with_solver(crate::linalg::SolverChoice::Auto);
        options.broyden = false;
        if curvature {
            options.max_contraction = T::lit(CURVED_MAX_CONTRACTION);
        }
        let newton = Newton::with_pattern(unknowns, options, Some(&pattern))?;
        let schur = SchurIteration::new(
            &form.inverse_mass,
            &form.momentum_block,
            m,
            form.constraint_pattern.as_deref(),
            options,
            stage,
        )?;
        Ok(Self {
            nq,
            w: form.inverse_mass,
            momentum_block: form.momentum_block,
            z: vec![T::zero(); unknowns],
            scaled: vec![T::zero(); m],
            solver: KeptNewton {
                schur,
                newton,
                h: T::zero(),
                past: Predictor::new(unknowns),
            },
        })
    }

    /// Forgets the kept Newton matrix and the past steps.
    pub(crate) fn invalidate(&mut self) {
        self.solver.invalidate();
    }
}

impl<T: Real, L: LinearSolver<T>> KeptNewton<T, L> {
    /// Forgets the kept Newton matrix and the past steps.
    pub(crate) fn invalidate(&mut self) {
        self.newton.invalidate_jacobian();
        self.schur.forget();
        self.h = T::zero();
        self.past.forget();
    }

    /// Lets the Schur iteration accept its first update on the contraction measured by an
    /// earlier solve, unevaluated ([`ContractionEstimate`](super::contraction)): for a step
    /// that needs nothing from the residual at its solution.
    pub(crate) fn trust_contraction(&mut self) {
        self.schur.trust_contraction();
    }

    /// Starts a step of size `h`: the kept matrix depends on `h` (not as a power of it), so a
    /// new size builds it anew; the past steps predict only a step that `continued` them.
    pub(crate) fn begin(&mut self, h: T, continued: bool) {
        if self.h != h {
            self.invalidate();
            self.h = h;
        }
        self.schur.begin(h);
        if !continued {
            self.past.forget();
            self.schur.forget_contraction();
        }
    }

    /// Replaces the predicted `z = (δq, ν)` by the extrapolation of the last steps' (of the
    /// degree that predicted the last step best, [`Predictor`]), when there are any.
    pub(crate) fn predict(&self, z: &mut [T]) {
        self.past.predict(z);
    }

    /// Solves `problem` from the predictor in `z`: by the Schur iteration when it is ready and
    /// contracts, by Newton on the kept matrix from where it stopped otherwise; on failure the
    /// kept matrix is forgotten. The report counts both.
    pub(crate) fn solve<P>(
        &mut self,
        problem: &mut P,
        z: &mut [T],
    ) -> Result<SolveReport<T>, NewtonError<StepError>>
    where
        P: ReducedBlocks<T, Error = StepError>,
    {
        let mut head = SolveReport::default();
        if self.schur.ready() {
            match self.schur.solve(problem, z, &mut head) {
                Ok(true) => return Ok(head),
                Ok(false) => {}
                Err(e) => {
                    self.invalidate();
                    return Err(e);
                }
            }
        }
        match self.newton.solve(problem, z) {
            Ok(mut report) => {
                report.iterations += head.iterations;
                report.residual_evaluations += head.residual_evaluations;
                report.factorizations += head.factorizations;
                Ok(report)
            }
            Err(e) => {
                self.invalidate();
                Err(e)
            }
        }
    }

    /// Records the solved `z` of a step that continued the previous one
    /// (`continued`).
    pub(crate) fn record(&mut self, z: &[T], continued: bool) {
        if !continued {
            self.past.forget();
        }
        self.past.record(z);
    }
}
