//! Work–precision: what accuracy costs in time, over step sizes and orders, against a
//! reference and against solvers a user would otherwise take.
//!
//! [`work_precision`] runs a scene with every scheme of a [`PrecisionPlan`] at every step size
//! (and the peers at every tolerance) and returns one [`PrecisionRow`] per run: the error at the
//! final time against a [`Reference`], `max |g|` and `max |φ|` over the run, the energy error
//! (the energy budget's error with damping), the work counters, and the time — one warm-up run
//! (which also observes the diagnostics), then the minimum and median of `repeats` timed runs
//! with nothing observed, as DiffEqDevTools' `WorkPrecisionSet` does. A run that fails is a row
//! with its error kind, never a panic.

use lieflow::models::paper;
use lieflow::scene::{RunPlan, run};
use lieflow::scene::{Scene, SceneError};
use serde::Serialize;

pub use lieflow::scene::DENSE_MAX_DIM;

/// What to run.
#[derive(Debug, Clone, PartialEq)]
pub struct PrecisionPlan {
    /// Step sizes for every lieflow scheme.
    pub dts: Vec<f64>,
    /// Composition orders of the projected splitting (2 = Strang; 4, 6, 8 = Suzuki 4,
    /// Kahan–Li 6, Kahan–Li 8). Orders above 2 are skipped (with a row saying so) for scenes
    /// with damping.
    pub orders: Vec<u32>,
    /// Also run the discrete gradient (scenes of bodies).
    pub discrete_gradient: bool,
    /// Also run the projection around the implicit midpoint rule (scenes with a state of at
    /// most [`DENSE_MAX_DIM`], the paper's model).
    pub midpoint: bool,
    /// Also run the paper's §2 scheme (the built-in paper model only).
    pub modified: bool,
    /// Tolerances (`rtol = atol`) for the peers.
    pub tolerances: Vec<f64>,
    /// Run the peers (needs the `peers` feature; otherwise no peer rows).
    pub peers: bool,
    /// Timed runs after the warm-up.
    pub repeats: usize,
    /// Compute the reference in double-double for scenes of at most [`DD_MAX_DIM`] (else in
    /// double precision).
    pub double_double: bool,
}

impl PrecisionPlan {
    /// Four step sizes `dt · 2^k`, the largest `k ≤ 3` whose steps divide `t_end`; orders 2,
    /// 4, 6, 8; the implicit schemes; peer tolerances `1e-4 … 1e-14` (every second decade);
    /// three timed runs.
    pub fn around(dt: f64, t_end: f64) -> Self {
        let divides = |h: f64| {
            let n = t_end / h;
            n >= 1.0 && (n - n.round()).abs() <= 1e-9 * n
        };
        let mut dts: Vec<f64> = (-3..=3)
            .rev()
            .map(|k| dt * 2f64.powi(k))
            .filter(|&h| divides(h))
            .take(4)
            .collect();
        if dts.is_empty() {
            dts.push(dt);
        }
        Self {
            dts,
            orders: vec![2, 4, 6, 8],
            discrete_gradient: true,
            midpoint: true,
            modified: true,
            tolerances: vec![1e-4, 1e-6, 1e-8, 1e-10, 1e-12, 1e-14],
            peers: true,
            repeats: 3,
            double_double: true,
        }
    }
}

/// The reference solution at the final time.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Reference {
    /// The state at `t`.
    pub x: Vec<f64>,
    /// The time.
    pub t: f64,
    /// Where it comes from, e.g. `closed form` or `kahan-li8 at h = …, Richardson-checked`.
    pub source: String,
    /// Its own error estimate (max-norm), `None` for a closed form.
    pub error_estimate: Option<f64>,
}

