//! The hidden-constraint projection `φ(x' + M(x') G(x')ᵀ ν) = 0`: the last stage of the
//! constrained discrete gradient ([`ConstrainedDiscreteGradient`](crate::flow::ConstrainedDiscreteGradient))
//! and the `λ_{k+1}` system of [`ProjectedMidpoint`](super::ProjectedMidpoint)'s general path.

use super::small::{SecondHalf, fixed_mut, solve_second_half};
use crate::error::{NewtonError, SetupError, StepError};
use crate::nonlinear::{
    Newton, NewtonOptions, NonlinearProblem, NonlinearSolver, SmallNewton, SolveReport,
};
use crate::real::Real;
use crate::system::Model;
use crate::system::{Hamiltonian, HolonomicConstraint, StructureMatrix, half_step_keeps_jacobian};
use crate::vector::{Vector, ops};
use num_traits::{One, Zero};

/// `F(ν) = φ(x' + M(x') G(x')ᵀ ν)`: the hidden-constraint projection (also the `λ_{k+1}`
/// system of [`ProjectedMidpoint`](super::ProjectedMidpoint)'s general path, `ν = (h/2) λ_{k+1}`).
pub(crate) struct Hidden<'a, V: Vector, Sys> {
    pub(crate) base: &'a V,
    /// `M(x') G(x')ᵀ` applied to `ν` lands here: `x = base + dir(ν)`.
    pub(crate) x: &'a mut V,
    pub(crate) t1: &'a mut V,
    pub(crate) t2: &'a mut V,
    pub(crate) system: &'a Sys,
    /// Scratch for closed-form Jacobian columns (a state and `m` multipliers), for a caller
    /// whose case makes them exact (see `jacobian_column`); `None`: differences.
    pub(crate) columns: Option<(&'a mut V, &'a mut [V::Real])>,
}

impl<V, Sys> Hidden<'_, V, Sys>
where
    V: Vector,
    Sys: Model<V>,
{
    /// `x = base + M(base) G(base)ᵀ ν`.
    pub(crate) fn place(&mut self, nu: &[V::Real]) {
        self.system
            .constraint_force(self.base, nu, self.t1, self.t2);
        ops::add_scaled(
            self.x.as_mut_slice(),
            self.base.as_slice(),
            V::Real::one(),
            self.t2.as_slice(),
        );
    }
}

impl<V, Sys> NonlinearProblem<V::Real> for Hidden<'_, V, Sys>
where
    V: Vector,
    Sys: Model<V>,
{
    type Error = StepError;

    fn dim(&self) -> usize {
        self.system.constraint().dim()
    }

    fn residual(&mut self, nu: &[V::Real], out: &mut [V::Real]) -> Result<(), StepError> {
        self.place(nu);
        self.system.hidden_constraint(self.x, self.t1, self.t2, out);
        Ok(())
    }
    /// `∂φ(x)/∂ν_j = G(x) M(x) ∇²H(x) M(x') G(x')ᵀ e_j`: exact in the decoupled case, where
    /// `G` and `M Gᵀ` do not change along the projection (as `SecondHalf`'s columns).
    fn jacobian_column(&mut self, nu: &[V::Real], j: usize, out: &mut [V::Real]) -> bool {
        if self.columns.is_none() {
            return false;
        }
        if j == 0 {
            self.place(nu);
        }
        let Some((scratch, unit)) = self.columns.as_mut() else {
            return false;
        };
        unit.iter_mut().for_each(|u| *u = V::Real::zero());
        unit[j] = V::Real::one();
        let sys = self.system;
        sys.constraint_force(self.base, unit, self.t1, self.t2);
        if !sys
            .hamiltonian()
            .hessian_apply(&*self.x, &*self.t2, self.t1)
        {
            return false;
        }
        sys.structure().apply(&*self.x, &*self.t1, scratch);
        sys.constraint().jacobian_apply(&*self.x, scratch, out);
        true
    }
}

/// The solver of the hidden-constraint projection `φ(x' + M Gᵀ ν) = 0`.
pub(crate) enum HiddenSolver<V: Vector> {
    /// `m ≤` [`SMALL_MAX`](crate::nonlinear::SMALL_MAX) and a Hamiltonian with a Hessian: full Newton on stack arrays with
    /// the closed-form columns `G M ∇²H M Gᵀ e_j` ([`SecondHalf`] with `h = 2`), and one
    /// linear solve when the system is affine in `ν` (quadratic `H`, constant `M`, `G`
    /// unchanged along `M Gᵀ`).
    Small {
        newton: SmallNewton<V::Real>,
        /// `M(x') G(x')ᵀ e_j`.
        dirs: Vec<V>,
        affine: bool,
    },
    /// Otherwise: [`Newton`] with a kept difference Jacobian.
    General(Newton<V>),
}

impl<V: Vector> HiddenSolver<V> {
    pub(crate) fn new<Sys>(
        system: &Sys,
        x0: &V,
        options: NewtonOptions<V::Real>,
        pattern: Option<&[(usize, usize)]>,
    ) -> Result<Self, SetupError>
    where
        Sys: Model<V>,
    {
        let m = system.constraint().dim();
        let mut out = x0.zeros_like();
        match SmallNewton::new(m, options) {
            Some(newton) if system.hamiltonian().hessian_apply(x0, x0, &mut out) => {
                Ok(HiddenSolver::Small {
                    newton,
                    dirs: vec![x0.zeros_like(); m],
                    affine: system.hamiltonian().is_quadratic()
                        && system.structure().is_constant()
                        && half_step_keeps_jacobian(system, x0),
                })
            }
            _ => Ok(HiddenSolver::General(Newton::with_pattern(
                m, options, pattern,
            )?)),
        }
    }

    /// The projection `x = base + M(base) G(base)ᵀ ν` with `φ(x) = 0` into `xe` (`nu` holds
    /// `ν`, warm-started by the caller). `K = m` on the small path, `K = 0` on the general one.
    #[inline(always)]
    pub(crate) fn project<const K: usize, Sys>(
        &mut self,
        system: &Sys,
        base: &V,
        xe: &mut V,
        tmp: &mut V,
        t2: &mut V,
        nu: &mut [V::Real],
    ) -> Result<SolveReport<V::Real>, NewtonError<StepError>>
    where
        Sys: Model<V>,
    {
        match self {
            HiddenSolver::Small {
                newton,
                dirs,
                affine,
            } if K > 0 => {
                let e: &mut [V; K] = fixed_mut(dirs);
                let mut unit = [V::Real::zero(); K];
                for (j, ej) in e.iter_mut().enumerate() {
                    unit[j] = V::Real::one();
                    system.constraint_force(base, &unit, tmp, ej);
                    unit[j] = V::Real::zero();
                }
                // x = x' + M Gᵀ ν: a half-step of "h = 2".
                let mut problem = SecondHalf {
                    h: V::Real::lit(2.0),
                    y: base,
                    system,
                    d: e,
                    x_next: xe,
                    t1: tmp,
                    t2,
                };
                let nu: &mut [V::Real; K] = fixed_mut(nu);
                solve_second_half(newton, *affine, &mut problem, nu)
            }
            HiddenSolver::Small { .. } => unreachable!("the small hidden solver runs with K = m"),
            HiddenSolver::General(newton) => {
                let mut problem = Hidden {
                    base,
                    x: xe,
                    t1: tmp,
                    t2,
                    system,
                    columns: None,
                };
                let report = newton.solve(&mut problem, nu)?;
                problem.place(nu);
                Ok(report)
            }
        }
    }
}
