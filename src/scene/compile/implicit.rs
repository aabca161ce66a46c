//! The implicit schemes of a scene — Petrov–Galerkin, the discrete gradient and the (projected)
//! implicit midpoint rule — each with the scene's inputs in its residual when it declares any.

use super::raise::{Raise, raised};
use super::scheme::{SceneSystem, SchemeFlow, projection_options};
use super::{Result, constraints::setup_error, err};
use crate::error::SetupError;
use crate::flow::{
    ConstrainedDiscreteGradient, DiscreteGradient, Flow, ImplicitMidpoint, PetrovGalerkin,
    ProjectedMidpoint,
};
use crate::nonlinear::NewtonOptions;
use crate::scene::error::{FieldPath, SceneErrorKind};
use crate::scene::model::SceneModel;
use crate::scene::schema::{Method, SceneFile};
use crate::system::{Hamiltonian, MechanicalForm, System};
use crate::vector::Vector;
use faer::Col;
use std::sync::Arc;

/// A scheme's flow with what `lieflow check` reports of it (no projection variant or
/// multiplier solver: those are the splitting's).
fn scheme(
    flow: Box<dyn Flow<Col<f64>>>,
    name: &'static str,
    constrained: bool,
    detail: Option<String>,
) -> SchemeFlow {
    SchemeFlow {
        flow,
        name,
        case: constrained.then(|| "degenerate".to_owned()),
        projection: None,
        solver: None,
        split: false,
        detail,
    }
}

/// The flow of `file`'s scheme when it is an implicit one (`None` for the splittings).
pub(super) fn implicit_flow(
    file: &SceneFile,
    model: &Arc<SceneModel>,
    x0: &Col<f64>,
    raise: Raise,
    backward: bool,
) -> Option<Result<SchemeFlow>> {
    let implicit = matches!(
        file.integrator.scheme,
        Method::PetrovGalerkin | Method::DiscreteGradient | Method::Midpoint
    );
    if implicit && model.has_hinge_dampers() {
        return Some(Err(err(
            SceneErrorKind::Unsupported,
            FieldPath::root().key("integrator").key("scheme"),
            format!(
                "'{}' does not take hinge or slider dampers: their exact flow along the constraint-consistent direction joins the splitting's kick, and the implicit schemes' M does not hold them; use scheme = \"auto\" (order 2) or \"extrapolation\" (order 4 and up)",
                file.integrator.scheme
            ),
        )));
    }
    let built = match file.integrator.scheme {
        Method::PetrovGalerkin => petrov_galerkin(file, model, x0),
        Method::DiscreteGradient => discrete_gradient(model, x0),
        Method::Midpoint => return Some(midpoint(model, x0, raise, backward)),
        _ => return None,
    };
    // A tolerance: the scheme's steps chosen by step doubling (`raise` is the base step or
    // that; the choice of scheme refuses the others).
    Some(built.and_then(|mut s| {
        if let Raise::Doubling(..) = raise {
            s.flow = raised::<_, _, SceneSystem<f64>>(s.flow, raise, backward, None)
                .map_err(|e| setup_error(model, e))?;
        }
        Ok(s)
    }))
}

/// The energy-consistent Petrov–Galerkin scheme at the file's order (4 by default).
fn petrov_galerkin(file: &SceneFile, model: &Arc<SceneModel>, x0: &Col<f64>) -> Result<SchemeFlow> {
    let order = file.integrator.order.unwrap_or(4);
    let system = System::new(model.clone(), model.clone(), model.clone());
    let options = projection_options(model, x0.as_slice(), f64::EPSILON);
    let mut pg = PetrovGalerkin::<Col<f64>, _>::try_new(system, x0, order, options)
        .map_err(|e| setup_error(model, e))?;
    if let Some(inputs) = model.inputs.as_ref() {
        // The inputs' forces in its residual, their work booked as supplied.
        pg = pg
            .with_inputs(inputs.map.clone(), inputs.signals.clone())
            .map_err(|e| setup_error(model, e))?;
    }
    let points = pg.quadrature_points();
    let gauss = if points == 1 {
        "1 Gauss point".to_owned()
    } else {
        format!("{points} Gauss points")
    };
    let detail = if Hamiltonian::<Col<f64>>::is_quadratic(model) {
        format!(
            "{gauss} a residual: H and any constraints are quadratic, so these integrate every term exactly"
        )
    } else {
        format!(
            "{gauss} a residual (k + 2): the potential is not a polynomial, so its energy balance holds to a quadrature error O(h^{})",
            2 * points + 1
        )
    };
    Ok(scheme(
        Box::new(pg),
        "energy-consistent Petrov–Galerkin with hidden-constraint projection",
        model.m > 0,
        Some(detail),
    ))
}