/// One run of a work–precision set.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PrecisionRow {
    /// `projection order 2`, `projection order 8`, `discrete gradient`, `DOP853 (index-1 ODE)`, …
    pub method: String,
    /// The step size (lieflow) …
    pub dt: Option<f64>,
    /// … or the tolerance (peers).
    pub tol: Option<f64>,
    /// `ok`, or the error's kind (`Newton`, `NonFinite`, `Setup`, `Skipped`, …).
    pub status: String,
    /// What failed, if anything.
    pub message: String,
    /// Max-norm error of the final state against the reference.
    pub error: Option<f64>,
    /// `max |g|` over the run (at the peers' accepted steps).
    pub max_abs_g: Option<f64>,
    /// `max |φ|` over the run.
    pub max_abs_phi: Option<f64>,
    /// `max |H − H₀|`, or with damping `max |H − H₀ + dissipated|`.
    pub energy_error: Option<f64>,
    /// Steps (accepted steps for the peers).
    pub steps: u64,
    /// Multiplier-residual evaluations (lieflow) or right-hand-side evaluations (peers).
    pub evaluations: u64,
    /// Newton iterations.
    pub newton_iterations: u64,
    /// Factorizations of Newton matrices (peers: LU decompositions).
    pub factorizations: u64,
    /// Minimum wall time of the timed runs, seconds.
    pub time_min: Option<f64>,
    /// Median wall time of the timed runs, seconds.
    pub time_median: Option<f64>,
}

impl PrecisionRow {
    pub(crate) fn failed(
        method: &str,
        dt: Option<f64>,
        tol: Option<f64>,
        status: &str,
        message: String,
    ) -> Self {
        Self {
            method: method.to_owned(),
            dt,
            tol,
            status: status.to_owned(),
            message,
            error: None,
            max_abs_g: None,
            max_abs_phi: None,
            energy_error: None,
            steps: 0,
            evaluations: 0,
            newton_iterations: 0,
            factorizations: 0,
            time_min: None,
            time_median: None,
        }
    }
}

/// `true` for the built-in paper model.
pub(crate) fn is_paper(scene: &Scene) -> bool {
    scene
        .file
        .builtin
        .as_ref()
        .is_some_and(|b| b.model == "paper")
}

/// Max-norm distance.
pub(crate) fn distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
}

/// `(min, median)` of the times.
pub(crate) fn min_median(mut times: Vec<f64>) -> (Option<f64>, Option<f64>) {
    if times.is_empty() {
        return (None, None);
    }
    times.sort_by(f64::total_cmp);
    let k = times.len();
    let median = if k % 2 == 1 {
        times[k / 2]
    } else {
        0.5 * (times[k / 2 - 1] + times[k / 2])
    };
    (Some(times[0]), Some(median))
}

fn with_scheme(scene: &Scene, scheme: &str, order: Option<u32>, dt: f64) -> Scene {
    let mut s = scene.clone();
    s.file.integrator.scheme = scheme.to_owned();
    s.file.integrator.order = order;
    s.file.integrator.dt = dt;
    s
}

/// The final time of the scene: `round(t_end/dt) · dt` is what a run reaches; the plan's step
/// sizes must all divide `t_end` (checked by [`work_precision`]).
fn final_time(scene: &Scene) -> f64 {
    scene.file.integrator.t_end
}

