//! The scheme of a scene: how its step is raised and to which order, the run plan, and the flow —
//! the splitting of the exact sub-flows, projected when constrained, or an implicit scheme.

use super::raise::{Raise, raised};
use super::{MAX_STEPS, Result, constraints::setup_error, err, validate::positive};
use crate::error::SetupError;
use crate::flow::{
    CompositionTable, Coupling, Flow, FlowExt, Projected, ProjectionOptions, Scheme,
};
use crate::linalg::LinearSolver;
use crate::nonlinear::NewtonOptions;
use crate::port::InputFlow;
use crate::real::Real;
use crate::scene::bodies::Bodies;
use crate::scene::error::{FieldPath, SceneErrorKind};
use crate::scene::model::{
    DashpotFlow, FreeFlight, HingeDamperFlow, Kick, SceneKick, SceneModel, SceneSplitting,
    consistent_account, consistent_momentum,
};
use crate::scene::run::RunPlan;
use crate::scene::schema::{Diagnostic, Flags, IntegratorSpec, Method, SceneFile};
use crate::system::{Case, System};
use crate::vector::Vector;
use faer::Col;
use std::sync::Arc;

/// The orders `auto` offers.
const ORDERS: &str =
    "the schemes have the even orders 2 to 16 (compositions up to 8, extrapolation from 4 to 16)";

/// The scheme a scene asks for: how its order-2 step is raised, and the order.
///
/// `auto` with `order = 4 | 6 | 8` composes the step (Suzuki, Kahan–Li) — or, when the scene
/// `dissipative`, extrapolates it, since a composition above order 2 runs the damping
/// backwards; `order = 10 | 12 | 14 | 16` extrapolates it (no composition of those orders is
/// offered). `extrapolation` extrapolates whatever the scene. A named composition on a
/// dissipative scene is refused.
pub(super) fn choose_scheme(
    integ: &IntegratorSpec,
    dissipative: bool,
    bodies: Option<&Bodies>,
) -> Result<(Raise, u32)> {
    let path = FieldPath::root().key("integrator");
    let out_of_range = |o: u32, what: &str| {
        err(
            SceneErrorKind::Value,
            path.key("order"),
            format!("order {o}: {what}"),
        )
    };
    let (raise, order) = match integ.scheme {
        Method::Auto => {
            let order = integ.order.unwrap_or(2);
            let raise = match order {
                2 => Raise::Base,
                4 | 6 | 8 if dissipative => Raise::Extrapolate(order),
                4 => Raise::Compose(Method::Suzuki4.composition().expect("a table")),
                6 => Raise::Compose(Method::KahanLi6.composition().expect("a table")),
                8 => Raise::Compose(Method::KahanLi8.composition().expect("a table")),
                // No composition of these orders: extrapolation, damped or not.
                10 | 12 | 14 | 16 => Raise::Extrapolate(order),
                o => return Err(out_of_range(o, ORDERS)),
            };
            (raise, order)
        }
        Method::PetrovGalerkin => {
            let order = integ.order.unwrap_or(4);
            if !matches!(order, 2 | 4 | 6 | 8) {
                return Err(out_of_range(
                    order,
                    "the Petrov–Galerkin scheme offers orders 2, 4, 6 and 8",
                ));
            }
            (Raise::Base, order)
        }
        Method::Extrapolation => {
            let order = integ.order.unwrap_or(4);
            if !matches!(order, 4 | 6 | 8 | 10 | 12 | 14 | 16) {
                return Err(out_of_range(
                    order,
                    "extrapolation of the splitting offers the even orders 4 to 16",
                ));
            }
            (Raise::Extrapolate(order), order)
        }
        method => match method.composition() {
            Some(t) => (Raise::Compose(t), t.order),
            None => (Raise::Base, 2),
        },
    };
    if let Some(o) = integ.order
        && o != order
    {
        return Err(err(
            SceneErrorKind::Value,
            path.key("order"),
            format!("order {o}, but scheme '{}' has order {order}", integ.scheme),
        ));
    }
    if dissipative && let Raise::Compose(t) = raise {
        return Err(err(
            SceneErrorKind::Unsupported,
            path.key("scheme"),
            format!(
                "'{}' (order {order}) takes negative sub-steps, which run the damping backwards (energy grows, unstable when stiff); with damping use `order = {order}` or scheme = \"extrapolation\" (every sub-step forward), or switch the damping off with [flags] damping = false",
                t.name
            ),
        ));
    }
    match super::tolerance::control(integ)? {
        Some(control) => {
            super::tolerance::controlled(integ, control, raise, order, dissipative, bodies)
        }
        None => Ok((raise, order)),
    }
}

