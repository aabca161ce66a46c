//! An `N`-link pendulum chain (Cartesian coordinates, pinned at the origin, gravity) by RATTLE —
//! the projected kick–drift–kick — with the multiplier systems solved by sparse or dense LU.
//!
//! The chain has total length 1 (`N` links of length `1/N`, unit masses, gravity 1) and starts
//! at rest with link `i` at angle `0.1 sin(π i/N)` from the downward vertical. Every step
//! is checked: `max_abs_g` and `max_abs_phi` are the worst constraint and hidden-constraint
//! residuals over all steps, `energy_max_err` the worst `|H − H₀|`. `ns_per_step` times the steps
//! only (not the checks); `peak_rss_mb` is the process's peak resident memory (Linux).
//! RATTLE is explicit in the chain's transverse waves: keep `--dt` below about `1/N`.
//!
//! ```text
//! cargo run --release --example chain -- --links 100000 --steps 100 --dt 1e-6
//! cargo run --release --example chain -- --links 50 --solver dense
//! ```

mod common;

use common::{Args, Json, fatal};
use faer::Col;
use lieflow::linalg::{LinearSolver, SolverChoice, SolverKind};
use lieflow::models::PendulumChain;
use lieflow::prelude::*;
use std::time::Instant;

type V = Col<f64>;

/// Peak resident set size in MB from `/proc/self/status` (`VmHWM`), where the platform has it.
fn peak_rss_mb() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1024.0)
}

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0f64, |m, x| m.max(x.abs()))
}

fn main() {
    let args = Args::parse(
        "N-link pendulum chain by RATTLE with sparse multiplier solves",
        &[
            ("links", "N", "number of links, 1..=1000000 (default 1000)"),
            ("steps", "K", "number of steps (default 1000)"),
            ("dt", "H", "step size (default 1e-4)"),
            ("dim", "2|3", "planar or spatial chain (default 2)"),
            (
                "solver",
                "auto|dense|sparse",
                "linear solver backend: auto|dense|sparse|banded (default auto)",
            ),
            (
                "print-every",
                "K",
                "progress line every K steps (default steps/10)",
            ),
        ],
    );
    let n: usize = args.get("links", 1000);
    let steps: usize = args.get("steps", 1000);
    let dt = args.positive("dt", 1e-4);
    let dim: usize = args.get("dim", 2);
    let solver = args.opt("solver").unwrap_or("auto").to_string();
    let choice = match solver.as_str() {
        "auto" => SolverChoice::Auto,
        "dense" => SolverChoice::Force(SolverKind::Dense),
        "sparse" => SolverChoice::Force(SolverKind::Sparse),
        "banded" => SolverChoice::Force(SolverKind::Banded),
        other => args.fail(&format!("unknown solver '{other}'")),
    };
    if n == 0 || n > 1_000_000 {
        args.fail("--links must be between 1 and 1000000");
    }
    if steps == 0 {
        args.fail("--steps must be at least 1");
    }
    if dim != 2 && dim != 3 {
        args.fail("--dim must be 2 or 3");
    }
    if solver == "dense" && n > 5000 {
        args.fail("--solver dense stores N x N matrices: use at most 5000 links");
    }
    let every: usize = args.get("print-every", (steps / 10).max(1)).max(1);

    let model = PendulumChain::<f64>::uniform(dim, n).unwrap_or_else(|e| fatal(&e));
    let x0: V = model.at_rest(|i| 0.1 * (std::f64::consts::PI * i as f64 / n as f64).sin());
    let options = model.projection_options();
    let options = options.with_newton(options.newton.with_solver(choice));
    let setup = Instant::now();
    let mut flow = model
        .kick::<V>()
        .strang(model.drift())
        .projected(model.system(), &x0, options)
        .unwrap_or_else(|e| fatal(&e));
    let setup_ms = setup.elapsed().as_secs_f64() * 1e3;
    let backend = match flow.newton().linear_solver().kind() {
        SolverKind::Stack => "stack",
        SolverKind::Dense => "dense",
        SolverKind::Sparse => "sparse",
        SolverKind::Banded => "banded",
    };
    println!(
        "chain: {n} links in {dim}D, h = {dt}, {steps} steps, {backend} LU (set up in {setup_ms:.1} ms)"
    );

    let sys = model.system();
    let m = model.constraints();
    let (mut g, mut phi) = (vec![0.0; m], vec![0.0; m]);
    let (mut t1, mut t2) = (x0.clone(), x0.clone());
    let e0 = model.energy(&x0);
    let mut x = x0.clone();
    let (mut max_g, mut max_phi, mut max_de) = (0.0f64, 0.0f64, 0.0f64);
    let mut stepping = std::time::Duration::ZERO;
    for k in 1..=steps {
        let start = Instant::now();
        if let Err(e) = flow.step(dt, &mut x) {
            fatal(&format!("step {k}: {e}"));
        }
        stepping += start.elapsed();
        sys.constraint.residual(&x, &mut g);
        sys.hidden_constraint(&x, &mut t1, &mut t2, &mut phi);
        let (gk, pk) = (max_abs(&g), max_abs(&phi));
        let de = (model.energy(&x) - e0).abs();
        max_g = max_g.max(gk);
        max_phi = max_phi.max(pk);
        max_de = max_de.max(de);
        if k % every == 0 || k == steps {
            println!(
                "t = {:8.4}  |g| = {gk:.2e}  |phi| = {pk:.2e}  |H - H0| = {de:.2e}",
                k as f64 * dt
            );
        }
    }
    let stats = flow.stats();
    let ns_per_step = stepping.as_nanos() as f64 / steps as f64;
    println!(
        "max |g| {max_g:.2e}, max |phi| {max_phi:.2e}, max |H - H0| {max_de:.2e}; {:.2} Newton iterations and {:.2} factorizations per step; {:.3} ms/step",
        stats.newton_iterations as f64 / steps as f64,
        stats.factorizations as f64 / steps as f64,
        ns_per_step * 1e-6
    );
    let mut json = Json::default()
        .num("t", steps as f64 * dt)
        .int("steps", steps as u64)
        .int("links", n as u64)
        .int("dim", dim as u64)
        .str("solver", backend)
        .num("max_abs_g", max_g)
        .num("max_abs_phi", max_phi)
        .num("energy_max_err", max_de)
        .num("energy", e0)
        .int("newton_iterations", stats.newton_iterations)
        .int("factorizations", stats.factorizations)
        .int("residual_evaluations", stats.residual_evaluations)
        .num("ns_per_step", ns_per_step)
        .num("setup_ms", setup_ms);
    if let Some(mb) = peak_rss_mb() {
        json = json.num("peak_rss_mb", mb);
    }
    json.print();
}
