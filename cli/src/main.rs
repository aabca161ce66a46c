//! `lieflow`: run, check, print, sweep and stress-test scene files (see `lieflow --help`).
//!
//! The command is thin: it parses flags, calls `lieflow::scene`, prints, writes CSV and plots.
//! Exit codes: 0 success, 1 a run that stopped early (what it computed is still written), 2 bad
//! input (flags or scene).

mod distributed;
mod plot;
mod precision_plot;
mod sweep_plot;

use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use lieflow::scene::{Assembly, DEFAULT_SCENE, RunSummary, Sample, Scene, SceneError, run};
use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

/// Simulate constrained generalized Hamiltonian systems with dissipation, described as scene
/// files (Zhang & Deng 2004 projection integrators).
#[derive(Debug, Parser)]
#[command(name = "lieflow", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Run a scene (the embedded default scene without an argument) and print a summary; the
    /// last line of stdout is a JSON summary.
    Run(RunArgs),
    /// Validate a scene and print what is assembled: bodies, constraints, effects, structure,
    /// the paper's case, the scheme and its order, the solver.
    Check {
        /// The scene file.
        scene: PathBuf,
        /// Print the assembly as one JSON line instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Print the default scene, a starting point for your own.
    Scene,
    /// Work–precision: run a scene with every scheme over a grid of step sizes, and the peer
    /// solvers (DOP853 on the index-1 ODE, Radau5 on the index-3 DAE) over tolerances; print a
    /// table, write a CSV and SVG figures; the last line of stdout is a JSON summary.
    Precision(PrecisionArgs),
    /// The hard-case suite: public test problems (Fekete, Andrews' squeezer, the N-four-bar),
    /// stiff damping and springs, extreme lengths and mass ratios, a nearly singular chain,
    /// redundant constraints, hostile input (and with --long, 10^7-step runs); one row per case,
    /// a JSON line per case with --json, and a final JSON summary. Exit code 1 if a case fails
    /// its checks.
    Stress(StressArgs),
    /// Run a parameter sweep of a scene (a sweep file: the base scene and the fields to vary),
    /// members in parallel; write one row per member (JSONL and CSV, in member order), their
    /// times, and an SVG of an output against a parameter; the last line of stdout is a JSON
    /// summary. A failing member is a row.
    Sweep(SweepArgs),
}

#[derive(Debug, clap::Args)]
struct SweepArgs {
    /// The sweep file.
    sweep: PathBuf,
    /// Write members.jsonl, members.csv, timing.csv and sweep.svg into this directory.
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    /// Threads (default: one per core); each member runs on one.
    #[arg(long, value_name = "N", default_value_t = 0)]
    threads: usize,
    /// Run only the members with these ids (`0..N` ranges or single ids, comma-separated): a
    /// slice of a larger sweep, e.g. one job of a batch array.
    #[arg(long, value_name = "A..B,…", value_delimiter = ',')]
    members: Vec<String>,
}

#[derive(Debug, clap::Args)]
struct StressArgs {
    /// Also run the long cases (10^7 steps each).
    #[arg(long)]
    long: bool,
    /// Run only the cases whose name contains this (repeatable).
    #[arg(long, value_name = "NAME")]
    case: Vec<String>,
    /// List the cases and exit.
    #[arg(long)]
    list: bool,
    /// Print every row as a JSON line (with its checks) instead of the table.
    #[arg(long)]
    json: bool,
}

#[derive(Debug, clap::Args)]
struct PrecisionArgs {
    /// The scene file (default: the embedded default scene).
    scene: Option<PathBuf>,
    /// Step sizes, comma-separated (default: four of the scene's dt times 8, 4, 2, 1, ½, ¼, ⅛
    /// that divide the final time, largest first); a step that does not divide it is a `Setup`
    /// row.
    #[arg(long, value_name = "H,H,…", value_delimiter = ',')]
    dt: Vec<f64>,
    /// Composition orders (default 2,4,6,8; only 2 with damping).
    #[arg(long, value_name = "P,P,…", value_delimiter = ',')]
    orders: Vec<u32>,
    /// Peer tolerances (default 1e-4,1e-6,…,1e-14).
    #[arg(long, value_name = "TOL,…", value_delimiter = ',')]
    tols: Vec<f64>,
    /// Override the scene's final time.
    #[arg(long, value_name = "T")]
    t_end: Option<f64>,
    /// Timed runs after the warm-up (default 3).
    #[arg(long, value_name = "N", default_value_t = 3)]
    repeats: usize,
    /// Leave out the peers.
    #[arg(long)]
    no_peers: bool,
    /// Leave out the implicit schemes (discrete gradient, implicit midpoint, §2).
    #[arg(long)]
    no_implicit: bool,
    /// Compute the reference in double precision even for small scenes (the double-double
    /// reference costs ~20× a double-precision run).
    #[arg(long)]
    f64_reference: bool,
    /// Write `<stem>.csv` and `<stem>_{time,dt,g}.svg` into this directory.
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// File-name stem for the outputs (default: work_precision).
    #[arg(long, value_name = "NAME", default_value = "work_precision")]
    stem: String,
}