pub(super) fn plan(integ: &IntegratorSpec, flags: &Flags) -> Result<(RunPlan, bool)> {
    let path = FieldPath::root().key("integrator");
    if integ.step().is_nan() {
        return Err(err(
            SceneErrorKind::Value,
            path.key("dt"),
            "missing: a step size `dt`, or a tolerance (`tol`, `rtol`, `atol`) to have the steps chosen",
        ));
    }
    let dt = positive(integ.step(), &path.key("dt"), "step size")?;
    let t_end = positive(integ.t_end, &path.key("t_end"), "final time")?;
    let (steps, last_step) = step_grid(dt, t_end, &path)?;
    let (mut energy, mut residuals, mut profile) = (false, false, false);
    for d in &integ.diagnostics {
        match d {
            Diagnostic::Energy => energy = true,
            Diagnostic::Constraints => residuals = true,
            Diagnostic::Profile => profile = true,
        }
    }
    Ok((
        RunPlan {
            steps,
            last_step,
            t_end,
            energy: energy && flags.energy,
            residuals: residuals && flags.residuals,
            multipliers: false,
            own_steps: false,
            dense: integ.dense,
        },
        profile,
    ))
}

/// The steps that end a run exactly at `t_end`: `t_end / dt` full steps when `dt` divides
/// `t_end` to within the rounding of the step times (`8 ε (t_end + dt)`, the slack of
/// [`Stepper::advance_to`](crate::stepper::Stepper::advance_to)), otherwise the whole steps that
/// fit and a shorter last one that lands on `t_end`. A step longer than the run is refused.
fn step_grid(dt: f64, t_end: f64, path: &FieldPath) -> Result<(usize, Option<f64>)> {
    if dt > t_end {
        return Err(err(
            SceneErrorKind::Value,
            path.key("dt"),
            format!("the step dt = {dt} is longer than the run (t_end = {t_end})"),
        ));
    }
    let ratio = t_end / dt;
    if ratio > MAX_STEPS as f64 {
        return Err(err(
            SceneErrorKind::Value,
            path.key("dt"),
            format!("t_end / dt = {ratio:.3e} steps, more than {MAX_STEPS:.0e}"),
        ));
    }
    let slack = 8.0 * f64::EPSILON * (t_end + dt);
    let nearest = ratio.round();
    if (t_end - nearest * dt).abs() <= slack {
        return Ok((nearest as usize, None));
    }
    let full = ratio.floor();
    Ok((full as usize, Some(t_end - full * dt)))
}

/// The flow a scene's scheme builds, and what the assembly reports of it.
pub(super) struct SchemeFlow {
    pub(super) flow: Box<dyn Flow<Col<f64>>>,
    /// The scheme's name, before any composition.
    pub(super) name: &'static str,
    /// The paper's case (`degenerate`, `non-degenerate`) when projected.
    pub(super) case: Option<String>,
    /// The projection variant, when projected.
    pub(super) projection: Option<String>,
    /// The multiplier solver, when projected by the splitting.
    pub(super) solver: Option<String>,
    /// The flow is the scene's splitting ([`splitting_flow`]), raised by the scene's `raise`.
    pub(super) split: bool,
    /// What else a reader of `lieflow check` should know about the scheme's choices.
    pub(super) detail: Option<String>,
}

