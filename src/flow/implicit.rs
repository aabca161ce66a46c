//! Implicit flows for Hamiltonians without a closed-form flow.

use super::{Flow, FlowStats};
use crate::error::{NewtonError, SetupError, StepError};
use crate::linalg::LinearSolver;
use crate::nonlinear::{Newton, NewtonOptions, NonlinearProblem, NonlinearSolver};
use crate::real::Real;
use crate::system::{Hamiltonian, StructureMatrix};
use crate::vector::{Vector, ops};
use num_traits::{Float as _, Zero};

/// The implicit midpoint rule for `x' = M(x) ∇H(x)`:
///
/// ```text
/// x_{k+1} = x_k + h M(x̄) ∇H(x̄),     x̄ = (x_k + x_{k+1}) / 2.
/// ```
///
/// Symmetric, order 2, and it preserves every quadratic invariant of the flow exactly (up to the
/// Newton tolerance): quadratic Casimirs of `M` such as `|y|²` for Lie–Poisson `so(3)*`, and a
/// quadratic `H` when `M` is skew. Usable wherever a closed-form sub-flow is (as the inner flow
/// of a projection, or inside a composition). GNI §II.1, §IV.2 (Theorem 2.1), §VII.4.
///
/// Each step solves for the increment `δ = x_{k+1} − x_k`, `δ = h M(x + δ/2) ∇H(x + δ/2)`, by
/// [`Newton`] with a forward-difference Jacobian (`n` residual evaluations when it is rebuilt;
/// kept and Broyden-updated across steps otherwise) from the explicit Euler predictor, then
/// polishes `δ` with two fixed-point sweeps (contraction `O(h)`), so that `δ` is accurate to its
/// own round-off rather than to Newton's absolute tolerance. The increment is added with
/// compensated summation (Kahan; GNI §VIII.5): the rounding error of `x + δ` is carried to the
/// next step as long as the caller passes back the state this flow returned. Over 10⁵ steps this
/// keeps quadratic invariants at the 1e-15 level instead of a linear drift of ~ε per step.
/// Workspace is allocated at construction; a step allocates nothing. On error the state is
/// unchanged.
pub struct ImplicitMidpoint<V: Vector, Ms, H, L = <V as Vector>::Solver> {
    structure: Ms,
    hamiltonian: H,
    newton: Newton<V, L>,
    start: V,
    /// The increment `δ` (Newton's unknown).
    delta: V,
    xm: V,
    grad: V,
    f: V,
    /// Compensation of the last `x + δ` (Kahan), valid while `x` is the state last returned.
    comp: V,
    last: V,
    stats: FlowStats,
}

impl<V: Vector, Ms, H, L> core::fmt::Debug for ImplicitMidpoint<V, Ms, H, L> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("ImplicitMidpoint")
            .field("n", &self.start.len())
            .field("stats", &self.stats)
            .finish_non_exhaustive()
    }
}

impl<V, Ms, H, L> ImplicitMidpoint<V, Ms, H, L>
where
    V: Vector,
    Ms: StructureMatrix<V>,
    H: Hamiltonian<V>,
    L: LinearSolver<V::Real>,
{
    /// The implicit midpoint flow of `M ∇H` for states shaped like `x0`.
    pub fn try_new(
        structure: Ms,
        hamiltonian: H,
        x0: &V,
        newton: NewtonOptions<V::Real>,
    ) -> Result<Self, SetupError> {
        if let Some(component) = ops::first_non_finite(x0.as_slice()) {
            return Err(SetupError::NonFiniteState { component });
        }
        let n = x0.len();
        Ok(Self {
            structure,
            hamiltonian,
            newton: Newton::new(n, newton)?,
            start: x0.zeros_like(),
            delta: x0.zeros_like(),
            xm: x0.zeros_like(),
            grad: x0.zeros_like(),
            f: x0.zeros_like(),
            comp: x0.zeros_like(),
            last: x0.zeros_like(),
            stats: FlowStats::default(),
        })
    }
}

/// `F(δ) = δ − h M(x + δ/2) ∇H(x + δ/2)`.
struct Midpoint<'a, V: Vector, Ms, H> {
    h: V::Real,
    x: &'a V,
    xm: &'a mut V,
    grad: &'a mut V,
    f: &'a mut V,
    structure: &'a Ms,
    hamiltonian: &'a H,
}

