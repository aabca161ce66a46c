//! `lieflow run`: a scene (the default scene without an argument) with a summary, CSV rows and
//! a plot; the last line of stdout is a JSON summary.

use crate::csv_rows::CsvRows;
use crate::progress::Progress;
use crate::{bad_scene, load, plot};
use lieflow::scene::schema::Diagnostic;
use lieflow::scene::{RunSummary, Sample, run};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Debug, clap::Args)]
pub(crate) struct RunArgs {
    /// The scene file (default: the embedded default scene, see `lieflow scene`).
    scene: Option<PathBuf>,
    /// Override the scene's step size.
    #[arg(long, value_name = "H")]
    dt: Option<f64>,
    /// Override the scene's final time.
    #[arg(long, value_name = "T")]
    t_end: Option<f64>,
    /// Write the trajectory (t, x, and the diagnostics) as CSV.
    #[arg(long, value_name = "FILE")]
    csv: Option<PathBuf>,
    /// Write every K-th step to the CSV (default: about 1000 rows).
    #[arg(long, value_name = "K")]
    every: Option<usize>,
    /// Plot energy and constraint residual over time (and the paths, for 2D scenes) as SVG.
    #[arg(long, value_name = "FILE.svg")]
    plot: Option<PathBuf>,
    /// Time each effect (adds a clock read per evaluation; shares go in the JSON).
    #[arg(long)]
    profile: bool,
    /// Switch a declared part off, as `[flags] NAME = false` does (repeatable): gravity,
    /// springs, pair, trap, damping, magnetic, constraints, energy, residuals.
    #[arg(long, value_name = "NAME")]
    off: Vec<String>,
}

pub(crate) fn run_scene(args: &RunArgs) -> ExitCode {
    let mut scene = match load(args.scene.as_deref()) {
        Ok(s) => s,
        Err(e) => return bad_scene(&e),
    };
    for (v, name) in [(args.dt, "--dt"), (args.t_end, "--t-end")] {
        if let Some(v) = v
            && !(v.is_finite() && v > 0.0)
        {
            eprintln!("error: {name} must be positive and finite, not {v}");
            return ExitCode::from(2);
        }
    }
    for name in &args.off {
        if let Err(e) = scene.file.flags.set_named(name, false) {
            eprintln!("error: --off: {e}");
            return ExitCode::from(2);
        }
    }
    if let Some(dt) = args.dt {
        scene.file.integrator.dt = dt;
    }
    if let Some(t) = args.t_end {
        scene.file.integrator.t_end = t;
    }
    let diagnostics = &mut scene.file.integrator.diagnostics;
    if args.profile && !diagnostics.contains(&Diagnostic::Profile) {
        diagnostics.push(Diagnostic::Profile);
    }
    let mut compiled = match scene.compile() {
        Ok(c) => c,
        Err(e) => return bad_scene(&e),
    };
    let a = &compiled.assembly;
    println!(
        "{}: {} bodies, {} constraint rows, {}, order {}, dt = {}, {} steps",
        a.name, a.bodies, a.constraint_rows, a.scheme, a.order, scene.file.integrator.dt, a.steps
    );
    if let Some((dq, dp)) = a.initial_projection {
        println!("  initial state projected: max |dq| = {dq:.3e}, max |dp| = {dp:.3e}");
    }
    if !a.dropped_constraints.is_empty() {
        println!(
            "  redundant constraints dropped: {}",
            a.dropped_constraints.join(", ")
        );
    }
    let steps = compiled.plan.steps;
    if args.every == Some(0) {
        eprintln!("error: --every must be at least 1");
        return ExitCode::from(2);
    }
    let every = args.every.unwrap_or((steps / 1000).max(1));
    let mut csv = match &args.csv {
        Some(p) => {
            let n = compiled.simulation.state().len();
            let names = compiled.simulation.output_names();
            match CsvRows::create(p, n, &names, &compiled.assembly, every, steps) {
                Ok(rows) => Some(rows),
                Err(e) => {
                    eprintln!("error: {e}");
                    return ExitCode::from(2);
                }
            }
        }
        None => None,
    };
    let bodies = compiled.simulation.bodies();
    let mut series = plot::Series::new(steps, bodies, &compiled.simulation.output_names());
    let mut progress = Progress::new(steps);
    // The last state seen: a run that stops early still ends its CSV and plot with it.
    let mut last = (0usize, 0.0f64, None, None, None);
    let mut last_outputs: Vec<f64> = Vec::new();
    let mut observe = |s: &Sample<'_>| {
        progress.observe(s);
        if args.plot.is_some() {
            series.push(s, false);
        }
        last = (s.step, s.t, s.energy, s.g, s.phi);
        last_outputs.clear();
        last_outputs.extend_from_slice(s.outputs);
        if let Some(rows) = csv.as_mut() {
            rows.observe(s);
        }
    };
    let summary = run(compiled.simulation.as_mut(), &compiled.plan, &mut observe);
    progress.finish();
    let final_sample = Sample {
        step: last.0,
        t: last.1,
        x: compiled.simulation.state(),
        energy: last.2,
        g: last.3,
        phi: last.4,
        outputs: &last_outputs,
    };
    if args.plot.is_some() {
        series.push(&final_sample, true);
    }
    let io_error = csv.and_then(|rows| rows.finish(&final_sample));
    print_summary(&summary);
    let mut code = ExitCode::SUCCESS;
    if let Some(e) = io_error {
        eprintln!("error: writing the CSV: {e}");
        code = ExitCode::from(1);
    }
    if let Some(p) = &args.plot {
        match series.draw(p, &compiled.assembly.name) {
            Ok(()) => println!("  plot: {}", p.display()),
            Err(e) => {
                eprintln!("error: plotting {}: {e}", p.display());
                code = ExitCode::from(1);
            }
        }
    }
    if let Some(f) = &summary.error {
        eprintln!(
            "error: step {} at t = {} failed ({}): {}; the outputs hold the run up to the last good state",
            f.step, f.t, f.kind, f.message
        );
        code = ExitCode::from(1);
    }
    let mut json = serde_json::to_value(&summary).expect("serializable");
    let obj = json.as_object_mut().expect("an object");
    obj.insert("scene".into(), compiled.assembly.name.clone().into());
    obj.insert("scheme".into(), compiled.assembly.scheme.clone().into());
    obj.insert("order".into(), compiled.assembly.order.into());
    if !compiled.assembly.dropped_constraints.is_empty() {
        obj.insert(
            "dropped_constraints".into(),
            compiled.assembly.dropped_constraints.clone().into(),
        );
    }
    println!("{json}");
    code
}