/// Gonzalez's discrete gradient, constrained when the scene is.
fn discrete_gradient(model: &Arc<SceneModel>, x0: &Col<f64>) -> Result<SchemeFlow> {
    let setup = |e: SetupError| setup_error(model, e);
    let m = model.m;
    let system = System::new(model.clone(), model.clone(), model.clone());
    if m == 0 && !matches!(MechanicalForm::of(&system, model, x0), Ok(Some(_))) {
        if model.inputs.is_some() {
            return Err(setup(SetupError::Scheme {
                what: "the discrete gradient takes inputs on a model of mechanical form only"
                    .to_owned(),
            }));
        }
        let dg = DiscreteGradient::<Col<f64>, Arc<SceneModel>, Arc<SceneModel>>::try_new(
            model.clone(),
            model.clone(),
            x0,
            NewtonOptions::default(),
        )
        .map_err(setup)?;
        return Ok(scheme(
            Box::new(dg),
            "discrete gradient (Gonzalez)",
            false,
            None,
        ));
    }
    // On a model of mechanical form (every scene), with or without constraints, the momenta
    // eliminated and the positions (and multipliers) solved with the model's sparsity; without
    // constraints it is Gonzalez's step block by block.
    let name = if m == 0 {
        "discrete gradient (Gonzalez)"
    } else {
        "constrained discrete gradient (Gonzalez) with hidden-constraint projection"
    };
    let options = projection_options(model, x0.as_slice(), f64::EPSILON);
    let mut dg =
        ConstrainedDiscreteGradient::<Col<f64>, _>::try_new(system, x0, options).map_err(setup)?;
    if let Some(inputs) = model.inputs.as_ref() {
        // The inputs' impulse at the step's midpoint, their work booked as supplied.
        dg = dg
            .with_inputs(inputs.map.clone(), inputs.signals.clone())
            .map_err(setup)?;
    }
    Ok(scheme(Box::new(dg), name, m > 0, None))
}

/// The implicit midpoint rule for all of `H` under `M`, projected when there are constraints:
/// the §3 scheme with a general inner flow, raised by `raise`.
fn midpoint(
    model: &Arc<SceneModel>,
    x0: &Col<f64>,
    raise: Raise,
    backward: bool,
) -> Result<SchemeFlow> {
    let setup = |e: SetupError| setup_error(model, e);
    let system = || System::new(model.clone(), model.clone(), model.clone());
    let options = projection_options(model, x0.as_slice(), f64::EPSILON);
    let joint = ProjectedMidpoint::<Col<f64>, _, _>::try_new(system(), model.clone(), x0, options);
    if model.m == 0 {
        // A model of mechanical form (every scene) takes the momenta eliminated and the
        // positions solved with its sparsity (`ProjectedMidpoint` without constraints is the
        // midpoint rule itself); dense Newton on all `n` unknowns otherwise.
        let flow = match joint {
            Ok(reduced) => {
                let reduced = with_midpoint_inputs(reduced, model).map_err(setup)?;
                raised::<_, _, SceneSystem<f64>>(reduced, raise, backward, None)
            }
            Err(SetupError::Dimension { .. }) if model.inputs.is_some() => {
                return Err(setup(SetupError::Scheme {
                    what:
                        "the implicit midpoint rule takes inputs on a model of mechanical form only"
                            .to_owned(),
                }));
            }
            Err(SetupError::Dimension { .. }) => {
                let midpoint =
                    ImplicitMidpoint::<Col<f64>, Arc<SceneModel>, Arc<SceneModel>>::try_new(
                        model.clone(),
                        model.clone(),
                        x0,
                        NewtonOptions::default(),
                    )
                    .map_err(setup)?;
                raised::<_, _, SceneSystem<f64>>(midpoint, raise, backward, None)
            }
            Err(e) => return Err(setup(e)),
        }
        .map_err(setup)?;
        return Ok(scheme(flow, "implicit midpoint rule", false, None));
    }
    // The midpoint increment and λ_k as one Newton system (the decoupled case, which a scene's
    // position constraints are): a scene's model has a mechanical form, so the joint system is
    // solved on the positions and multipliers with its sparsity at any size. The projection
    // around a separate midpoint solve (`Projected` around `ImplicitMidpoint`) is the
    // library's path for models without that form; a scene never needs it, and it is not
    // compiled for scenes.
    let joint = joint.map_err(|e| match e {
        SetupError::Dimension { what } => err(
            SceneErrorKind::Unsupported,
            FieldPath::root().key("integrator").key("scheme"),
            format!("the projected midpoint rule does not apply to this scene: {what}"),
        ),
        e => setup(e),
    })?;
    let joint = with_midpoint_inputs(joint, model).map_err(setup)?;
    let flow = raised(joint, raise, backward, Some((system(), x0, options))).map_err(setup)?;
    Ok(scheme(
        flow,
        "projection around the implicit midpoint rule",
        true,
        None,
    ))
}

/// The projected midpoint rule with the scene's inputs, when it declares any: their forces at
/// the step's midpoint in its residual, their work booked as supplied.
fn with_midpoint_inputs<K, L>(
    flow: ProjectedMidpoint<Col<f64>, SceneSystem<f64>, K, L>,
    model: &SceneModel,
) -> std::result::Result<ProjectedMidpoint<Col<f64>, SceneSystem<f64>, K, L>, SetupError>
where
    K: crate::system::Hamiltonian<Col<f64>>,
    L: crate::linalg::LinearSolver<f64>,
{
    match model.inputs.as_ref() {
        Some(inputs) => flow.with_inputs(inputs.map.clone(), inputs.signals.clone()),
        None => Ok(flow),
    }
}