#[derive(Debug, clap::Args)]
struct RunArgs {
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

fn main() -> ExitCode {
    let cli = Cli::parse();
    match cli.command {
        Command::Scene => {
            print!("{DEFAULT_SCENE}");
            ExitCode::SUCCESS
        }
        Command::Check { scene, json } => match load(Some(&scene)).and_then(|s| s.compile()) {
            Ok(compiled) => {
                if json {
                    println!(
                        "{}",
                        serde_json::to_string(&compiled.assembly).expect("serializable")
                    );
                } else {
                    print_assembly(&compiled.assembly);
                }
                ExitCode::SUCCESS
            }
            Err(e) => bad_scene(&e),
        },
        Command::Run(args) => run_scene(&args),
        Command::Precision(args) => precision(&args),
        Command::Stress(args) => stress(&args),
        Command::Sweep(args) => sweep(&args),
    }
}

/// Parses `--members` (`a..b` or `i`) against the sweep's size.
fn member_ids(specs: &[String], len: usize) -> Result<Vec<usize>, String> {
    if specs.is_empty() {
        return Ok((0..len).collect());
    }
    let mut ids = Vec::new();
    for s in specs {
        let (a, b) = match s.split_once("..") {
            Some((a, b)) => (a.trim().parse::<usize>(), b.trim().parse::<usize>()),
            None => (
                s.trim().parse::<usize>(),
                s.trim().parse::<usize>().map(|v| v + 1),
            ),
        };
        let (Ok(a), Ok(b)) = (a, b) else {
            return Err(format!("--members: '{s}' is not an id or a range a..b"));
        };
        if a >= b || b > len {
            return Err(format!(
                "--members: '{s}' is empty or beyond the sweep's {len} members"
            ));
        }
        ids.extend(a..b);
    }
    ids.sort_unstable();
    ids.dedup();
    Ok(ids)
}

fn sweep(args: &SweepArgs) -> ExitCode {
    use lieflow_lab::sweep::{OUTPUTS, Sweep, run_all, to_jsonl};
    let sweep = match Sweep::from_path(&args.sweep) {
        Ok(s) => s,
        Err(e) => return bad_scene(&e),
    };
    let ids = match member_ids(&args.members, sweep.len()) {
        Ok(ids) => ids,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    // Under mpirun (feature `mpi`), rank r of n runs every n-th member; rank 0 gathers.
    let ranks = distributed::Ranks::init();
    let members: Vec<_> = ids
        .iter()
        .enumerate()
        .filter(|(k, _)| k % ranks.size == ranks.rank)
        .map(|(_, &i)| sweep.member(i))
        .collect();
    // Only rank 0 writes; every rank reaches the gather (a rank that left early would block it).
    if ranks.rank == 0
        && let Err(e) = std::fs::create_dir_all(&args.out)
    {
        eprintln!("error: cannot create {}: {e}", args.out.display());
        return ExitCode::from(2);
    }
    let bar = if ranks.size == 1 && std::io::IsTerminal::is_terminal(&std::io::stderr()) {
        let b = ProgressBar::new(members.len() as u64);
        b.set_style(
            ProgressStyle::with_template("{bar:40} {pos}/{len} members, {per_sec}, eta {eta}")
                .expect("valid template"),
        );
        Some(b)
    } else {
        None
    };
    let start = std::time::Instant::now();
    let rows = match run_all(&sweep, &members, args.threads, &|| {
        if let Some(b) = &bar {
            b.inc(1);
        }
    }) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(1);
        }
    };
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    let rows = match ranks.gather(rows) {
        Ok(Some(rows)) => rows,
        Ok(None) => return ExitCode::SUCCESS, // not rank 0: its rows went there
        Err(e) => {
            eprintln!("error: gathering the rows: {e}");
            return ExitCode::from(1);
        }
    };
    let seconds = start.elapsed().as_secs_f64();
    let threads = if args.threads == 0 {
        std::thread::available_parallelism().map_or(1, |n| n.get())
    } else {
        args.threads
    };
    let member_rows: Vec<_> = rows.iter().map(|(r, _)| r.clone()).collect();
    let failed = member_rows.iter().filter(|r| r.error.is_some()).count();
    // Files: the deterministic rows (JSONL, CSV), the times apart.
    let mut csv = String::from("id");
    for p in &sweep.file.parameters {
        csv.push_str(&format!(",{}", p.path));
    }
    for o in OUTPUTS {
        csv.push_str(&format!(",{o}"));
    }
    csv.push_str(",error\n");
    for r in &member_rows {
        csv.push_str(&r.id.to_string());
        for (_, v) in &r.parameters {
            csv.push_str(&format!(",{v:?}"));
        }
        for o in OUTPUTS {
            csv.push_str(&r.output(o).map_or_else(String::new, |v| format!(",{v:?}")));
            if r.output(o).is_none() {
                csv.push(',');
            }
        }
        csv.push_str(&format!(
            ",{}\n",
            r.error.as_ref().map_or("", |e| e.0.as_str())
        ));
    }
    let timing: String = std::iter::once("id,seconds\n".to_owned())
        .chain(rows.iter().map(|(r, t)| format!("{},{t:e}\n", r.id)))
        .collect();
    let write = |name: &str, text: &str| {
        std::fs::write(args.out.join(name), text).map_err(|e| format!("writing {name}: {e}"))
    };
    if let Err(e) = write("members.jsonl", &to_jsonl(&member_rows))
        .and_then(|_| write("members.csv", &csv))
        .and_then(|_| write("timing.csv", &timing))
    {
        eprintln!("error: {e}");
        return ExitCode::from(1);
    }
    let mut plot = None;
    if let Some(p) = &sweep.file.plot {
        let path = args.out.join("sweep.svg");
        match sweep_plot::scatter(
            &path,
            &format!("{} against {}", p.y, p.x),
            &p.x,
            &p.y,
            &member_rows,
        ) {
            Ok(()) => plot = Some(path.display().to_string()),
            Err(e) => eprintln!("warning: plot not written: {e}"),
        }
    }
    // The table: each output's range over the members that report it.
    println!(
        "{} members ({} failed) on {} x {threads} threads in {seconds:.2} s: {:.1} members/s",
        member_rows.len(),
        failed,
        ranks.size,
        member_rows.len() as f64 / seconds
    );
    println!("{:<22} {:>13} {:>13}", "output", "min", "max");
    for o in OUTPUTS {
        let v: Vec<f64> = member_rows
            .iter()
            .filter_map(|r| r.output(o))
            .filter(|v| v.is_finite())
            .collect();
        if v.is_empty() {
            continue;
        }
        let (lo, hi) = v
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
                (a.min(x), b.max(x))
            });
        println!("{o:<22} {lo:>13.6e} {hi:>13.6e}");
    }
    for r in member_rows.iter().filter(|r| r.error.is_some()).take(5) {
        let (k, m) = r.error.as_ref().expect("filtered");
        println!("member {} failed ({k}): {m}", r.id);
    }
    println!(
        "{}",
        serde_json::json!({
            "command": "sweep",
            "members": member_rows.len(),
            "failed": failed,
            "ranks": ranks.size,
            "threads": threads,
            "seconds": seconds,
            "members_per_second": member_rows.len() as f64 / seconds,
            "out": args.out.display().to_string(),
            "plot": plot,
        })
    );
    ExitCode::SUCCESS
}