impl<V, Ms, H> Midpoint<'_, V, Ms, H>
where
    V: Vector,
    Ms: StructureMatrix<V>,
    H: Hamiltonian<V>,
{
    /// `f = M(x + δ/2) ∇H(x + δ/2)`.
    fn increment_field(&mut self, delta: &[V::Real]) {
        ops::add_scaled(
            self.xm.as_mut_slice(),
            self.x.as_slice(),
            V::Real::lit(0.5),
            delta,
        );
        self.hamiltonian.gradient(self.xm, self.grad);
        self.structure.apply(self.xm, self.grad, self.f);
    }
}

impl<V, Ms, H> NonlinearProblem<V::Real> for Midpoint<'_, V, Ms, H>
where
    V: Vector,
    Ms: StructureMatrix<V>,
    H: Hamiltonian<V>,
{
    fn dim(&self) -> usize {
        self.x.len()
    }

    fn residual(&mut self, z: &[V::Real], out: &mut [V::Real]) -> Result<(), StepError> {
        self.increment_field(z);
        for ((o, &zi), &fi) in out.iter_mut().zip(z).zip(self.f.as_slice()) {
            *o = zi - self.h * fi;
        }
        Ok(())
    }
}

impl<V, Ms, H, L> Flow<V> for ImplicitMidpoint<V, Ms, H, L>
where
    V: Vector,
    Ms: StructureMatrix<V>,
    H: Hamiltonian<V>,
    L: LinearSolver<V::Real>,
{
    fn step(&mut self, h: V::Real, x: &mut V) -> Result<(), StepError> {
        if !h.is_finite() {
            return Err(StepError::BadStepSize {
                h: h.to_f64_lossy(),
            });
        }
        if let Some(component) = ops::first_non_finite(x.as_slice()) {
            return Err(StepError::NonFinite { component });
        }
        if h == V::Real::zero() {
            return Ok(());
        }
        self.start.copy_from(x);
        // Explicit Euler predictor δ = h M(x) ∇H(x).
        self.hamiltonian.gradient(&self.start, &mut self.grad);
        self.structure.apply(&self.start, &self.grad, &mut self.f);
        for (d, &fi) in self.delta.as_mut_slice().iter_mut().zip(self.f.as_slice()) {
            *d = h * fi;
        }
        let mut problem = Midpoint {
            h,
            x: &self.start,
            xm: &mut self.xm,
            grad: &mut self.grad,
            f: &mut self.f,
            structure: &self.structure,
            hamiltonian: &self.hamiltonian,
        };
        let solved = self.newton.solve(&mut problem, self.delta.as_mut_slice());
        if solved.is_ok() {
            // Polish δ below Newton's absolute tolerance: δ ← h f(x + δ/2) contracts by O(h).
            for _ in 0..2 {
                problem.increment_field(self.delta.as_slice());
                for (d, &fi) in self
                    .delta
                    .as_mut_slice()
                    .iter_mut()
                    .zip(problem.f.as_slice())
                {
                    *d = h * fi;
                }
            }
        }
        match solved {
            Ok(report) => {
                self.stats.newton_solves += 1;
                self.stats.newton_iterations += report.iterations as u64;
                self.stats.residual_evaluations += report.residual_evaluations as u64;
                self.stats.factorizations += report.factorizations as u64;
            }
            Err(e) => {
                self.newton.invalidate_jacobian();
                return Err(match e {
                    NewtonError::Residual(e) => *e,
                    source => StepError::Newton {
                        stage: "implicit midpoint",
                        source,
                    },
                });
            }
        }
        if let Some(component) = ops::first_non_finite(self.delta.as_slice()) {
            self.newton.invalidate_jacobian();
            return Err(StepError::NonFinite { component });
        }
        // Compensated summation x ← x + δ; the compensation only applies to the state this
        // flow returned last time (anything else starts afresh).
        if x.as_slice() != self.last.as_slice() {
            ops::fill_zero(self.comp.as_mut_slice());
        }
        for ((xi, &d), c) in x
            .as_mut_slice()
            .iter_mut()
            .zip(self.delta.as_slice())
            .zip(self.comp.as_mut_slice())
        {
            let y = d + *c;
            let t = *xi + y;
            *c = (*xi - t) + y;
            *xi = t;
        }
        self.last.copy_from(x);
        Ok(())
    }
    fn order(&self) -> u32 {
        2
    }
    fn is_symmetric(&self) -> bool {
        true
    }
    fn stats(&self) -> FlowStats {
        self.stats
    }
    fn dissipates(&self) -> bool {
        self.structure.is_dissipative()
    }
}