/// The reference: the closed form for the paper's example; otherwise Kahan–Li 8 around the
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
    let h_min = plan.dts.iter().copied().fold(f64::INFINITY, f64::min);
    let at = |scheme: &str, h: f64| -> Result<Vec<f64>, SceneError> {
        let mut c = lieflow::scene::compile_reference(&with_scheme(scene, scheme, None, h).file)?;
        let quiet = RunPlan {
            steps: c.plan.steps,
            energy: false,
            residuals: false,
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
    // A scene of bodies small enough: Kahan–Li 8 in double-double at h_min/4 and h_min/8 (with
    // damping its backward sub-steps are allowed here: the reference needs accuracy only, and
    // mild damping is harmless backwards).
    if scene.file.builtin.is_none() {
        let compiled = scene.compile()?;
        if plan.double_double && compiled.assembly.state_len <= DD_MAX_DIM {
            let model = compiled.model.expect("a scene of bodies has a model");
            let x0 = compiled.simulation.state().to_vec();
            let dd = |h: f64| double_double_run(&model, &x0, t, h);
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
                            "kahan-li8 in double-double (twofloat) at h = {:.3e} (checked against 2h)",
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
fn dividing(t: f64, h: f64) -> f64 {
    t / (t / h).ceil()
}

/// `max(1, max |x_i|)`.
fn state_scale(x: &[f64]) -> f64 {
    x.iter().fold(1.0f64, |a, v| a.max(v.abs()))
}

/// The largest scene state given a double-double reference (its arithmetic costs ~20× f64).
pub const DD_MAX_DIM: usize = 400;

/// Kahan–Li 8 around the scene's splitting in double-double from `x0` to `t` in steps of about
/// `h` (exactly `t / round(t/h)` in double-double); the final state.
fn double_double_run(
    model: &std::sync::Arc<lieflow::scene::SceneModel>,
    x0: &[f64],
    t: f64,
    h: f64,
) -> Result<Vec<twofloat::TwoFloat>, String> {
    use lieflow::Flow as _;
    use lieflow::Real;
    use twofloat::TwoFloat;
    type V = nalgebra::DVector<TwoFloat>;
    let dd = std::sync::Arc::new(model.with_scalar::<TwoFloat>());
    let mut x = V::from_iterator(x0.len(), x0.iter().map(|&v| TwoFloat::lit(v)));
    // twofloat's `epsilon()` is f64::MIN_POSITIVE; its unit round-off is ~2^-106.
    let eps = TwoFloat::lit(1e-31);
    let table = lieflow::flow::coefficients::table_by_name("kahan-li8");
    let (mut flow, _, _) =
        lieflow::scene::splitting_flow(&dd, &x, table, true, eps).map_err(|e| e.to_string())?;
    let steps = (t / h).round().max(1.0);
    let step = TwoFloat::lit(t) / TwoFloat::lit(steps);
    for k in 0..steps as usize {
        flow.step(step, &mut x)
            .map_err(|e| format!("step {k}: {e}"))?;
    }
    Ok(x.iter().copied().collect())
}

/// A reference run: the final state of the scene with the named scheme at a step size.
type RunAt<'a> = dyn Fn(&str, f64) -> Result<Vec<f64>, SceneError> + 'a;

/// The double-precision reference: Kahan–Li 8 at `h_min/8` and `/16`, or, if that fails (stiff
/// damping), Strang at `h_min/64` and `/128`, Richardson-extrapolated.
fn f64_reference(h_min: f64, t: f64, at: &RunAt<'_>) -> Result<Reference, SceneError> {
    let h = dividing(t, h_min / 8.0);
    if let (Ok(coarse), Ok(fine)) = (at("kahan-li8", h), at("kahan-li8", h / 2.0)) {
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
    let coarse = at("strang", h)?;
    let fine = at("strang", h / 2.0)?;
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

/// Runs the whole set (see the module docs). `progress` sees every row as it is done.
pub fn work_precision(
    scene: &Scene,
    plan: &PrecisionPlan,
    reference: &Reference,
    progress: &mut dyn FnMut(&PrecisionRow),
) -> Vec<PrecisionRow> {
    let mut rows = Vec::new();
    let mut push = |row: PrecisionRow, rows: &mut Vec<PrecisionRow>| {
        progress(&row);
        rows.push(row);
    };
    let dissipative = scene
        .compile()
        .map(|c| c.assembly.dissipative)
        .unwrap_or(false);
    let is_builtin = scene.file.builtin.is_some();
    let mut methods: Vec<(String, &str, Option<u32>)> = Vec::new();
    for &o in &plan.orders {
        methods.push((format!("lieflow order {o}"), "auto", Some(o)));
    }
    let is_paper = scene
        .file
        .builtin
        .as_ref()
        .is_some_and(|b| b.model == "paper");
    let n = scene.compile().map(|c| c.assembly.state_len).unwrap_or(0);
    let mut implicit: Vec<(String, &str)> = Vec::new();
    if plan.discrete_gradient && !is_builtin {
        implicit.push(("lieflow discrete gradient".into(), "discrete-gradient"));
    }
    if plan.midpoint && (!is_builtin || is_paper) {
        implicit.push(("lieflow implicit midpoint".into(), "midpoint"));
    }
    if plan.modified && is_paper {
        implicit.push(("lieflow §2 scheme".into(), "modified"));
    }
    for (name, scheme) in implicit {
        if n > DENSE_MAX_DIM {
            push(
                PrecisionRow::failed(
                    &name,
                    None,
                    None,
                    "Skipped",
                    format!("state of {n} > {DENSE_MAX_DIM}: dense Newton matrices"),
                ),
                &mut rows,
            );
        } else {
            methods.push((name, scheme, None));
        }
    }
    for (name, scheme, order) in &methods {
        for &dt in &plan.dts {
            if dissipative && order.is_some_and(|o| o > 2) {
                push(
                    PrecisionRow::failed(
                        name,
                        Some(dt),
                        None,
                        "Skipped",
                        "negative sub-steps would run the damping backwards".into(),
                    ),
                    &mut rows,
                );
                continue;
            }
            let row = lieflow_row(scene, name, scheme, *order, dt, plan.repeats, reference);
            push(row, &mut rows);
        }
    }
    if plan.peers {
        for row in crate::peers::peer_rows(scene, plan, reference) {
            push(row, &mut rows);
        }
    }
    rows
}

/// One lieflow run: warm-up with diagnostics, then timed runs.
fn lieflow_row(
    scene: &Scene,
    name: &str,
    scheme: &str,
    order: Option<u32>,
    dt: f64,
    repeats: usize,
    reference: &Reference,
) -> PrecisionRow {
    let s = with_scheme(scene, scheme, order, dt);
    let steps_f = final_time(scene) / dt;
    if (steps_f - steps_f.round()).abs() > 1e-9 * steps_f.max(1.0) {
        return PrecisionRow::failed(
            name,
            Some(dt),
            None,
            "Setup",
            format!("dt = {dt} does not divide t_end"),
        );
    }
    let compile = || s.compile();
    let mut c = match compile() {
        Ok(c) => c,
        Err(e) => return PrecisionRow::failed(name, Some(dt), None, "Setup", e.to_string()),
    };
    let observed = RunPlan {
        steps: c.plan.steps,
        energy: true,
        residuals: true,
    };
    let summary = run(c.simulation.as_mut(), &observed, &mut |_| {});
    if let Some(f) = &summary.error {
        let mut row = PrecisionRow::failed(
            name,
            Some(dt),
            None,
            &f.kind,
            format!("step {} at t = {}: {}", f.step, f.t, f.message),
        );
        row.steps = summary.steps as u64;
        return row;
    }
    let stats = c.simulation.stats();
    // Timed runs: a fresh simulation each (compiling it is not timed), one clock around all
    // its steps and nothing observed — as the peers are timed around their whole solve.
    let mut times = Vec::with_capacity(repeats);
    'timed: for _ in 0..repeats {
        let Ok(mut c) = compile() else { break };
        let start = std::time::Instant::now();
        for _ in 0..c.plan.steps {
            if c.simulation.step().is_err() {
                break 'timed;
            }
        }
        times.push(start.elapsed().as_secs_f64());
    }
    let (time_min, time_median) = min_median(times);
    PrecisionRow {
        method: name.to_owned(),
        dt: Some(dt),
        tol: None,
        status: "ok".into(),
        message: String::new(),
        error: Some(distance(&summary.x, &reference.x)),
        max_abs_g: summary.max_abs_g,
        max_abs_phi: summary.max_abs_phi,
        // The paper's H is not an invariant of its example (H̃ is): no energy error there.
        energy_error: if is_paper(scene) {
            None
        } else {
            summary
                .max_energy_balance_error
                .or(summary.max_abs_energy_error)
        },
        steps: summary.steps as u64,
        evaluations: stats.residual_evaluations,
        newton_iterations: stats.newton_iterations,
        factorizations: stats.factorizations,
        time_min,
        time_median,
    }
}

/// The least-squares slope of `log(error)` against `log(dt)` per lieflow method, over its rows
/// with an error in `(floor, ceiling)`: above the reference's error and the round-off a run
/// accumulates, below the saturated, pre-asymptotic range. The fitted order.
pub fn fitted_slopes(rows: &[PrecisionRow], floor: f64, ceiling: f64) -> Vec<(String, f64)> {
    let mut out: Vec<(String, f64)> = Vec::new();
    let mut names: Vec<&str> = rows
        .iter()
        .filter(|r| r.dt.is_some())
        .map(|r| r.method.as_str())
        .collect();
    names.dedup();
    for name in names {
        let pts: Vec<(f64, f64)> = rows
            .iter()
            .filter(|r| r.method == name && r.status == "ok")
            .filter_map(|r| Some((r.dt?, r.error?)))
            .filter(|&(_, e)| e > floor && e < ceiling)
            .map(|(h, e)| (h.ln(), e.ln()))
            .collect();
        if pts.len() < 2 {
            continue;
        }
        let n = pts.len() as f64;
        let (mx, my) = (
            pts.iter().map(|p| p.0).sum::<f64>() / n,
            pts.iter().map(|p| p.1).sum::<f64>() / n,
        );
        let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
        let sxx: f64 = pts.iter().map(|p| (p.0 - mx) * (p.0 - mx)).sum();
        if sxx > 0.0 {
            out.push((name.to_owned(), sxy / sxx));
        }
    }
    out
}

/// The CSV columns, in order.
pub const CSV_COLUMNS: [&str; 16] = [
    "method",
    "dt",
    "tol",
    "status",
    "error",
    "max_abs_g",
    "max_abs_phi",
    "energy_error",
    "steps",
    "evaluations",
    "newton_iterations",
    "factorizations",
    "time_min_s",
    "time_median_s",
    "fitted_order",
    "message",
];

/// Writes the rows as long-format CSV: `# key: value` comment lines first (`comments`, e.g.
/// the machine, the revision and the reference), then the header [`CSV_COLUMNS`] and one line
/// per row. Empty fields are values that do not apply.
pub fn write_csv(
    w: &mut dyn std::io::Write,
    comments: &[(&str, String)],
    rows: &[PrecisionRow],
    slopes: &[(String, f64)],
) -> std::io::Result<()> {
    for (k, v) in comments {
        writeln!(w, "# {k}: {}", v.replace('\n', " "))?;
    }
    writeln!(w, "{}", CSV_COLUMNS.join(","))?;
    let f = |v: Option<f64>| v.map_or_else(String::new, |v| format!("{v:e}"));
    for r in rows {
        let slope = slopes
            .iter()
            .find(|s| s.0 == r.method && r.status == "ok")
            .map(|s| s.1);
        let message = r.message.replace('"', "'");
        writeln!(
            w,
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},\"{}\"",
            r.method,
            f(r.dt),
            f(r.tol),
            r.status,
            f(r.error),
            f(r.max_abs_g),
            f(r.max_abs_phi),
            f(r.energy_error),
            r.steps,
            r.evaluations,
            r.newton_iterations,
            r.factorizations,
            f(r.time_min),
            f(r.time_median),
            f(slope),
            message
        )?;
    }
    Ok(())
}

/// The fitting window of [`fitted_slopes`] for a reference and the smallest step: errors above
/// ten times the reference's own error and ten times the round-off `ε · T/h_min · |x|` a run
/// accumulates, and below `10⁻² |x|` (beyond that the error has saturated, e.g. a phase error of
/// order one at a long horizon).
pub fn fitting_window(reference: &Reference, h_min: f64) -> (f64, f64) {
    let scale = reference.x.iter().fold(1.0f64, |a, x| a.max(x.abs()));
    let steps = (reference.t / h_min).max(1.0);
    let floor =
        (10.0 * reference.error_estimate.unwrap_or(0.0)).max(10.0 * f64::EPSILON * steps * scale);
    (floor, 1e-2 * scale)
}