fn stress(args: &StressArgs) -> ExitCode {
    use lieflow_lab::stress::{cases, run_case};
    let selected: Vec<_> = cases()
        .into_iter()
        .filter(|c| args.long || !c.long)
        .filter(|c| args.case.is_empty() || args.case.iter().any(|n| c.name.contains(n.as_str())))
        .collect();
    if selected.is_empty() {
        eprintln!(
            "error: no case matches {:?} (see lieflow stress --list)",
            args.case
        );
        return ExitCode::from(2);
    }
    if args.list {
        for c in &selected {
            let long = if c.long { " (long)" } else { "" };
            println!(
                "{:<24} {}{long}\n{:<24} source: {}",
                c.name, c.about, "", c.source
            );
        }
        return ExitCode::SUCCESS;
    }
    let sci = |v: Option<f64>| v.map_or_else(|| "-".to_owned(), |v| format!("{v:.1e}"));
    if !args.json {
        println!(
            "{:<24} {:>9} {:>8} {:>8} {:>6} {:>8} {:>7}  {:<5} outcome / energy",
            "case", "steps", "max|g|", "max|phi|", "newton", "cond", "time s", "pass"
        );
    }
    let (mut passed, mut failed) = (0, Vec::new());
    let start = std::time::Instant::now();
    for case in &selected {
        let row = run_case(case);
        if row.passed {
            passed += 1;
        } else {
            failed.push(row.case.clone());
        }
        if args.json {
            println!("{}", serde_json::to_string(&row).expect("serializable"));
            continue;
        }
        println!(
            "{:<24} {:>9} {:>8} {:>8} {:>6} {:>8} {:>7.2}  {:<5} {}",
            row.case,
            row.steps,
            sci(row.max_g),
            sci(row.max_phi),
            row.newton_max,
            sci(row.condition),
            row.seconds,
            if row.passed { "yes" } else { "NO" },
            row.outcome
        );
        println!("{:<24} scheme: {}", "", row.scheme);
        if row.energy != "-" {
            println!("{:<24} energy: {}", "", row.energy);
        }
        for c in &row.checks {
            println!(
                "{:<24} {} {:.3e} <= {:.3e}{}",
                "",
                c.what,
                c.value,
                c.bound,
                if c.passed { "" } else { "  FAILED" }
            );
        }
    }
    println!(
        "{}",
        serde_json::json!({
            "command": "stress",
            "cases": selected.len(),
            "passed": passed,
            "failed": failed,
            "long": args.long,
            "seconds": start.elapsed().as_secs_f64(),
        })
    );
    if failed.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    }
}

