//! The step density a reversible controller follows ([`StepDensity`]).

use crate::vector::Vector;

/// A step density `ρ(x) = 1/s(x)`: the steps of a reversible controller are `h ≈ ε/ρ(x)`
/// (`s` is the step-size function of Hairer & Söderlind, *SIAM J. Sci. Comput.* 26, 2005, and
/// Huang & Leimkuhler, *SIAM J. Sci. Comput.* 18, 1997). The controller carries `ρ` as an extra
/// variable and advances it with the rate of change of `log ρ` along the motion,
///
/// ```text
/// G(x) = d/dt log ρ(x(t)) = ∇ρ(x) · ẋ / ρ(x),
/// ```
///
/// so only `G` is needed at every step and `ρ` itself once, at the start.
///
/// Kepler's problem with `s = |q|^{3/2}` (steps shrinking like the orbital period at the
/// current radius): `ρ = |q|^{−3/2}`, `G = −(3/2) qᵀq̇ / qᵀq`. Arclength (`s = 1/|ẋ|`):
/// `ρ = |ẋ|`, `G = ẋᵀẍ / |ẋ|²`.
pub trait StepDensity<V: Vector> {
    /// `ρ(x) > 0`, the density at `x` (read once, when the controller starts).
    fn density(&mut self, x: &V) -> V::Real;
    /// `G(x) = d/dt log ρ(x(t))` along the motion through `x`.
    fn log_rate(&mut self, x: &V) -> V::Real;
}

/// A [`StepDensity`] from two closures: `ρ(x)` and `G(x)` (see [`step_density`]).
#[derive(Debug, Clone, Copy)]
pub struct DensityFn<R, G> {
    density: R,
    log_rate: G,
}

/// The step density `ρ(x)` with its logarithmic rate `G(x) = d/dt log ρ(x(t))`.
///
/// ```
/// use lieflow::flow::{StepDensity, step_density};
/// use nalgebra::SVector;
/// // Kepler in the plane, x = (q, p), unit mass: ρ = |q|^{-3/2}, G = −(3/2) qᵀp / qᵀq.
/// let mut kepler = step_density(
///     |x: &SVector<f64, 4>| (x[0] * x[0] + x[1] * x[1]).powf(-0.75),
///     |x: &SVector<f64, 4>| -1.5 * (x[0] * x[2] + x[1] * x[3]) / (x[0] * x[0] + x[1] * x[1]),
/// );
/// let x = SVector::<f64, 4>::new(4.0, 0.0, 0.0, 0.5);
/// assert_eq!(kepler.density(&x), 0.125);
/// assert_eq!(kepler.log_rate(&x), 0.0);
/// ```
pub fn step_density<R, G>(density: R, log_rate: G) -> DensityFn<R, G> {
    DensityFn { density, log_rate }
}

impl<V, R, G> StepDensity<V> for DensityFn<R, G>
where
    V: Vector,
    R: FnMut(&V) -> V::Real,
    G: FnMut(&V) -> V::Real,
{
    fn density(&mut self, x: &V) -> V::Real {
        (self.density)(x)
    }
    fn log_rate(&mut self, x: &V) -> V::Real {
        (self.log_rate)(x)
    }
}
