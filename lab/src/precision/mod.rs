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

use lieflow::scene::Scene;
use lieflow::scene::schema::Method;
use lieflow::scene::{RunPlan, advance_plan, run};
use std::sync::atomic::{AtomicBool, Ordering};

pub(crate) mod plan;
mod reference;

pub use lieflow::scene::DENSE_MAX_DIM;
pub use plan::{PrecisionPlan, PrecisionRow, Reference};
pub(crate) use plan::{distance, is_paper, min_median};
use plan::{final_time, with_scheme, with_tolerance};
pub use reference::{DD_MAX_DIM, double_double_splitting, reference};

/// Runs the whole set (see the module docs). `progress` sees every row as it is done.
pub fn work_precision(
    scene: &Scene,
    plan: &PrecisionPlan,
    reference: &Reference,
    progress: &mut dyn FnMut(&PrecisionRow),
) -> Vec<PrecisionRow> {
    work_precision_until(scene, plan, reference, progress, &AtomicBool::new(false))
}

/// [`work_precision`] that stops before the next run once `stop` is raised (by a Ctrl-C
/// handler, say): the rows of the runs that finished, in order. A run in progress completes.
pub fn work_precision_until(
    scene: &Scene,
    plan: &PrecisionPlan,
    reference: &Reference,
    progress: &mut dyn FnMut(&PrecisionRow),
    stop: &AtomicBool,
) -> Vec<PrecisionRow> {
    let stopped = || stop.load(Ordering::Relaxed);
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
    let mut methods: Vec<(String, Method, Option<u32>)> = Vec::new();
    for &o in &plan.orders {
        // With damping, orders above 2 extrapolate the splitting (every sub-step forward).
        let name = if dissipative && o > 2 {
            format!("lieflow order {o} extrapolated")
        } else {
            format!("lieflow order {o}")
        };
        methods.push((name, Method::Auto, Some(o)));
    }
    let is_paper = scene
        .file
        .builtin
        .as_ref()
        .is_some_and(|b| b.model == "paper");
    let n = scene.compile().map(|c| c.assembly.state_len).unwrap_or(0);
    let mut implicit: Vec<(String, Method, Option<u32>)> = Vec::new();
    if plan.discrete_gradient && !is_builtin {
        implicit.push((
            "lieflow discrete gradient".into(),
            Method::DiscreteGradient,
            None,
        ));
    }
    if plan.midpoint && (!is_builtin || is_paper) {
        implicit.push(("lieflow implicit midpoint".into(), Method::Midpoint, None));
    }
    if plan.modified && is_paper {
        implicit.push(("lieflow §2 scheme".into(), Method::Modified, None));
    }
    if !is_builtin {
        for &o in &plan.petrov_galerkin {
            implicit.push((
                format!("lieflow Petrov–Galerkin order {o}"),
                Method::PetrovGalerkin,
                Some(o),
            ));
        }
    }
    for (name, scheme, order) in implicit {
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
            methods.push((name, scheme, order));
        }
    }
    for (name, scheme, order) in &methods {
        for &dt in &plan.dts {
            if stopped() {
                return rows;
            }
            let row = lieflow_row(scene, name, *scheme, *order, dt, plan.repeats, reference);
            push(row, &mut rows);
        }
    }
    if plan.adaptive && !is_builtin {
        for &tol in &plan.tolerances {
            if stopped() {
                return rows;
            }
            let s = with_tolerance(scene, tol);
            let name = "lieflow adaptive extrapolation";
            let row = timed_row(scene, &s, name, None, Some(tol), plan.repeats, reference);
            push(row, &mut rows);
        }
    }
    if plan.peers && !stopped() {
        for row in crate::peers::peer_rows(scene, plan, reference, &stopped) {
            push(row, &mut rows);
        }
    }
    rows
}

/// One lieflow run: warm-up with diagnostics, then timed runs.
fn lieflow_row(
    scene: &Scene,
    name: &str,
    scheme: Method,
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
    timed_row(scene, &s, name, Some(dt), None, repeats, reference)
}

/// The row of `s` (a variant of `scene`) at step `dt` or tolerance `tol`: a warm-up run with
/// diagnostics, then `repeats` timed runs with nothing observed.
fn timed_row(
    scene: &Scene,
    s: &Scene,
    name: &str,
    dt: Option<f64>,
    tol: Option<f64>,
    repeats: usize,
    reference: &Reference,
) -> PrecisionRow {
    let compile = || s.compile();
    let mut c = match compile() {
        Ok(c) => c,
        Err(e) => return PrecisionRow::failed(name, dt, tol, "Setup", e.to_string()),
    };
    let observed = RunPlan {
        energy: true,
        residuals: true,
        ..c.plan
    };
    let summary = run(c.simulation.as_mut(), &observed, &mut |_| {});
    if let Some(f) = &summary.error {
        let mut row = PrecisionRow::failed(
            name,
            dt,
            tol,
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
        let plan = c.plan;
        // Nothing observed, so no books read (whatever the plan's diagnostics): the flows skip
        // their work, as in `lieflow run` without the energy diagnostic.
        c.simulation.read_books(false);
        let start = std::time::Instant::now();
        let done = advance_plan(c.simulation.as_mut(), &plan, &mut ());
        if done.error.is_some() {
            break 'timed;
        }
        times.push(start.elapsed().as_secs_f64());
    }
    let (time_min, time_median) = min_median(times);
    PrecisionRow {
        method: name.to_owned(),
        dt,
        tol,
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
        // Under a tolerance, the steps the controller accepted (the run reports once).
        steps: summary
            .adaptive
            .as_ref()
            .map_or(summary.steps as u64, |a| a.accepted),
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