fn load(path: Option<&PathBuf>) -> Result<Scene, SceneError> {
    match path {
        Some(p) => Scene::from_path(p),
        None => Ok(Scene::default_scene()),
    }
}

fn bad_scene(e: &SceneError) -> ExitCode {
    eprintln!("error: {e}");
    ExitCode::from(2)
}

fn print_assembly(a: &Assembly) {
    println!("scene        {}", a.name);
    if let Some(d) = a.dim {
        println!(
            "space        {d}D, {} bodies, state of {}",
            a.bodies, a.state_len
        );
    } else {
        println!("model        built-in, state of {}", a.state_len);
    }
    if a.constraints.is_empty() {
        println!("constraints  none");
    } else {
        let list: Vec<String> = a
            .constraints
            .iter()
            .map(|(k, n)| format!("{n} {k}"))
            .collect();
        println!(
            "constraints  {} rows: {}",
            a.constraint_rows,
            list.join(", ")
        );
    }
    for (i, (label, kind)) in a.effects.iter().enumerate() {
        let head = if i == 0 { "effects" } else { "" };
        println!("{head:<12} {label} ({kind})");
    }
    for d in &a.disabled {
        println!("switched off {d}");
    }
    println!(
        "structure    {}, {}",
        if a.canonical {
            "J canonical"
        } else {
            "J non-canonical (magnetic field)"
        },
        if a.dissipative {
            "dissipative (M = J - R)"
        } else {
            "conservative"
        }
    );
    if let Some(case) = &a.case {
        println!("case         {case} (Zhang & Deng 2004)");
    }
    if let Some(p) = &a.projection {
        println!("projection   {p}");
    }
    println!("scheme       {}, order {}", a.scheme, a.order);
    if let Some(s) = &a.solver {
        println!("solver       {s}");
    }
    println!("steps        {}", a.steps);
    if let Some((dq, dp)) = a.initial_projection {
        println!("projected    initial state moved by max |dq| = {dq:.3e}, max |dp| = {dp:.3e}");
    }
    if !a.dropped_constraints.is_empty() {
        println!(
            "dropped      redundant: {}",
            a.dropped_constraints.join(", ")
        );
    }
}

