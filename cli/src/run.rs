//! `lieflow run`: a scene (the default scene without an argument) with a summary, CSV rows and
//! a plot; the last line of stdout is a JSON summary.

use crate::csv_rows::{Columns, CsvRows};
use crate::interrupt;
use crate::number::{count, num};
use crate::progress::Progress;
use crate::{bad_scene, load, plot};
use lieflow::scene::schema::Diagnostic;
use lieflow::scene::{Assembly, RunPlan};
use lieflow::scene::{RunSummary, Sample, run_until};
use std::path::PathBuf;
use std::process::ExitCode;

/// The scalar fields of a [`Sample`].
#[derive(Default, Clone, Copy)]
struct Scalars {
    step: usize,
    t: f64,
    energy: Option<f64>,
    dissipated: Option<f64>,
    supplied: Option<f64>,
    g: Option<f64>,
    phi: Option<f64>,
}

/// The run's first line: the scene, what it holds, its scheme and its steps (the shortened
/// last one named).
fn headline(a: &Assembly, plan: &RunPlan, dt: f64) -> String {
    let holds = match a.dim {
        Some(_) => format!(
            "{}, {}",
            crate::check::bodies(a),
            count(a.constraint_rows, "constraint row", "constraint rows")
        ),
        None if a.constraint_rows == 0 => format!("built-in model, state of {}", a.state_len),
        None => format!(
            "built-in model, state of {}, {}",
            a.state_len,
            count(a.constraint_rows, "constraint row", "constraint rows")
        ),
    };
    let steps = match plan.last_step {
        _ if plan.own_steps => format!("steps chosen to t_end = {}", num(plan.t_end, 12)),
        _ if plan.dense => format!(
            "{} from the dense output of the steps chosen",
            count(plan.total_steps(), "report", "reports")
        ),
        None => count(plan.steps, "step", "steps"),
        Some(last) => format!(
            "{} (the last {} long, to end at t_end = {})",
            count(plan.total_steps(), "step", "steps"),
            num(last, 6),
            num(plan.t_end, 12)
        ),
    };
    format!(
        "{}: {holds}, {}, order {}, dt = {}, {steps}",
        a.name,
        a.scheme,
        a.order,
        num(dt, 12)
    )
}

