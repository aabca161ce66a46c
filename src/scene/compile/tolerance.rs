//! A scene's tolerance (`integrator.tol`, `rtol`, `atol`, the step limits) and the controller
//! that meets it: the adaptive extrapolation of the splitting, step doubling of a named
//! fixed-order scheme, or reversible steps along a density.

use super::density::compile_density;
use super::raise::{Control, Raise};
use super::{Result, err, validate::positive};
use crate::scene::bodies::Bodies;
use crate::scene::error::{FieldPath, SceneErrorKind};
use crate::scene::schema::{Controller, IntegratorSpec, Method};

/// The scene's tolerance, when it gives one: `tol`, or `rtol` and `atol` (each defaulting to
/// the other, or to `tol`), with the step limits. The keys that go with a tolerance are
/// refused without one.
pub(super) fn control(integ: &IntegratorSpec) -> Result<Option<Control>> {
    let path = FieldPath::root().key("integrator");
    let given = integ.tol.or(integ.rtol).or(integ.atol);
    let Some(tol) = given else {
        for (key, set) in [
            ("h_min", integ.h_min.is_some()),
            ("h_max", integ.h_max.is_some()),
            ("max_order", integ.max_order.is_some()),
            ("controller", integ.controller.is_some()),
            ("density", integ.density.is_some()),
            ("dense", integ.dense),
        ] {
            if set {
                return Err(err(
                    SceneErrorKind::Value,
                    path.key(key),
                    format!("`{key}` goes with a tolerance (`tol`, or `rtol` and `atol`)"),
                ));
            }
        }
        return Ok(None);
    };
    let key = if integ.tol.is_some() {
        "tol"
    } else if integ.rtol.is_some() {
        "rtol"
    } else {
        "atol"
    };
    let tolerance = |v: Option<f64>, name: &str| -> Result<f64> {
        let v = v.or(integ.tol).unwrap_or(tol);
        if v > 0.0 && v.is_finite() {
            Ok(v)
        } else {
            Err(err(
                SceneErrorKind::Value,
                path.key(if v == tol { key } else { name }),
                format!("a tolerance is positive and finite, not {v}"),
            ))
        }
    };
    let (rtol, atol) = (
        tolerance(integ.rtol, "rtol")?,
        tolerance(integ.atol, "atol")?,
    );
    let dt = positive(integ.step(), &path.key("dt"), "step size")?;
    let h_min = match integ.h_min {
        None => 0.0,
        Some(h) if h >= 0.0 && h < dt => h,
        Some(h) => {
            return Err(err(
                SceneErrorKind::Value,
                path.key("h_min"),
                format!("h_min {h}: non-negative and below dt = {dt}"),
            ));
        }
    };
    let h_max = match integ.h_max {
        None if integ.dense => f64::INFINITY,
        None => dt,
        Some(h) => positive(h, &path.key("h_max"), "largest step")?,
    };
    let max_order = integ.max_order.unwrap_or(16);
    if !max_order.is_multiple_of(2) || !(4..=16).contains(&max_order) {
        return Err(err(
            SceneErrorKind::Value,
            path.key("max_order"),
            format!(
                "max_order {max_order}: the adaptive extrapolation reaches the even orders 4 to 16"
            ),
        ));
    }
    Ok(Some(Control {
        rtol,
        atol,
        h_min,
        h_max,
        max_order,
        scales: Vec::new(),
        resolve: None,
        breakpoints: Vec::new(),
        dense: integ.dense,
    }))
}