/// Builds the flow of `file`'s splitting scheme for `model` from `x0`: the splitting of the
/// exact sub-flows ([`splitting_flow`]), raised by `raise` (the implicit schemes are built in
/// `implicit.rs`).
pub(super) fn scheme_flow(
    file: &SceneFile,
    model: &Arc<SceneModel>,
    x0: &Col<f64>,
    raise: Raise,
    backward: bool,
) -> Result<SchemeFlow> {
    if file.integrator.scheme == Method::Modified {
        return Err(err(
            SceneErrorKind::Unsupported,
            FieldPath::root().key("integrator").key("scheme"),
            "the §2 scheme (`modified`) is offered for the built-in paper model only",
        ));
    }
    let (flow, name, desc) = splitting_flow(model, x0, raise, backward, f64::EPSILON)
        .map_err(|e| setup_error(model, e))?;
    let (mut case, mut projection, mut solver) = (None, None, None);
    if let Some((scheme, small, kind)) = desc {
        case = Some(
            match scheme {
                Scheme::Symmetric => "non-degenerate",
                _ => "degenerate",
            }
            .to_owned(),
        );
        projection = Some(
            match scheme {
                Scheme::Decoupled => "decoupled",
                Scheme::Coupled => "coupled",
                Scheme::Symmetric => "symmetric",
            }
            .to_owned(),
        );
        solver = Some(if small {
            "small (stack, closed-form Jacobians)".to_owned()
        } else {
            kind
        });
    }
    Ok(SchemeFlow {
        flow,
        name,
        case,
        projection,
        solver,
        split: true,
        detail: None,
    })
}

/// Projection options for a scene: position constraints with forces on the momenta only
/// (`M Gᵀλ = (0, −G_qᵀλ)` whatever the damping and field), so the degenerate case and the
/// decoupled variant hold by construction; naming them skips the dense bracket analysis. The
/// residual tolerance is scaled like the chain's (`16 ε ℓ L`: `ℓ` the smallest constraint
/// length, `L` the scene's extent), the rounding level of `g = (|u|² − ℓ²)/2`.
pub(super) fn projection_options<T: Real>(
    model: &SceneModel<T>,
    x0: &[T],
    eps: T,
) -> ProjectionOptions<T> {
    let nq = model.state_len() / 2;
    let extent = x0[..nq].iter().fold(T::zero(), |a, &b| a.max(b.abs()));
    let mut ell = T::infinity();
    for c in &model.constraints {
        if let Some(l) = c.kind.length() {
            ell = ell.min(l);
        }
    }
    if !ell.is_finite() {
        ell = extent.max(T::one());
    }
    // The scene's own scale, not clamped to 1: a micrometre chain rounds at ε ℓ L with L ~ 1e-5.
    let big = extent.max(ell);
    let big = if big > T::zero() { big } else { T::one() };
    let ftol = T::lit(16.0) * eps * ell * big;
    // `eps` is the scalar's unit round-off: f64's, or ~1e-32 for double-double (whose
    // `epsilon()` is not its round-off), and the defaults' tolerances are rebuilt from it.
    let newton = NewtonOptions::default()
        .with_ftol(ftol)
        .with_xtol(T::lit(16.0) * eps)
        .with_fd_step(eps.sqrt());
    let options = ProjectionOptions::default()
        .with_case(Case::Degenerate)
        .with_coupling(Coupling::Decoupled)
        .with_newton(newton);
    if eps > T::epsilon() {
        // An extended-precision run starts from the f64 state, on the constraints to f64
        // round-off only: the first step projects it (the scene has checked it already).
        options.with_manifold_tol(None)
    } else {
        options
    }
}

/// The splitting of a scene's terms (see the module docs of `scene`): the free flight alone, or
/// `free flight(h/2) ∘ kick(h) ∘ free flight(h/2)` without constraints; with constraints the
/// projection around `kick(h/2) ∘ free flight(h) ∘ kick(h/2)`; raised by `raise`. For any
/// storage and scalar (`eps` its unit round-off): `Col<f64>` for runs, `DVector` of a
/// double-double scalar for references. Returns the flow, its description and, when projected,
/// the projection variant, whether it takes the small path, and its linear solver. `backward`
/// lets a composition run a dissipative sub-flow backwards (reference runs only).
///
/// # Errors
/// The projection's setup errors at `x0` ([`SetupError`]).
pub fn splitting_flow<V: Vector + 'static>(
    model: &Arc<SceneModel<V::Real>>,
    x0: &V,
    raise: Raise,
    backward: bool,
    eps: V::Real,
) -> std::result::Result<Splitting<V>, SetupError> {
    let kick = scene_kick(model)?;
    // The exact free flight (booking the energy a damping removes, exactly, per sub-step).
    let drift = match consistent_account(model) {
        // Damped bodies on constraints: the damping booked on the motion they allow.
        Some(account) => FreeFlight::new(model.clone()).with_account(account),
        None => FreeFlight::new(model.clone()),
    };
    assemble(model, x0, raise, backward, eps, kick, drift)
}

