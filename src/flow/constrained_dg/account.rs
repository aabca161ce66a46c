//! The energy account of a constrained discrete-gradient step: its balance
//! `H(x') − H(x) = h F̄ᵀM F̄ + S_n` (damping and inputs), the kinetic energy the
//! hidden-constraint projection removes, and what the step books in the ledger.

use super::step_problem::Problem;
use super::{ConstrainedDiscreteGradient, problem};
use crate::flow::step_end;
use crate::nonlinear::NonlinearProblem;
use crate::system::{Hamiltonian, Model};
use crate::vector::{Vector, ops};
use num_traits::Zero;

/// The energy bookkeeping of the last step of a [`ConstrainedDiscreteGradient`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EnergyBalance<T> {
    /// `H(x_k)`.
    pub before: T,
    /// `H(x')` after the discrete-gradient step, before the hidden-constraint projection.
    pub after_step: T,
    /// `H(x_{k+1})`, after the projection (equal to `after_step` without one).
    pub after: T,
    /// `h F̄ᵀ M(x̄) F̄`, `F̄ = ∇̄H + ∇̄gᵀλ`: the energy the step supplies. The discrete-gradient
    /// identity is `after_step − before = supplied` (to round-off): `≤ 0` when `M + Mᵀ ⪯ 0`,
    /// `0` when `M` is skew. The constraint force does no work.
    pub supplied: T,
    /// `S_n = δqᵀ F(q̄) u(t_n + h/2)`, the work of the inputs
    /// ([`with_inputs`](ConstrainedDiscreteGradient::with_inputs); zero without): the identity
    /// is `after_step − before = supplied + inputs`.
    pub inputs: T,
}

impl<V, Sys, W> ConstrainedDiscreteGradient<V, Sys, W>
where
    V: Vector,
    Sys: Model<V>,
    W: Vector<Real = V::Real>,
{
    /// The energy bookkeeping of the last successful step (`None` before the first), recomputed
    /// from the stored step (costs three energies and one residual evaluation, or on the
    /// mechanical path one product with `M`).
    pub fn energy_balance(&mut self) -> Option<EnergyBalance<V::Real>> {
        if !self.have_step {
            return None;
        }
        let h = self.last_h;
        let sys = &self.system;
        let (before, after_step, after) = (
            sys.hamiltonian().energy(&self.start),
            sys.hamiltonian().energy(&self.after_step),
            sys.hamiltonian().energy(&self.last),
        );
        if self.mechanical.is_some() {
            let supplied = self.supplied_reduced(h);
            let inputs = self.input_work(h);
            return Some(EnergyBalance {
                before,
                after_step,
                after,
                supplied,
                inputs,
            });
        }
        let zs = self.z.as_slice().to_vec();
        let mut out = vec![V::Real::zero(); zs.len()];
        let mut problem = problem!(self, h);
        problem.residual(&zs, &mut out).ok()?;
        let (supplied, inputs) = self.full_account(h);
        Some(EnergyBalance {
            before,
            after_step,
            after,
            supplied,
            inputs,
        })
    }

    /// `(h F̄ᵀM F̄, S_n)` on the full path from the last residual (`grad = h F̄`,
    /// `f = h M(x̄) F̄`, the inputs' `h B(x̄) u` in the forcing), which must have been evaluated
    /// at the step's solution: Newton's last evaluation is.
    pub(super) fn full_account(&self, h: V::Real) -> (V::Real, V::Real) {
        let damping = ops::dot(self.grad.as_slice(), self.f.as_slice()) / h;
        let supplied = self.forcing.as_ref().map_or(V::Real::zero(), |forcing| {
            ops::dot(self.grad.as_slice(), forcing.last_force().as_slice()) / h
        });
        (damping, supplied)
    }

    /// `H(x') − H(x_{k+1})`, the energy the hidden-constraint projection removed (zero
    /// without one).
    pub(super) fn removed_by_projection(&self) -> V::Real {
        if self.hidden.is_none() {
            return V::Real::zero();
        }
        let mechanical = self.mechanical.as_ref().map(|r| (r.nq, &r.w[..]));
        step_end::removed_energy(&self.system, mechanical, &self.after_step, &self.last)
    }
}
