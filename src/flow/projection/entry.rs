//! The entry check of a step: the state a step receives is the one the last step left
//! (or is finite and on the manifold), so an embedder's change between steps is caught.

use crate::error::StepError;
use crate::real::Real;
use crate::system::HolonomicConstraint;
use crate::system::Model;
use crate::vector::{Vector, ops};
use num_traits::Float as _;

/// The check of a step's starting state (see [`ProjectionOptions::manifold_tol`]): skipped when
/// the state equals the flow's own last result, or the last state that passed the check (as
/// floats) — an extrapolation starts each row from the same state, a rejected step retries
/// from it.
pub(super) struct EntryCheck<V: Vector> {
    tol: Option<V::Real>,
    /// A copy of the last result (`valid`), or nothing yet.
    last: V,
    valid: bool,
    /// The last state that passed [`check`](Self::check) (`passed_valid`).
    passed: V,
    passed_valid: bool,
}

impl<V: Vector> EntryCheck<V> {
    /// The check for a flow built at `x0` with tolerance `tol`; `x0` counts as the last result
    /// when there is a tolerance (the constructors checked it).
    pub(super) fn new(tol: Option<V::Real>, x0: &V) -> Self {
        Self {
            tol,
            last: x0.clone(),
            valid: tol.is_some(),
            passed: x0.clone(),
            passed_valid: false,
        }
    }

    /// `true` when `x` is, float for float, the flow's own last result or the last state that
    /// passed the check.
    #[inline]
    pub(super) fn is_last(&self, x: &V) -> bool {
        (self.valid && ops::equal(x.as_slice(), self.last.as_slice()))
            || (self.passed_valid && ops::equal(x.as_slice(), self.passed.as_slice()))
    }

    /// A step must start on the manifold (`‖g‖∞`, and with `check_phi` `‖φ‖∞`, within the
    /// tolerance). Called only when the step does not start from the flow's own last result:
    /// one residual evaluation (two with `φ`) when the caller changed the state between
    /// steps. `r` has the constraint's length; `t1`, `t2` are workspace of the state's length.
    pub(super) fn check<Sys>(
        &mut self,
        system: &Sys,
        x: &V,
        check_phi: bool,
        r: &mut [V::Real],
        t1: &mut V,
        t2: &mut V,
    ) -> Result<(), StepError>
    where
        Sys: Model<V>,
    {
        let Some(tol) = self.tol else {
            return Ok(());
        };
        let off = |what, r: V::Real| StepError::OffManifold {
            what,
            residual: r.to_f64_lossy(),
            tol: tol.to_f64_lossy(),
        };
        system.constraint().residual(x, r);
        let g = ops::norm_inf(r);
        if g.is_nan() || g > tol {
            return Err(off("g", g));
        }
        if check_phi {
            // φ = G M ∇H, the hidden constraint of the degenerate case.
            system.hidden_constraint(x, t1, t2, r);
            let phi = ops::norm_inf(r);
            if phi.is_nan() || phi > tol {
                return Err(off("phi", phi));
            }
        }
        self.passed.copy_from(x);
        self.passed_valid = true;
        Ok(())
    }

    /// `x` is the flow's newest result (checked when it was made).
    #[inline(always)]
    pub(super) fn record(&mut self, x: &V) {
        if self.tol.is_some() {
            self.last.copy_from(x);
            self.valid = true;
        }
    }
}
