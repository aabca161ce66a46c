//! `lieflow precision`: work–precision sets of a scene against a reference and the peer
//! solvers; a table, CSV, SVG figures and a final JSON summary.

use crate::{bad_scene, load, precision_plot};
use lieflow::scene::Scene;

/// The scene `lieflow precision` measures without an argument: small and damped, its sets
/// (every scheme, the peers, a double-double reference) done in seconds.
const DEFAULT_PRECISION_SCENE: &str = include_str!("../../scenes/damped_pendulum.toml");
use indicatif::ProgressBar;
use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Debug, clap::Args)]
pub(crate) struct PrecisionArgs {
    /// The scene file (default: the damped pendulum, scenes/damped_pendulum.toml, whose
    /// sets take a few seconds; the run's default scene, twelve bodies at dt = 1e-4, would take
    /// many minutes).
    scene: Option<PathBuf>,
    /// Step sizes, comma-separated (default: four of the scene's dt times 8, 4, 2, 1, ½, ¼, ⅛
    /// that divide the final time, largest first); a step that does not divide it is a `Setup`
    /// row.
    #[arg(long, value_name = "H,H,…", value_delimiter = ',')]
    dt: Vec<f64>,
    /// Orders of the splitting (default 2,4,6,8): compositions, or with damping extrapolations.
    #[arg(long, value_name = "P,P,…", value_delimiter = ',')]
    orders: Vec<u32>,
    /// Tolerances for the peers and for lieflow's adaptive extrapolation (default
    /// 1e-4,1e-6,…,1e-14); the adaptive runs report once, at the final time, the controller
    /// choosing every step and order (scenes of bodies).
    #[arg(long, value_name = "TOL,…", value_delimiter = ',')]
    tols: Vec<f64>,
    /// Leave out lieflow's adaptive extrapolation.
    #[arg(long)]
    no_adaptive: bool,
    /// Override the scene's final time.
    #[arg(long, value_name = "T")]
    t_end: Option<f64>,
    /// Timed runs after the warm-up (default 3).
    #[arg(long, value_name = "N", default_value_t = 3)]
    repeats: usize,
    /// Leave out the peers.
    #[arg(long)]
    no_peers: bool,
    /// Leave out the implicit schemes (discrete gradient, implicit midpoint, §2, Petrov–Galerkin).
    #[arg(long)]
    no_implicit: bool,
    /// Compute the reference in double precision even for small scenes (the double-double
    /// reference costs ~20× a double-precision run).
    #[arg(long)]
    f64_reference: bool,
    /// Compute the reference with the energy-consistent Petrov–Galerkin scheme of order 6 (in
    /// double precision, at an eighth and a sixteenth of the smallest step): for stiff damping,
    /// where a splitting's error expansion in h² breaks down and its extrapolation is no
    /// reference.
    #[arg(long)]
    implicit_reference: bool,
    /// The scene's motion is periodic and its final time a whole number of periods (a Kepler
    /// orbit over whole periods, say): the reference is its initial state, exact.
    #[arg(long)]
    periodic: bool,
    /// Write `<stem>.csv` and `<stem>_{time,dt,g}.svg` into this directory.
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// File-name stem for the outputs (default: work_precision).
    #[arg(long, value_name = "NAME", default_value = "work_precision")]
    stem: String,
}