#[derive(Debug, clap::Args)]
pub(crate) struct RunArgs {
    /// The scene file (default: the embedded default scene, see `lieflow scene`).
    scene: Option<PathBuf>,
    /// Override the scene's step size (when it does not divide the final time, the last step
    /// is shortened to end there).
    #[arg(long, value_name = "H", allow_negative_numbers = true)]
    dt: Option<f64>,
    /// Override the scene's final time.
    #[arg(long, value_name = "T", allow_negative_numbers = true)]
    t_end: Option<f64>,
    /// Override the scene's scheme (`integrator.scheme`: auto, strang, suzuki4, …,
    /// extrapolation, midpoint, discrete-gradient, petrov-galerkin).
    #[arg(long, value_name = "NAME")]
    scheme: Option<String>,
    /// Override the scene's order (`integrator.order`).
    #[arg(long, value_name = "K")]
    order: Option<u32>,
    /// Write the trajectory (t, x, and the diagnostics) as CSV.
    #[arg(long, value_name = "FILE")]
    csv: Option<PathBuf>,
    /// Write every K-th step to the CSV (default: about 1000 rows; with --accepted-steps,
    /// every accepted step).
    #[arg(long, value_name = "K")]
    every: Option<usize>,
    /// Take the steps the controller chooses (a scene with a tolerance) and write a CSV row
    /// and plot point at each accepted step, instead of stepping to every `dt`.
    #[arg(long)]
    accepted_steps: bool,
    /// Report every `dt` from the dense output of the controller's own steps (a scene with a
    /// tolerance, as `[integrator] dense = true`): the steps are not shortened to land on
    /// the report times.
    #[arg(long, conflicts_with = "accepted_steps")]
    dense: bool,
    /// Plot energy and constraint residual over time (and the paths, for 2D scenes) as SVG
    /// (the file must end in `.svg`; it is checked writable before the run).
    #[arg(long, value_name = "FILE.svg")]
    plot: Option<PathBuf>,
    /// Time each effect (adds a clock read per evaluation; shares go in the JSON).
    #[arg(long)]
    profile: bool,
    /// Switch declared parts off (repeatable): a kind, as `[flags] NAME = false` does
    /// (gravity, springs, pair, trap, damping, magnetic, constraints, energy, residuals), or
    /// one effect or constraint by its `name`.
    #[arg(long, value_name = "NAME")]
    off: Vec<String>,
    #[command(flatten)]
    animate: crate::animate::AnimateArgs,
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
        // A kind of part (every gravity, every constraint) by its flag; otherwise one named
        // effect or constraint (the compile refuses a name the scene does not have).
        if scene.file.flags.set_named(name, false).is_err() {
            scene.file.off.push(name.clone());
        }
    }
    if let Some(name) = &args.scheme {
        let Some(method) = lieflow::scene::schema::Method::from_name(name) else {
            eprintln!(
                "error: --scheme {name}: not a scheme (one of {})",
                lieflow::scene::schema::Method::names()
            );
            return ExitCode::from(2);
        };
        scene.file.integrator.scheme = method;
        if args.order.is_none() {
            // The new scheme's own default order, not the file's (which named another's).
            scene.file.integrator.order = None;
        }
    }
    if let Some(order) = args.order {
        scene.file.integrator.order = Some(order);
    }
    if let Some(dt) = args.dt {
        scene.file.integrator.dt = dt;
    }
    if let Some(t) = args.t_end {
        scene.file.integrator.t_end = t;
    }
    if args.dense {
        scene.file.integrator.dense = true;
    }
    let (dt, t_end) = (scene.file.integrator.step(), scene.file.integrator.t_end);
    if (args.dt.is_some() || args.t_end.is_some()) && dt > t_end {
        // The same refusal as the scene's, naming the flag that caused it.
        let flag = if args.dt.is_some() { "--dt" } else { "--t-end" };
        eprintln!(
            "error: {flag}: the step dt = {} is longer than the run (t_end = {})",
            num(dt, 12),
            num(t_end, 12)
        );
        return ExitCode::from(2);
    }
    let diagnostics = &mut scene.file.integrator.diagnostics;
    if args.profile && !diagnostics.contains(&Diagnostic::Profile) {
        diagnostics.push(Diagnostic::Profile);
    }
    if let Some(p) = &args.plot
        && let Err(e) = plot::check_target(p)
    {
        eprintln!("error: --plot: {e}");
        return ExitCode::from(2);
    }
    if let Err(e) = args.animate.check() {
        eprintln!("error: {e}");
        return ExitCode::from(2);
    }
    let mut compiled = match scene.compile() {
        Ok(c) => c,
        Err(e) => return bad_scene(&e),
    };
    if args.accepted_steps {
        if compiled.simulation.adaptive_stats().is_none() {
            eprintln!(
                "error: --accepted-steps: the scheme takes fixed steps of dt = {}; give the scene a tolerance (`[integrator] tol`) to have its steps chosen",
                num(dt, 12)
            );
            return ExitCode::from(2);
        }
        compiled.plan.own_steps = true;
    }
    println!("{}", headline(&compiled.assembly, &compiled.plan, dt));
    let a = &compiled.assembly;
    for note in &a.notes {
        println!("  note: {note}");
    }
    if let Some((dq, dp)) = a.initial_projection {
        println!("  initial state projected: max |dq| = {dq:.3e}, max |dp| = {dp:.3e}");
    }
    if !a.dropped_constraints.is_empty() {
        println!(
            "  redundant constraints dropped: {}",
            a.dropped_constraints.join(", ")
        );
    }
    // Without a count known before (the controller's steps), every step is a row; a plot and
    // a progress bar follow the time instead.
    let steps = (!args.accepted_steps).then(|| compiled.plan.total_steps());
    if args.every == Some(0) {
        eprintln!("error: --every must be at least 1");
        return ExitCode::from(2);
    }
    let every = args
        .every
        .unwrap_or_else(|| steps.map_or(1, |n| (n / 1000).max(1)));
    let mut csv = match &args.csv {
        Some(p) => {
            let sim = compiled.simulation.as_ref();
            let columns = Columns {
                state: sim.state_names(),
                inv_mass: compiled.model.as_ref().map(|m| {
                    let d = m.space_dim();
                    m.inv_masses()
                        .iter()
                        .flat_map(|&w| std::iter::repeat_n(w, d))
                        .collect()
                }),
                multipliers: sim.multiplier_names(),
                outputs: sim.output_names(),
            };
            compiled.plan.multipliers = !columns.multipliers.is_empty();
            match CsvRows::create(p, columns, &compiled.assembly, every, steps) {
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
    // Body names from the state's columns `q.<body>.x`.
    let body_names: Vec<String> = compiled
        .simulation
        .state_names()
        .iter()
        .filter_map(|n| n.strip_prefix("q.")?.strip_suffix(".x").map(str::to_owned))
        .collect();
    let span = (compiled.simulation.time(), compiled.plan.t_end);
    let mut series = plot::Series::new(
        steps.map_or(plot::Spacing::Time(span), plot::Spacing::Steps),
        bodies,
        &body_names,
        &compiled.simulation.output_names(),
    );
    let mut animation = match args.animate.recorder(&compiled) {
        Ok(a) => a,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    let mut progress = match steps {
        Some(n) => Progress::new(n),
        None => Progress::over_time(span),
    };
    // The last state seen: a run that stops early still ends its CSV and plot with it.
    // The scalars of the last sample seen (its slices are copied beside it).
    let mut last = Scalars::default();
    let mut last_outputs: Vec<f64> = Vec::new();
    let mut last_multipliers: Vec<f64> = Vec::new();
    let mut observe = |s: &Sample<'_>| {
        progress.observe(s);
        if args.plot.is_some() {
            series.push(s, false);
        }
        last = Scalars {
            step: s.step,
            t: s.t,
            energy: s.energy,
            dissipated: s.dissipated,
            supplied: s.supplied,
            g: s.g,
            phi: s.phi,
        };
        last_outputs.clear();
        last_outputs.extend_from_slice(s.outputs);
        last_multipliers.clear();
        last_multipliers.extend_from_slice(s.multipliers);
        if let Some(rows) = csv.as_mut() {
            rows.observe(s);
        }
        if let Some(a) = animation.as_mut() {
            a.observe(s);
        }
    };
    // The books are read through the energy diagnostic only (the summary, the CSV, the plot
    // and the animation take them from it): without it the flows skip their work.
    compiled.simulation.read_books(compiled.plan.energy);
    interrupt::catch_interrupt();
    let summary = run_until(
        compiled.simulation.as_mut(),
        &compiled.plan,
        &mut observe,
        &interrupt::INTERRUPTED,
    );
    progress.finish();
    let final_sample = Sample {
        step: last.step,
        t: last.t,
        x: compiled.simulation.state(),
        energy: last.energy,
        dissipated: last.dissipated,
        supplied: last.supplied,
        g: last.g,
        phi: last.phi,
        outputs: &last_outputs,
        multipliers: &last_multipliers,
    };
    if args.plot.is_some() {
        series.push(&final_sample, true);
    }
    let io_error = csv.and_then(|rows| rows.finish(&final_sample));
    print_summary(&summary);
    if let Some(hint) = dense_hint(&scene, &compiled.plan, &summary, dt) {
        println!("  note: {hint}");
    }
    let mut code = ExitCode::SUCCESS;
    let animated = animation.map(|a| a.write(&summary));
    if let Some(Err(e)) = &animated {
        eprintln!("error: --animate: {e}");
        code = ExitCode::from(1);
    }
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
            f.step,
            num(f.t, 12),
            f.kind,
            f.message
        );
        if let Some(advice) = &f.advice {
            eprintln!("  what to try: {advice}");
        }
        code = ExitCode::from(1);
    }
    if summary.interrupted {
        let done = if summary.own_steps {
            count(summary.steps, "accepted step", "accepted steps")
        } else {
            format!("{} of {} steps", summary.steps, summary.steps_planned)
        };
        eprintln!(
            "interrupted at t = {} after {done}: the CSV, plot and summary hold the run so far",
            num(summary.t, 12),
        );
        code = ExitCode::from(interrupt::EXIT_INTERRUPTED);
    }
    let mut json = serde_json::to_value(&summary).expect("serializable");
    let obj = json.as_object_mut().expect("an object");
    obj.insert("scene".into(), compiled.assembly.name.clone().into());
    obj.insert("scheme".into(), compiled.assembly.scheme.clone().into());
    obj.insert("order".into(), compiled.assembly.order.into());
    if let Some(Ok(a)) = animated {
        obj.insert("animation".into(), a);
    }
    if !compiled.assembly.dropped_constraints.is_empty() {
        obj.insert(
            "dropped_constraints".into(),
            compiled.assembly.dropped_constraints.clone().into(),
        );
    }
    println!("{json}");
    code
}