pub(crate) fn print_summary(s: &RunSummary) {
    let opt = |v: Option<f64>| v.map_or_else(|| "-".to_owned(), |v| format!("{v:.3e}"));
    println!(
        "  t = {}, {} of {} steps, {:.0} ns/step",
        s.t, s.steps, s.steps_planned, s.ns_per_step
    );
    println!(
        "  max |g|   = {}   max |phi| = {}",
        opt(s.max_abs_g),
        opt(s.max_abs_phi)
    );
    if let (Some(e0), Some(e1)) = (s.energy_initial, s.energy_final) {
        println!(
            "  energy {e0:.9} -> {e1:.9}, max |H - H0| = {}, max increase per step = {}",
            opt(s.max_abs_energy_error),
            opt(s.max_energy_increase)
        );
    }
    match (s.dissipated, s.supplied) {
        (None, None) => {}
        (d, u) => println!(
            "  dissipated {}, supplied {}, energy budget error {}",
            opt(d),
            opt(u),
            opt(s.max_energy_balance_error)
        ),
    }
    if !s.events.is_empty() {
        let shown: Vec<String> = s
            .events
            .iter()
            .take(5)
            .map(|e| format!("{} at t = {:.12}", e.name, e.t))
            .collect();
        let more = s.events.len().saturating_sub(5);
        println!(
            "  events: {}{}",
            shown.join(", "),
            if more > 0 {
                format!(" (and {more} more)")
            } else {
                String::new()
            }
        );
    }
    if let Some(name) = &s.stopped_by {
        println!("  stopped by event '{name}' at t = {}", s.t);
    }
    let counts: Vec<String> = s
        .effects
        .iter()
        .map(|e| match e.time_share {
            Some(share) => format!("{} {} ({:.0}%)", e.name, e.evaluations, 100.0 * share),
            None => format!("{} {}", e.name, e.evaluations),
        })
        .collect();
    println!("  evaluations: {}", counts.join(", "));
}