/// The raise that meets a scene's tolerance with the scheme it names (`raise` at `order`, as
/// chosen without the tolerance), and the order reported.
///
/// `controller = "error"` (default): `auto` and `extrapolation` extrapolate adaptively (the
/// order chosen, up to `max_order`); a named fixed-order scheme (a composition, Strang, the
/// implicit schemes) keeps its order and its steps are chosen by step doubling.
/// `controller = "reversible"`: the splitting or its composition, not damped, with reversible
/// steps along `density`.
pub(super) fn controlled(
    integ: &IntegratorSpec,
    control: Control,
    raise: Raise,
    order: u32,
    dissipative: bool,
    bodies: Option<&Bodies>,
) -> Result<(Raise, u32)> {
    let path = FieldPath::root().key("integrator");
    let mut control = control;
    if let Some(bodies) = bodies {
        // Momenta p = m v: their absolute tolerance is atol times the slot's mass, so that
        // `atol` holds velocities as it holds positions (a planet of mass 1e-3 would otherwise
        // have its velocity held to 1e3 atol).
        let d = bodies.dim;
        let mut scales = vec![1.0; bodies.list.len() * d];
        scales.extend(
            bodies
                .list
                .iter()
                .flat_map(|b| std::iter::repeat_n(b.mass, d)),
        );
        control.scales = scales;
    }
    let extrapolates = matches!(integ.scheme, Method::Auto | Method::Extrapolation);
    let controller = integ.controller.unwrap_or(Controller::Error);
    if integ.max_order.is_some() && !(extrapolates && controller == Controller::Error) {
        return Err(err(
            SceneErrorKind::Value,
            path.key("max_order"),
            "`max_order` bounds the adaptive extrapolation (`scheme = \"auto\"` or `\"extrapolation\"` with the error controller); this scheme keeps its order",
        ));
    }
    if integ.dense && !(extrapolates && controller == Controller::Error) {
        return Err(err(
            SceneErrorKind::Unsupported,
            path.key("dense"),
            "dense output is the adaptive extrapolation's (`scheme = \"auto\"` or `\"extrapolation\"` with the error controller)",
        ));
    }
    if integ.density.is_some() && controller != Controller::Reversible {
        return Err(err(
            SceneErrorKind::Value,
            path.key("density"),
            "`density` goes with `controller = \"reversible\"`",
        ));
    }
    match controller {
        Controller::Error if extrapolates => {
            if integ.order.is_some() {
                return Err(err(
                    SceneErrorKind::Value,
                    path.key("order"),
                    "with a tolerance the adaptive extrapolation chooses the order: give `max_order` instead (or name a scheme of fixed order)",
                ));
            }
            let max_order = control.max_order;
            Ok((Raise::Adaptive(control), max_order))
        }
        Controller::Error => match raise {
            Raise::Base | Raise::Compose(_) => Ok((Raise::Doubling(control, raise.table()), order)),
            _ => Err(err(
                SceneErrorKind::Unsupported,
                path.key("scheme"),
                format!("'{}' takes no tolerance", integ.scheme),
            )),
        },
        Controller::Reversible => {
            let at = path.key("controller");
            if dissipative {
                return Err(err(
                    SceneErrorKind::Unsupported,
                    at,
                    "the reversible controller is for conservative runs, and this scene dissipates (damping, dashpots or joint dampers): run backwards its damping would add energy; use `controller = \"error\"`",
                ));
            }
            let splitting = matches!(integ.scheme, Method::Auto | Method::Strang)
                || integ.scheme.composition().is_some();
            if !splitting || !matches!(raise, Raise::Base | Raise::Compose(_)) {
                return Err(err(
                    SceneErrorKind::Unsupported,
                    at,
                    format!(
                        "the reversible controller steps the symmetric splitting or its composition (`scheme = \"auto\"` up to order 8, `\"strang\"` or a composition by name), not '{}'",
                        integ.scheme
                    ),
                ));
            }
            let spec = integ.density.as_ref().ok_or_else(|| {
                err(
                    SceneErrorKind::Value,
                    at.clone(),
                    "the reversible controller steps along a `density`, e.g. `density = { distance = [\"sun\", \"planet\"], power = 1.5 }`",
                )
            })?;
            let bodies = bodies.ok_or_else(|| {
                err(
                    SceneErrorKind::Unsupported,
                    path.key("density"),
                    "a density names bodies; the built-in models have none",
                )
            })?;
            let density = compile_density(spec, bodies, &path.key("density"))?;
            Ok((Raise::Reversible(control, density, raise.table()), order))
        }
    }
}
