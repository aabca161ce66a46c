//! The reference solution of a set: the closed form of the paper's example, Kahan–Li 8 in
//! double-double arithmetic for scenes of bodies, or Richardson-extrapolated double runs.

use super::plan::{PrecisionPlan, Reference, distance, final_time, with_scheme};
use lieflow::models::paper;
use lieflow::scene::schema::Method;
use lieflow::scene::{RunPlan, run};
use lieflow::scene::{Scene, SceneError};

/// The reference: the closed form for the paper's example, the initial state when the plan
/// says the motion is periodic over the run ([`PrecisionPlan::periodic`]); otherwise Kahan–Li 8 around the
/// scene's splitting (backward damping sub-steps allowed for this run) at steps dividing `T`
/// near `h_min/4` and `h_min/8` in double-double for scenes of at most [`DD_MAX_DIM`] state
/// entries (when the plan asks), else at `h_min/8` and `h_min/16` in double precision, or if
/// that fails Strang at `h_min/64` and `/128` with Richardson extrapolation. Its error estimate
/// is the truncation estimate from the two runs plus the round-off they accumulate; the
/// double-double one does not see errors of twofloat's own transcendental functions, which are
/// not correctly rounded (they are far below f64's resolution).
pub fn reference(scene: &Scene, plan: &PrecisionPlan) -> Result<Reference, SceneError> {
    let t = final_time(scene);
    if scene
        .file
        .builtin
        .as_ref()
        .is_some_and(|b| b.model == "paper")
    {
        return Ok(Reference {
            x: paper::exact(t, -0.15).to_vec(),
            t,
            source: "closed form (models::paper::exact)".into(),
            error_estimate: None,
        });
    }
    if plan.periodic {
        // A periodic motion over whole periods ends where it started: its initial state is
        // the exact final state (a Kepler orbit with its centre of mass at rest, say).
        let c = scene.compile()?;
        return Ok(Reference {
            x: c.simulation.state().to_vec(),
            t,
            source: "closed form: the initial state (a periodic motion over whole periods)".into(),
            error_estimate: None,
        });
    }
    let h_min = plan.dts.iter().copied().fold(f64::INFINITY, f64::min);
    let at_order = |scheme: Method, order: Option<u32>, h: f64| -> Result<Vec<f64>, SceneError> {
        let mut c = lieflow::scene::compile_reference(&with_scheme(scene, scheme, order, h).file)?;
        let quiet = RunPlan {
            energy: false,
            residuals: false,
            ..c.plan
        };
        let s = run(c.simulation.as_mut(), &quiet, &mut |_| {});
        match s.error {
            None => Ok(s.x),
            Some(f) => Err(SceneError::new(
                lieflow::scene::SceneErrorKind::Setup,
                lieflow::scene::FieldPath::root(),
                format!(
                    "the reference run ({scheme}, h = {h:e}) failed at step {}: {}",
                    f.step, f.message
                ),
            )),
        }
    };
    let at = |scheme: Method, h: f64| at_order(scheme, None, h);
    if plan.implicit_reference && scene.file.builtin.is_none() {
        // Order 6 at h and h/2: the gap over 2⁶ − 1, plus the round-off of the finer run.
        let h = dividing(t, h_min / 8.0);
        let coarse = at_order(Method::PetrovGalerkin, Some(6), h)?;
        let fine = at_order(Method::PetrovGalerkin, Some(6), h / 2.0)?;
        let roundoff = f64::EPSILON * (2.0 * t / h) * state_scale(&fine);
        return Ok(Reference {
            error_estimate: Some(distance(&coarse, &fine) / 63.0 + roundoff),
            x: fine,
            t,
            source: format!(
                "Petrov–Galerkin order 6 at h = {:.3e} (checked against 2h)",
                h / 2.0
            ),
        });
    }
    // A scene of bodies small enough: an order-8 scheme in double-double at h_min/4 and h_min/8
    // — Kahan–Li 8, or with damping Strang extrapolated to order 8 (every sub-step forward, so
    // stiff damping is as safe for the reference as for the runs it judges).
    if scene.file.builtin.is_none() {
        let compiled = scene.compile()?;
        if plan.double_double && compiled.assembly.state_len <= DD_MAX_DIM {
            let model = compiled.model.expect("a scene of bodies has a model");
            let x0 = compiled.simulation.state().to_vec();
            let damped = compiled.assembly.dissipative;
            let dd = |h: f64| double_double_run(&model, &x0, t, h, damped);
            let h = dividing(t, h_min / 4.0);
            match (dd(h), dd(h / 2.0)) {
                (Ok(coarse), Ok(fine)) => {
                    use lieflow::Real as _;
                    // The estimate in double-double: the two runs agree far below f64's
                    // resolution, which rounding them first would hide.
                    let diff = coarse
                        .iter()
                        .zip(&fine)
                        .fold(0.0f64, |m, (c, f)| m.max((*c - *f).abs().to_f64_lossy()));
                    return Ok(Reference {
                        // Truncation (Kahan–Li 8: the gap over 2⁸ − 1) plus the double-double
                        // round-off of the finer run's steps.
                        error_estimate: Some(
                            diff / 255.0 + 1e-31 * (2.0 * t / h) * state_scale(&x0),
                        ),
                        x: fine.iter().map(|v| v.to_f64_lossy()).collect(),
                        t,
                        source: format!(
                            "{} in double-double (twofloat) at h = {:.3e} (checked against 2h)",
                            if damped {
                                "Strang extrapolated to order 8"
                            } else {
                                "kahan-li8"
                            },
                            h / 2.0
                        ),
                    });
                }
                (Err(e), _) | (_, Err(e)) => {
                    // Fall through to double precision, saying why in the source.
                    let mut r = f64_reference(h_min, t, &at)?;
                    r.source = format!("{} (double-double run failed: {e})", r.source);
                    return Ok(r);
                }
            }
        }
    }
    f64_reference(h_min, t, &at)
}