/// [`splitting_flow`] in `f64` on a heap column, the storage of every scene of more than three
/// bodies: a non-generic entry (compiled once, in the library) for callers that compare it with
/// a compiled scene's run.
///
/// # Errors
/// The projection's setup errors at `x0` ([`SetupError`]).
pub fn heap_splitting(
    model: &Arc<SceneModel>,
    x0: &Col<f64>,
    raise: Raise,
    backward: bool,
) -> std::result::Result<Splitting<Col<f64>>, SetupError> {
    splitting_flow(model, x0, raise, backward, f64::EPSILON)
}

/// The scene's kick (see [`SceneKick`]): the potential's alone, or composed with the dashpots
/// and the inputs the scene declares.
fn scene_kick<V: Vector + 'static>(
    model: &Arc<SceneModel<V::Real>>,
) -> std::result::Result<SceneKick<V>, SetupError> {
    // Dashpots couple bodies, so their flow is not part of the per-body flight: it joins the
    // kick as `D(τ/2) ∘ K(τ) ∘ D(τ/2)` (the dashpots alone without a kick), a symmetric
    // composition of exact flows.
    let dashpots = DashpotFlow::new(model.clone()).map(|dashpots| {
        // On constrained bodies the dashpots book their dissipation on the consistent motion.
        match consistent_momentum(model) {
            Some(account) => dashpots.with_account(account),
            None => dashpots,
        }
    });
    // Hinge dampers likewise: `J(τ/2) ∘ … ∘ J(τ/2)` around the rest of the kick.
    let joints = HingeDamperFlow::new(model.clone());
    if joints.as_ref().is_some_and(|j| !j.is_consistent()) {
        return Err(SetupError::InvalidParameter {
            name: "joint damper (hinge-damper, slider-damper)".to_owned(),
            value: f64::NAN,
            requirement: "a constrained scene in f64: the damper's constraint-consistent direction is formed with the scene's f64 Gram matrix (a reference run in another scalar is not supported)",
        });
    }
    let dampers: Option<Box<dyn Flow<V>>> = match (dashpots, joints) {
        (Some(d), Some(j)) => Some(Box::new(d.strang(j))),
        (Some(d), None) => Some(Box::new(d)),
        (None, Some(j)) => Some(Box::new(j)),
        (None, None) => None,
    };
    // The inputs are forces on the bodies: a kick, like the potential's, side by side with it
    // (`K(τ/2) ∘ U(τ) ∘ K(τ/2)`); their sub-flow carries the time and books the energy supplied.
    let forces: Option<Box<dyn Flow<V>>> = match model.inputs.as_ref() {
        None => None,
        Some(inputs) => {
            let input = InputFlow::try_new(inputs.map.clone(), inputs.signals.clone())?
                .kick()
                .supplying(model.clone());
            Some(if model.has_kick() {
                Box::new(Kick::new(model.clone()).strang(input))
            } else {
                Box::new(input)
            })
        }
    };
    // The dampers around the forces, `D(τ/2) ∘ F(τ) ∘ D(τ/2)`: forces that balance at rest (a
    // servo's spring and motor torque) then leave the momenta at zero, which a damper's flow
    // between them would not.
    Ok(match (dampers, forces) {
        (Some(d), Some(f)) => SceneKick::Composed(Box::new(d.strang(f))),
        (Some(d), None) if model.has_kick() => {
            SceneKick::Composed(Box::new(d.strang(Kick::new(model.clone()))))
        }
        (Some(d), None) => SceneKick::Composed(d),
        (None, Some(f)) => SceneKick::Composed(f),
        (None, None) => SceneKick::potential(model.clone()),
    })
}

