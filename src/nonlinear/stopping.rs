//! When Newton's iteration stops: the effective residual (rows within the problem's noise
//! floor count as zero) and the tests after an update at the round-off of the residual or of
//! the unknowns, shared by [`Newton`](super::Newton) and [`DiagonalNewton`](super::DiagonalNewton).

use super::{NewtonOptions, NonlinearProblem};
use crate::real::Real;
use crate::vector::ops;

/// Residuals below `NOISE_FACTOR · ftol` are treated as possibly at their round-off floor.
pub(crate) const NOISE_FACTOR: f64 = 100.0;

/// The residual as the convergence test sees it: the rows the problem's noise floor applies to
/// count as zero while within `4 · noise_floor`; the other rows count as they are.
#[inline]
pub(crate) fn effective_residual<T: Real, P: NonlinearProblem<T>>(problem: &P, f: &[T]) -> T {
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

/// Whether an update `dz` to `z` that took the effective residual from `r` to `r_new`, still
/// above `ftol`, reached the root as far as it can be represented (`halvings` of the update
/// taken; `fresh`: the Jacobian was built at the iterate the update started from).
///
/// - The update test (`atol`, `rtol`): a full step that reduced the residual and moved every
///   unknown by less than its tolerance; a damped or worsening step is small without being
///   accurate.
/// - Below `noise = NOISE_FACTOR · ftol` the residual is dominated by its own round-off: an
///   update at the round-off of `z`, or a step with a fresh Jacobian that no longer halves it,
///   means the root is reached. With a kept Jacobian slow progress is no evidence of that, but
///   an update at round-off is: the kept matrix has converged the iteration as far as `z` can
///   be represented (a rebuild would cost a Jacobian to learn nothing).
/// - Further up (to `NOISE_FACTOR · noise`: a residual whose terms cancel, like the hidden
///   constraint of a light body between heavy ones, rounds far above ε times its own size),
///   with a fresh Jacobian, only both together for a full step: the update is at round-off of
///   `z` and did not halve the residual — no representable `z` does better.
#[inline]
pub(crate) fn converged_after_update<T: Real>(
    opts: &NewtonOptions<T>,
    r: T,
    r_new: T,
    halvings: usize,
    fresh: bool,
    dz: &[T],
    z: &[T],
) -> bool {
    if (opts.atol > T::zero() || opts.rtol > T::zero())
        && halvings == 0
        && r_new < r
        && dz
            .iter()
            .zip(z)
            .all(|(&d, &zi)| d.abs() <= opts.atol + opts.rtol * zi.abs())
    {
        return true;
    }
    let noise = T::lit(NOISE_FACTOR) * opts.ftol;
    let at_roundoff = ops::norm_inf(dz) <= opts.xtol * (T::one() + ops::norm_inf(z));
    if !fresh {
        return r_new <= noise && at_roundoff;
    }
    let stalled = r_new >= T::lit(0.5) * r;
    (r_new <= noise && (at_roundoff || stalled))
        || (r_new <= T::lit(NOISE_FACTOR) * noise && halvings == 0 && at_roundoff && stalled)
}