pub(crate) fn precision(args: &PrecisionArgs) -> ExitCode {
    use lieflow_lab::precision::{
        PrecisionPlan, fitted_slopes, fitting_window, reference, work_precision_until, write_csv,
    };
    let loaded = match &args.scene {
        Some(p) => load(Some(p)),
        None => Scene::from_toml(DEFAULT_PRECISION_SCENE, "damped pendulum (built in)"),
    };
    let mut scene = match loaded {
        Ok(s) => s,
        Err(e) => return bad_scene(&e),
    };
    if let Some(t) = args.t_end {
        if !(t.is_finite() && t > 0.0) {
            eprintln!("error: --t-end must be positive and finite, not {t}");
            return ExitCode::from(2);
        }
        scene.file.integrator.t_end = t;
    }
    let mut plan = PrecisionPlan::around(scene.file.integrator.step(), scene.file.integrator.t_end);
    if !args.dt.is_empty() {
        plan.dts = args.dt.clone();
    }
    if !args.orders.is_empty() {
        plan.orders = args.orders.clone();
    }
    if !args.tols.is_empty() {
        plan.tolerances = args.tols.clone();
    }
    if let Some(bad) = plan
        .dts
        .iter()
        .chain(&plan.tolerances)
        .find(|v| !(v.is_finite() && **v > 0.0))
    {
        eprintln!("error: step sizes and tolerances must be positive and finite, not {bad}");
        return ExitCode::from(2);
    }
    plan.repeats = args.repeats;
    plan.double_double = !args.f64_reference;
    plan.implicit_reference = args.implicit_reference;
    plan.periodic = args.periodic;
    plan.peers = !args.no_peers;
    plan.adaptive = !args.no_adaptive;
    if args.no_implicit {
        plan.discrete_gradient = false;
        plan.midpoint = false;
        plan.modified = false;
        plan.petrov_galerkin.clear();
    }
    let name = match scene.compile() {
        Ok(c) => c.assembly.name,
        Err(e) => return bad_scene(&e),
    };
    eprintln!("computing the reference …");
    let reference = match reference(&scene, &plan) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(1);
        }
    };
    // From here on the first Ctrl-C stops the set after the run in progress, and what was
    // measured is kept: the table, the fitted orders, the CSV and figures, the summary (exit
    // 130). Before, while the reference is computed, Ctrl-C ends the command: there is nothing
    // to keep yet.
    crate::interrupt::catch_interrupt();
    let interrupted = &crate::interrupt::INTERRUPTED;
    println!(
        "{name}: T = {}, reference: {} (its error ~ {})",
        reference.t,
        reference.source,
        reference
            .error_estimate
            .map_or_else(|| "round-off".to_owned(), |e| format!("{e:.1e}"))
    );
    println!(
        "{:<28} {:>10} {:>10} {:>9} {:>9} {:>9} {:>9} {:>9} {:>10} {:>10}  status",
        "method", "h", "tol", "error", "max|g|", "max|phi|", "energy", "evals", "min s", "median s"
    );
    let f = |v: Option<f64>| v.map_or_else(|| "-".to_owned(), |v| format!("{v:.2e}"));
    let bar = ProgressBar::new_spinner();
    let mut rows_done = 0usize;
    let started = std::time::Instant::now();
    let quiet_bar = bar.is_hidden();
    let rows = work_precision_until(
        &scene,
        &plan,
        &reference,
        &mut |r| {
            rows_done += 1;
            bar.set_message(format!("{rows_done} runs"));
            if quiet_bar {
                // No terminal for the spinner: a line of progress per run on stderr.
                eprintln!(
                    "  [{rows_done} runs, {:.1} s] {} {}",
                    started.elapsed().as_secs_f64(),
                    r.method,
                    r.dt.or(r.tol)
                        .map_or_else(String::new, |v| format!("{v:e}"))
                );
            }
            bar.suspend(|| {
                println!(
                    "{:<28} {:>10} {:>10} {:>9} {:>9} {:>9} {:>9} {:>9} {:>10} {:>10}  {}{}",
                    r.method,
                    f(r.dt),
                    f(r.tol),
                    f(r.error),
                    f(r.max_abs_g),
                    f(r.max_abs_phi),
                    f(r.energy_error),
                    r.evaluations,
                    f(r.time_min),
                    f(r.time_median),
                    r.status,
                    if r.message.is_empty() {
                        String::new()
                    } else {
                        format!(": {}", r.message)
                    }
                )
            });
        },
        interrupted,
    );
    bar.finish_and_clear();
    let stopped = interrupted.load(std::sync::atomic::Ordering::SeqCst);
    if stopped {
        eprintln!(
            "interrupted: {} runs measured; writing what they measured",
            rows.len()
        );
    }
    let h_min = plan.dts.iter().copied().fold(f64::INFINITY, f64::min);
    let (floor, ceiling) = fitting_window(&reference, h_min);
    let slopes = fitted_slopes(&rows, floor, ceiling);
    for (m, s) in &slopes {
        println!("fitted order {m}: {s:.2}");
    }
    let mut outputs = Vec::new();
    let mut code = ExitCode::SUCCESS;
    if let Some(dir) = &args.out {
        let written = std::fs::create_dir_all(dir)
            .map_err(|e| e.to_string())
            .and_then(|()| {
                let path = dir.join(format!("{}.csv", args.stem));
                let mut w = std::io::BufWriter::new(
                    std::fs::File::create(&path).map_err(|e| e.to_string())?,
                );
                let comments = [
                    ("scene", name.clone()),
                    ("machine", machine()),
                    ("revision", revision()),
                    ("lieflow", env!("CARGO_PKG_VERSION").to_owned()),
                    ("final time", reference.t.to_string()),
                    (
                        "reference",
                        format!(
                            "{} (error estimate {})",
                            reference.source,
                            reference
                                .error_estimate
                                .map_or_else(|| "round-off".to_owned(), |e| format!("{e:e}"))
                        ),
                    ),
                ];
                write_csv(&mut w, &comments, &rows, &slopes).map_err(|e| e.to_string())?;
                w.flush().map_err(|e| e.to_string())?;
                let mut paths = vec![path.display().to_string()];
                paths.extend(
                    precision_plot::figures(dir, &args.stem, &name, &rows, &slopes)
                        .map_err(|e| e.to_string())?,
                );
                Ok(paths)
            });
        match written {
            Ok(p) => {
                for path in &p {
                    println!("wrote {path}");
                }
                outputs = p;
            }
            Err(e) => {
                eprintln!("error: writing the outputs: {e}");
                code = ExitCode::from(1);
            }
        }
    }
    let failed = rows
        .iter()
        .filter(|r| r.status != "ok" && r.status != "Skipped")
        .count();
    let fitted: serde_json::Map<String, serde_json::Value> = slopes
        .iter()
        .map(|(m, s)| (m.clone(), (*s).into()))
        .collect();
    // The DESIGN §6 fields: the reference state as `x`, all steps taken, the worst constraint
    // residual of the lieflow runs, and the cheapest lieflow step.
    let lieflow_rows = || {
        rows.iter()
            .filter(|r| r.status == "ok" && r.method.starts_with("lieflow"))
    };
    let max_g = lieflow_rows()
        .filter_map(|r| r.max_abs_g)
        .fold(0.0f64, f64::max);
    let ns_per_step = lieflow_rows()
        .filter_map(|r| Some(r.time_min? * 1e9 / r.steps.max(1) as f64))
        .fold(f64::INFINITY, f64::min);
    let json = serde_json::json!({
        "scene": name,
        "t": reference.t,
        "x": reference.x,
        "steps": rows.iter().map(|r| r.steps).sum::<u64>(),
        "max_abs_g": max_g,
        "ns_per_step": ns_per_step.is_finite().then_some(ns_per_step),
        "reference": reference.source,
        "reference_error": reference.error_estimate,
        "rows": rows.len(),
        "failed": failed,
        "fitted_orders": fitted,
        "outputs": outputs,
        "interrupted": stopped,
    });
    println!("{json}");
    if stopped {
        return ExitCode::from(crate::interrupt::EXIT_INTERRUPTED);
    }
    code
}

/// What this machine is, for the CSV's comment lines.
pub(crate) fn machine() -> String {
    let cores = std::thread::available_parallelism().map_or(0, |n| n.get());
    format!(
        "{} {}, {cores} cores",
        std::env::consts::OS,
        std::env::consts::ARCH
    )
}

/// The git revision of the working directory, if there is one.
pub(crate) fn revision() -> String {
    std::process::Command::new("git")
        .args(["rev-parse", "--short", "HEAD"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_owned())
        .unwrap_or_else(|| "unknown".to_owned())
}