fn run_scene(args: &RunArgs) -> ExitCode {
    let mut scene = match load(args.scene.as_ref()) {
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
        if let Err(e) = scene.file.flags.set(name, false) {
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
    if args.profile
        && !scene
            .file
            .integrator
            .diagnostics
            .iter()
            .any(|d| d == "profile")
    {
        scene.file.integrator.diagnostics.push("profile".into());
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
        Some(p) => match std::fs::File::create(p) {
            Ok(f) => Some(std::io::BufWriter::new(f)),
            Err(e) => {
                eprintln!("error: cannot create {}: {e}", p.display());
                return ExitCode::from(2);
            }
        },
        None => None,
    };
    let bodies = compiled.simulation.bodies();
    let mut series = plot::Series::new(steps, bodies);
    let bar = ProgressBar::new(steps as u64);
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} steps, {elapsed} (eta {eta})")
            .expect("valid template"),
    );
    let tick = (steps / 200).max(1);
    let mut io_error = None;
    if let Some(w) = csv.as_mut() {
        let n = compiled.simulation.state().len();
        if let Err(e) = write_header(w, n, &compiled.assembly) {
            io_error.get_or_insert(e);
        }
    }
    // The last state seen and whether it was written: a run that stops early still ends its
    // CSV and plot with its last good state.
    let mut last = (0usize, 0.0f64, None, None, None);
    let mut last_written = true;
    let mut observe = |s: &Sample<'_>| {
        if s.step.is_multiple_of(tick) {
            bar.set_position(s.step as u64);
        }
        if args.plot.is_some() {
            series.push(s, false);
        }
        last = (s.step, s.t, s.energy, s.g, s.phi);
        last_written = false;
        if let Some(w) = csv.as_mut()
            && (s.step.is_multiple_of(every) || s.step == steps)
        {
            last_written = true;
            if let Err(e) = write_row(w, s) {
                io_error.get_or_insert(e);
            }
        }
    };
    let summary = run(compiled.simulation.as_mut(), &compiled.plan, &mut observe);
    bar.finish_and_clear();
    let final_sample = Sample {
        step: last.0,
        t: last.1,
        x: compiled.simulation.state(),
        energy: last.2,
        g: last.3,
        phi: last.4,
    };
    if args.plot.is_some() {
        series.push(&final_sample, true);
    }
    if !last_written
        && let Some(w) = csv.as_mut()
        && let Err(e) = write_row(w, &final_sample)
    {
        io_error.get_or_insert(e);
    }
    if let Some(mut w) = csv
        && let Err(e) = w.flush()
    {
        io_error.get_or_insert(e);
    }
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

fn print_summary(s: &RunSummary) {
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
    if let Some(d) = s.dissipated {
        println!(
            "  dissipated {d:.9}, energy budget error {}",
            opt(s.max_energy_balance_error)
        );
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

fn write_header(w: &mut impl Write, n: usize, a: &Assembly) -> std::io::Result<()> {
    writeln!(
        w,
        "# lieflow {} scene: {}; scheme: {}",
        env!("CARGO_PKG_VERSION"),
        a.name,
        a.scheme
    )?;
    write!(w, "step,t")?;
    for i in 0..n {
        write!(w, ",x{i}")?;
    }
    writeln!(w, ",energy,max_abs_g,max_abs_phi")
}

fn write_row(w: &mut impl Write, s: &Sample<'_>) -> std::io::Result<()> {
    write!(w, "{},{}", s.step, s.t)?;
    for v in s.x {
        write!(w, ",{v}")?;
    }
    let opt = |v: Option<f64>| v.map_or_else(String::new, |v| v.to_string());
    writeln!(w, ",{},{},{}", opt(s.energy), opt(s.g), opt(s.phi))
}

fn precision(args: &PrecisionArgs) -> ExitCode {
    use lieflow_lab::precision::{
        PrecisionPlan, fitted_slopes, fitting_window, reference, work_precision, write_csv,
    };
    let mut scene = match load(args.scene.as_ref()) {
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
    let mut plan = PrecisionPlan::around(scene.file.integrator.dt, scene.file.integrator.t_end);
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
    plan.peers = !args.no_peers;
    if args.no_implicit {
        plan.discrete_gradient = false;
        plan.midpoint = false;
        plan.modified = false;
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
    let rows = work_precision(&scene, &plan, &reference, &mut |r| {
        rows_done += 1;
        bar.set_message(format!("{rows_done} runs"));
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
    });
    bar.finish_and_clear();
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
    });
    println!("{json}");
    code
}

/// What this machine is, for the CSV's comment lines.
fn machine() -> String {
    let cores = std::thread::available_parallelism().map_or(0, |n| n.get());
    format!(
        "{} {}, {cores} cores",
        std::env::consts::OS,
        std::env::consts::ARCH
    )
}

/// The git revision of the working directory, if there is one.
fn revision() -> String {
    std::process::Command::new("git")
        .args(["rev-parse", "--short", "HEAD"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_owned())
        .unwrap_or_else(|| "unknown".to_owned())
}
