//! Ready-made models, one file each. Every model implements the traits generically for any
//! [`Vector`](crate::Vector) storage, so the same model runs on the stack or on the heap.

#[cfg(feature = "autodiff")]
pub mod andrews;
pub mod bricard;
pub mod damped_pendulum;
pub mod four_bar;
pub mod paper;
pub mod pendulum_chain;
pub mod rigid_body;
pub mod sphere_particles;
pub mod spherical_pendulum;
pub mod spring_chain;

pub use damped_pendulum::DampedPendulum;
pub use pendulum_chain::PendulumChain;
pub use rigid_body::RigidBody;
pub use sphere_particles::SphereParticles;
pub use spherical_pendulum::SphericalPendulum;
pub use spring_chain::SpringChain;

use crate::error::SetupError;
use crate::real::Real;

/// Checks model parameters: every entry of each `positive` list positive and finite (the error
/// names it, `"mass 3"`, or just `"rod length"` for a single value), and every `non_negative`
/// value finite and `≥ 0`.
pub(crate) fn check_parameters<T: Real>(
    positive: &[(&str, &[T])],
    non_negative: &[(&str, T)],
) -> Result<(), SetupError> {
    for (what, values) in positive {
        if let Some(i) = values
            .iter()
            .position(|v| !(*v > T::zero() && v.is_finite()))
        {
            let name = if values.len() > 1 {
                format!("{what} {i}")
            } else {
                what.to_string()
            };
            return Err(SetupError::InvalidParameter {
                name,
                value: values[i].to_f64_lossy(),
                requirement: "positive and finite",
            });
        }
    }
    for (what, v) in non_negative {
        if !(*v >= T::zero() && v.is_finite()) {
            return Err(SetupError::InvalidParameter {
                name: what.to_string(),
                value: v.to_f64_lossy(),
                requirement: "finite and non-negative",
            });
        }
    }
    Ok(())
}

/// What [`tracked_run`] measured.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Tracked {
    /// Steps taken (all of them, or up to the failing one).
    pub steps: usize,
    /// The most Newton iterations one step took.
    pub newton_max: u64,
    /// `max ‖g‖∞` over the run.
    pub max_g: f64,
    /// `max |H − H₀|` over the first and over the last tenth of the run.
    pub first_tenth: f64,
    /// See `first_tenth`.
    pub last_tenth: f64,
    /// The step error that stopped the run, if one did (the state is then the last good one).
    pub error: Option<crate::error::StepError>,
    /// The final state is finite.
    pub finite: bool,
}

/// Steps `flow` `steps` times by `h` from `x`, and after every step records the Newton
/// iterations it took, `‖g‖∞` of `constraint` and `|H − H₀|` of `hamiltonian` over the first
/// and last tenth, then calls `each` on the state: the loop of the benchmark runs of the
/// IFToMM models.
pub(crate) fn tracked_run<V, F>(
    flow: &mut F,
    x: &mut V,
    (h, steps): (f64, usize),
    constraint: &impl crate::HolonomicConstraint<V>,
    hamiltonian: &impl crate::Hamiltonian<V>,
    mut each: impl FnMut(&V),
) -> Tracked
where
    V: crate::Vector<Real = f64>,
    F: crate::flow::Flow<V>,
{
    let e0 = hamiltonian.energy(x);
    let mut g = vec![0.0; constraint.dim()];
    let mut run = Tracked {
        steps: 0,
        newton_max: 0,
        max_g: 0.0,
        first_tenth: 0.0,
        last_tenth: 0.0,
        error: None,
        finite: true,
    };
    let mut newton_prev = flow.stats().newton_iterations;
    let mut stepper = match crate::Stepper::new(flow, &mut *x, 0.0, h) {
        Ok(s) => s,
        Err(e) => {
            run.error = Some(match e {
                crate::IntegrateError::NonFiniteInitialState { component } => {
                    crate::error::StepError::NonFinite { component }
                }
                crate::IntegrateError::Step { source, .. } => source,
            });
            run.finite = false;
            return run;
        }
    };
    for k in 0..steps {
        if let Err(e) = stepper.step() {
            run.error = Some(e);
            break;
        }
        run.steps += 1;
        let n = stepper.flow().stats().newton_iterations;
        run.newton_max = run.newton_max.max(n - newton_prev);
        newton_prev = n;
        let x = stepper.state();
        constraint.residual(x, &mut g);
        run.max_g = g.iter().fold(run.max_g, |a, v| a.max(v.abs()));
        let de = (hamiltonian.energy(x) - e0).abs();
        if k < steps / 10 {
            run.first_tenth = run.first_tenth.max(de);
        } else if k >= steps - steps / 10 {
            run.last_tenth = run.last_tenth.max(de);
        }
        each(x);
    }
    drop(stepper);
    run.finite = x.as_slice().iter().all(|v| v.is_finite());
    run
}