/// A run of the adaptive extrapolation whose every step ended on a report time (the steps
/// bounded by `dt`, as `h_max` is by default): the dense output would let them be longer.
fn dense_hint(
    scene: &lieflow::scene::Scene,
    plan: &RunPlan,
    s: &RunSummary,
    dt: f64,
) -> Option<String> {
    use lieflow::scene::schema::{Controller, Method};
    let i = &scene.file.integrator;
    let extrapolates = matches!(i.scheme, Method::Auto | Method::Extrapolation)
        && i.controller.unwrap_or(Controller::Error) == Controller::Error;
    let a = s.adaptive.as_ref()?;
    let bound = a.largest_step? >= dt * (1.0 - 1e-9) && a.accepted <= s.steps as u64 + a.rejected;
    (extrapolates && !plan.dense && !plan.own_steps && s.steps >= 20 && bound).then(|| {
        format!(
            "every step ended on a report time (dt = {}); `--dense` (`[integrator] dense = true`) reads the reports from the steps' dense output and lets the controller take its own",
            num(dt, 6)
        )
    })
}

pub(crate) fn print_summary(s: &RunSummary) {
    let opt = |v: Option<f64>| v.map_or_else(|| "-".to_owned(), |v| num(v, 4));
    let steps = if s.own_steps {
        count(s.steps, "accepted step", "accepted steps")
    } else {
        format!("{} of {} steps", s.steps, s.steps_planned)
    };
    println!(
        "  t = {}, {steps}, {} ns/step",
        num(s.t, 12),
        num(s.ns_per_step.round(), 6)
    );
    if s.max_abs_g.is_some() || s.max_abs_phi.is_some() {
        println!(
            "  max |g|   = {}   max |phi| = {}",
            opt(s.max_abs_g),
            opt(s.max_abs_phi)
        );
    }
    if let (Some(e0), Some(e1)) = (s.energy_initial, s.energy_final) {
        println!(
            "  energy {} -> {}, max |H - H0| = {}, max increase per step = {}",
            num(e0, 10),
            num(e1, 10),
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
    if let Some(w) = &s.energy_balance_warning {
        println!("  warning: {w}");
    }
    if !s.events.is_empty() {
        let shown: Vec<String> = s
            .events
            .iter()
            .take(5)
            .map(|e| format!("{} at t = {}", e.name, num(e.t, 12)))
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
        println!("  stopped by event '{name}' at t = {}", num(s.t, 12));
    }
    let counts: Vec<String> = s
        .effects
        .iter()
        .map(|e| match e.time_share {
            Some(share) => format!("{} {} ({:.0}%)", e.name, e.evaluations, 100.0 * share),
            None => format!("{} {}", e.name, e.evaluations),
        })
        .collect();
    if !counts.is_empty() {
        println!("  evaluations: {}", counts.join(", "));
    }
    if let Some(a) = &s.adaptive {
        let orders: Vec<String> = a.orders.iter().map(|[o, n]| format!("{o}: {n}")).collect();
        println!(
            "  steps chosen: {} accepted, {} rejected, {} halved after a failed sub-step; {} base steps; orders {}; steps {} … {}; last error estimate {:.2} of the tolerance",
            a.accepted,
            a.rejected,
            a.failed,
            a.base_steps,
            orders.join(", "),
            a.smallest_step
                .map_or("-".to_owned(), |h| format!("{h:.3e}")),
            a.largest_step
                .map_or("-".to_owned(), |h| format!("{h:.3e}")),
            a.error_estimate
        );
    }
}