/// The splitting of a kick (with the inputs, when the model has any) and a drift, projected
/// when constrained.
fn assemble<V: Vector + 'static>(
    model: &Arc<SceneModel<V::Real>>,
    x0: &V,
    raise: Raise,
    backward: bool,
    eps: V::Real,
    kick: SceneKick<V>,
    drift: FreeFlight<V::Real>,
) -> std::result::Result<Splitting<V>, SetupError> {
    let forced = model.inputs.is_some();
    let dampers = model.has_dashpots() || model.has_hinge_dampers();
    let has_potential = model.has_kick() || forced || dampers;
    if model.m == 0 {
        return Ok(if has_potential {
            (
                raised::<_, _, SceneSystem<V::Real>>(drift.strang(kick), raise, backward, None)?,
                match (forced, dampers) {
                    (true, _) => "free flight ∘ kick and inputs ∘ free flight (Strang)",
                    (false, true) => "free flight ∘ kick and dampers ∘ free flight (Strang)",
                    (false, false) => "free flight ∘ kick ∘ free flight (Strang)",
                },
                None,
            )
        } else if model.gravity_in_flight() {
            (Box::new(drift), "free flight under gravity (exact)", None)
        } else {
            (Box::new(drift), "free flight (exact)", None)
        });
    }
    let system = System::new(model.clone(), model.clone(), model.clone());
    let options = projection_options(model, x0.as_slice(), eps);
    let (splitting, name) = if has_potential {
        (
            SceneSplitting::Kicked(kick.strang(drift)),
            match (forced, dampers) {
                (true, _) => {
                    "projection around kick and inputs ∘ free flight ∘ kick and inputs (Strang, RATTLE)"
                }
                (false, true) => {
                    "projection around kick and dampers ∘ free flight ∘ kick and dampers (Strang, RATTLE)"
                }
                (false, false) => "projection around kick ∘ free flight ∘ kick (Strang, RATTLE)",
            },
        )
    } else if model.gravity_in_flight() {
        (
            SceneSplitting::Drift(drift),
            "projection around free flight under gravity (exact)",
        )
    } else {
        (
            SceneSplitting::Drift(drift),
            "projection around free flight (exact)",
        )
    };
    let p = splitting.projected(system.clone(), x0, options)?;
    boxed_projection(p, raise, backward, (system, x0, options), name)
}

/// A scene's splitting: the flow, its description and, when projected, the projection variant,
/// whether it takes the small path, and its linear solver.
pub type Splitting<V> = (
    Box<dyn Flow<V>>,
    &'static str,
    Option<(Scheme, bool, String)>,
);

/// A scene model as a [`System`] (the three parts share one model).
pub(super) type SceneSystem<T> = System<Arc<SceneModel<T>>, Arc<SceneModel<T>>, Arc<SceneModel<T>>>;

/// A scene's projected flow, raised and boxed (re-projected onto `onto` when extrapolated),
/// with its description and what it assembled.
pub(super) fn boxed_projection<V, F>(
    p: Projected<V, F, SceneSystem<V::Real>>,
    raise: Raise,
    backward: bool,
    onto: (SceneSystem<V::Real>, &V, ProjectionOptions<V::Real>),
    name: &'static str,
) -> std::result::Result<Splitting<V>, SetupError>
where
    V: Vector + 'static,
    F: Flow<V> + 'static,
{
    let desc = (
        p.scheme(),
        p.uses_small_path(),
        format!("{:?}", p.newton().linear_solver().kind()),
    );
    Ok((raised(p, raise, backward, Some(onto))?, name, Some(desc)))
}

/// `flow`, or its composition by `table`, boxed (the built-in models).
pub(super) fn with_table<V: Vector + 'static, F: Flow<V> + 'static>(
    flow: F,
    table: Option<&'static CompositionTable>,
) -> Box<dyn Flow<V>> {
    match table {
        None => Box::new(flow),
        Some(t) => Box::new(flow.composed(t)),
    }
}