/// The step nearest below `h` that divides `t` (`t / ⌈t/h⌉`).
pub(crate) fn dividing(t: f64, h: f64) -> f64 {
    t / (t / h).ceil()
}

/// `max(1, max |x_i|)`.
pub(crate) fn state_scale(x: &[f64]) -> f64 {
    x.iter().fold(1.0f64, |a, v| a.max(v.abs()))
}

/// The largest scene state given a double-double reference (its arithmetic costs ~20× f64).
pub const DD_MAX_DIM: usize = 400;

/// Kahan–Li 8 around the scene's splitting — with damping (`damped`) the splitting extrapolated
/// to order 8 instead, every sub-step forward — in double-double from `x0` to `t` in steps of
/// about `h` (exactly `t / round(t/h)` in double-double); the final state.
pub(crate) fn double_double_run(
    model: &std::sync::Arc<lieflow::scene::SceneModel>,
    x0: &[f64],
    t: f64,
    h: f64,
    damped: bool,
) -> Result<Vec<twofloat::TwoFloat>, String> {
    let raise = if damped {
        lieflow::scene::Raise::Extrapolate(8)
    } else {
        let table = lieflow::flow::coefficients::table_by_name("kahan-li8").expect("a table");
        lieflow::scene::Raise::Compose(table)
    };
    let steps = (t / h).round().max(1.0) as usize;
    double_double_splitting(model, x0, t, steps, raise, !damped)
}

/// The scene's splitting raised by `raise` in double-double arithmetic (twofloat, unit
/// round-off ~2⁻¹⁰⁶), `steps` equal steps from `x0` to `t`: the final state. `backward` lets a
/// composition run a mild damping backwards (references only). The one place the
/// double-double splitting is compiled: every reference and test that needs it calls this.
///
/// # Errors
/// The splitting's setup error or the failed step, as text.
pub fn double_double_splitting(
    model: &std::sync::Arc<lieflow::scene::SceneModel>,
    x0: &[f64],
    t: f64,
    steps: usize,
    raise: lieflow::scene::Raise,
    backward: bool,
) -> Result<Vec<twofloat::TwoFloat>, String> {
    use lieflow::Real;
    use twofloat::TwoFloat;
    type V = nalgebra::DVector<TwoFloat>;
    let dd = std::sync::Arc::new(model.with_scalar::<TwoFloat>());
    let mut x = V::from_iterator(x0.len(), x0.iter().map(|&v| TwoFloat::lit(v)));
    // twofloat's `epsilon()` is f64::MIN_POSITIVE; its unit round-off is ~2^-106.
    let eps = TwoFloat::lit(1e-31);
    let (mut flow, _, _) =
        lieflow::scene::splitting_flow(&dd, &x, raise, backward, eps).map_err(|e| e.to_string())?;
    let steps = steps.max(1);
    let step = TwoFloat::lit(t) / TwoFloat::lit(steps as f64);
    lieflow::integrate(&mut flow, &mut x, TwoFloat::lit(0.0), step, steps, &mut ())
        .map_err(|e| e.to_string())?;
    Ok(x.iter().copied().collect())
}

/// A reference run: the final state of the scene with the named scheme at a step size.
pub(crate) type RunAt<'a> = dyn Fn(Method, f64) -> Result<Vec<f64>, SceneError> + 'a;

/// The double-precision reference: Kahan–Li 8 at `h_min/8` and `/16`, or, if that fails (stiff
/// damping), Strang at `h_min/64` and `/128`, Richardson-extrapolated.
pub(crate) fn f64_reference(h_min: f64, t: f64, at: &RunAt<'_>) -> Result<Reference, SceneError> {
    let h = dividing(t, h_min / 8.0);
    if let (Ok(coarse), Ok(fine)) = (at(Method::KahanLi8, h), at(Method::KahanLi8, h / 2.0)) {
        // In f64 the gap of the two runs is mostly round-off, not truncation: the gap itself,
        // plus the round-off the finer run accumulates.
        let roundoff = f64::EPSILON * (2.0 * t / h) * state_scale(&fine);
        return Ok(Reference {
            error_estimate: Some(distance(&coarse, &fine) + roundoff),
            x: fine,
            t,
            source: format!("kahan-li8 at h = {:.3e} (checked against 2h)", h / 2.0),
        });
    }
    let h = dividing(t, h_min / 64.0);
    let coarse = at(Method::Strang, h)?;
    let fine = at(Method::Strang, h / 2.0)?;
    // Richardson: x(h/2) + (x(h/2) − x(h))/3 removes the h² term; the finer run's own error,
    // |x(h) − x(h/2)|/3, bounds the extrapolated one up to the next term.
    let x = fine
        .iter()
        .zip(&coarse)
        .map(|(f, c)| f + (f - c) / 3.0)
        .collect();
    Ok(Reference {
        error_estimate: Some(
            distance(&coarse, &fine) / 3.0 + f64::EPSILON * (2.0 * t / h) * state_scale(&fine),
        ),
        x,
        t,
        source: format!("strang at h = {h:.3e} and h/2, Richardson-extrapolated"),
    })
}
