//! Work against precision on a damped problem, both sides hand-written: the damped pendulum
//! (`models::DampedPendulum`, damping 0.5, from the horizontal at rest, `T = 10`) by lieflow's
//! extrapolated projected Strang step of orders 4, 6, 8 — every sub-step forward, so the
//! damping never runs backwards — and by a peer's DOP853 on the index-1 ODE with its multiplier
//! in closed form, in one process.
//!
//! ```text
//! cargo run --release -p lieflow-lab --example damped_high_order
//! cargo run --release -p lieflow-lab --example damped_high_order -- --repeat 5 --t-end 20
//! ```
//!
//! The peer is the lab's DOP853 (`lieflow_lab::peers::dop853`: Hairer's 8(5,3) pair as his
//! `dop853.f` runs it, 12 right-hand sides a step, no allocation) on `q' = p`,
//! `p' = −q μ − c p − e_y`, `μ = (|p|² − y)/|q|²` (from `d/dt (q·p) = 0`): a right-hand side of a
//! dozen flops, the peer at its best on this problem. lieflow
//! runs the model's own exact damped flow (`LinearFlow`) inside the projection. The error of
//! every run is measured at `T` against a reference that neither side produced alone: the
//! peer at tolerance 1e-15 and lieflow's order 8 at `h = 1/400`, which must agree (their gap is
//! printed). Times are the best of `--repeat` runs, nothing observed.
//!
//! The last line of stdout is a JSON summary: for each target error 1e-6, 1e-8, 1e-10, the
//! fastest lieflow run that reaches it, the fastest peer run that reaches it, and their ratio.

use lieflow::models::DampedPendulum;
use lieflow::prelude::*;
use lieflow_lab::peers::dop853::Dop853;
use nalgebra::SVector;
use std::time::Instant;

type V = SVector<f64, 4>;

const C: f64 = 0.5;

/// Prints the message and exits with status 1.
fn fatal(message: &dyn std::fmt::Display) -> ! {
    eprintln!("error: {message}");
    std::process::exit(1)
}

/// The index-1 right-hand side of the damped pendulum.
fn index1(x: &[f64], dx: &mut [f64]) {
    let mu = (x[2] * x[2] + x[3] * x[3] - x[1]) / (x[0] * x[0] + x[1] * x[1]);
    dx[0] = x[2];
    dx[1] = x[3];
    dx[2] = -x[0] * mu - C * x[2];
    dx[3] = -1.0 - x[1] * mu - C * x[3];
}

/// `--name value` from the command line, parsed, or `default`.
fn flag<T: std::str::FromStr>(name: &str, default: T) -> T {
    let args: Vec<String> = std::env::args().collect();
    if args.iter().any(|a| a == "--help" || a == "-h") {
        println!(
            "Damped pendulum work-precision: lieflow's extrapolated projections (orders 4, 6, 8, \
             positive sub-steps) against DOP853 with a closed-form right-hand side.\n\n\
             Options:\n  --t-end T    final time (default 10)\n  --repeat N   timed runs per configuration, best kept (default 3)"
        );
        std::process::exit(0);
    }
    match args.iter().position(|a| a == &format!("--{name}")) {
        None => default,
        Some(i) => args
            .get(i + 1)
            .and_then(|v| v.parse().ok())
            .unwrap_or_else(|| fatal(&format!("--{name} needs a valid value"))),
    }
}

struct Row {
    method: String,
    setting: String,
    x: [f64; 4],
    max_g: f64,
    ms: f64,
    evaluations: u64,
}

fn g(x: &[f64]) -> f64 {
    0.5 * (x[0] * x[0] + x[1] * x[1] - 1.0)
}

fn x0() -> V {
    DampedPendulum::try_new(C)
        .unwrap()
        .state(std::f64::consts::FRAC_PI_2, 0.0)
}

fn peer(tol: f64, t_end: f64, repeat: usize) -> Row {
    let start: [f64; 4] = x0().into();
    let run = || {
        let mut x = start;
        let clock = Instant::now();
        let stats = Dop853::new(4, tol, tol)
            .solve(|_, x, dx| index1(x, dx), &mut x, t_end, |_, _| {})
            .unwrap_or_else(|e| fatal(&format!("DOP853 at tol {tol:e}: {e}")));
        (x, clock.elapsed().as_secs_f64(), stats.evaluations)
    };
    let (x, _, evaluations) = run();
    let best = (0..repeat).map(|_| run().1).fold(f64::INFINITY, f64::min);
    Row {
        method: "DOP853 (index-1 ODE)".into(),
        setting: format!("tol {tol:.2e}"),
        x,
        max_g: g(&x).abs(),
        ms: best * 1e3,
        evaluations,
    }
}

fn lieflow_run(order: u32, dt: f64, t_end: f64, repeat: usize) -> Row {
    let model = DampedPendulum::try_new(C).unwrap();
    let start = x0();
    let build = || -> Box<dyn Flow<V>> {
        let projected = model
            .free_flow()
            .and_then(|f| f.projected(model.system(), &start, ProjectionOptions::default()))
            .unwrap_or_else(|e| fatal(&e));
        if order == 2 {
            return Box::new(projected);
        }
        Box::new(
            projected
                .extrapolated(order)
                .and_then(|e| e.reprojected(model.system(), &start, ProjectionOptions::default()))
                .unwrap_or_else(|e| fatal(&e)),
        )
    };
    let steps = (t_end / dt).round() as usize;
    let mut flow = build();
    let mut x = start;
    let mut max_g = 0.0f64;
    for k in 0..steps {
        flow.step(dt, &mut x)
            .unwrap_or_else(|e| fatal(&format!("order {order} step {k}: {e}")));
        max_g = max_g.max(g(x.as_slice()).abs());
    }
    let evaluations = flow.stats().residual_evaluations;
    let best = (0..repeat)
        .map(|_| {
            let mut flow = build();
            let mut y = start;
            let clock = Instant::now();
            for _ in 0..steps {
                flow.step(std::hint::black_box(dt), &mut y)
                    .unwrap_or_else(|e| fatal(&e));
            }
            clock.elapsed().as_secs_f64()
        })
        .fold(f64::INFINITY, f64::min);
    Row {
        method: if order == 2 {
            "lieflow Strang (projected)".into()
        } else {
            format!("lieflow order {order} extrapolated")
        },
        setting: format!("h {dt}"),
        x: x.into(),
        max_g,
        ms: best * 1e3,
        evaluations,
    }
}

/// lieflow's adaptive extrapolation of the projected Strang step at `tol` (rtol = atol),
/// projected after every accepted step: one call `step(t_end)`, the steps and orders chosen
/// inside it.
fn adaptive_run(tol: f64, t_end: f64, repeat: usize) -> Row {
    use lieflow::flow::{AdaptiveExtrapolation, AdaptiveOptions, ManifoldProjection, Tolerances};
    let model = DampedPendulum::try_new(C).unwrap();
    let start = x0();
    let build = || {
        let projected = model
            .free_flow()
            .and_then(|f| f.projected(model.system(), &start, ProjectionOptions::default()))
            .unwrap_or_else(|e| fatal(&e));
        let finish =
            ManifoldProjection::try_new(model.system(), &start, ProjectionOptions::default())
                .unwrap_or_else(|e| fatal(&e));
        let options = AdaptiveOptions::new(Tolerances::new(tol, tol).unwrap_or_else(|e| fatal(&e)));
        AdaptiveExtrapolation::try_new(projected, finish, options).unwrap_or_else(|e| fatal(&e))
    };
    let mut flow = build();
    let mut x = start;
    flow.step(t_end, &mut x)
        .unwrap_or_else(|e| fatal(&format!("adaptive at tol {tol:e}: {e}")));
    let evaluations = flow.stats().residual_evaluations;
    let s = flow.adaptive_stats().expect("an adaptive flow");
    let best = (0..repeat)
        .map(|_| {
            let mut flow = build();
            let mut y = start;
            let clock = Instant::now();
            flow.step(std::hint::black_box(t_end), &mut y)
                .unwrap_or_else(|e| fatal(&e));
            clock.elapsed().as_secs_f64()
        })
        .fold(f64::INFINITY, f64::min);
    Row {
        method: format!(
            "lieflow adaptive ({} steps, {} base)",
            s.accepted, s.base_steps
        ),
        setting: format!("tol {tol:.2e}"),
        x: x.into(),
        max_g: g(x.as_slice()).abs(),
        ms: best * 1e3,
        evaluations,
    }
}

/// Tolerances from `loosest` down to `tightest`, five a decade (`10^{−k/5}`, three digits).
fn tolerances(loosest: f64, tightest: f64) -> Vec<f64> {
    let (a, b) = (
        (-loosest.log10() * 5.0).round() as i32,
        (-tightest.log10() * 5.0).round() as i32,
    );
    (a..=b)
        .map(|k| {
            let t = 10f64.powf(-f64::from(k) / 5.0);
            let scale = 10f64.powi(t.log10().floor() as i32 - 2);
            (t / scale).round() * scale
        })
        .collect()
}

fn main() {
    let t_end: f64 = flag("t-end", 10.0);
    if !(t_end.is_finite() && t_end > 0.0) {
        fatal(&"--t-end must be positive and finite");
    }
    let repeat = flag("repeat", 3usize).max(1);
    // The reference: the two sides at their finest must agree.
    let a = peer(1e-15, t_end, 1).x;
    let b = lieflow_run(8, 1.0 / 400.0, t_end, 1).x;
    let gap = (0..4).map(|i| (a[i] - b[i]).abs()).fold(0.0, f64::max);
    println!("reference gap (DOP853 tol 1e-15 vs order 8 at h = 1/400): {gap:.1e}");
    let reference = b;
    let mut rows = Vec::new();
    // Both sides over the same tolerances, five a decade (as the scene sets of
    // docs/work-precision.md): "the fastest run reaching the target" is then no accident of
    // where a coarse grid puts each side's error.
    for tol in tolerances(1e-4, 1e-14) {
        rows.push(peer(tol, t_end, repeat));
    }
    for (order, dts) in [
        (2, &[0.01, 0.005][..]),
        (4, &[0.1, 0.05, 0.025, 0.0125][..]),
        (6, &[0.2, 0.1, 0.05, 0.025][..]),
        (8, &[0.4, 0.2, 0.1, 0.05][..]),
    ] {
        for &dt in dts {
            rows.push(lieflow_run(order, dt, t_end, repeat));
        }
    }
    for tol in tolerances(1e-4, 1e-12) {
        rows.push(adaptive_run(tol, t_end, repeat));
    }
    let error = |r: &Row| {
        (0..4)
            .map(|i| (r.x[i] - reference[i]).abs())
            .fold(0.0, f64::max)
    };
    println!(
        "{:<40} {:>10} {:>10} {:>10} {:>10} {:>8}",
        "method", "setting", "error", "max|g|", "ms", "evals"
    );
    for r in &rows {
        println!(
            "{:<40} {:>10} {:>10.2e} {:>10.1e} {:>10.4} {:>8}",
            r.method,
            r.setting,
            error(r),
            r.max_g,
            r.ms,
            r.evaluations
        );
    }
    let mut json = format!("{{\"t\":{t_end},\"damping\":{C},\"reference_gap\":{gap:e}");
    for (target, key) in [(1e-6, "1e-6"), (1e-8, "1e-8"), (1e-10, "1e-10")] {
        let fastest = |peer: bool| {
            rows.iter()
                .filter(|r| r.method.starts_with("DOP853") == peer && error(r) <= target)
                .map(|r| r.ms)
                .fold(f64::INFINITY, f64::min)
        };
        let (ours, theirs) = (fastest(false), fastest(true));
        // The adaptive runs alone: what a user who asks for a tolerance gets, no step
        // picked from a grid.
        let adaptive = rows
            .iter()
            .filter(|r| r.method.starts_with("lieflow adaptive") && error(r) <= target)
            .map(|r| r.ms)
            .fold(f64::INFINITY, f64::min);
        // Which runs they are: the setting of each side's fastest.
        let which = |pick: &dyn Fn(&Row) -> bool, ms: f64| {
            rows.iter()
                .find(|r| pick(r) && r.ms == ms && error(r) <= target)
                .map_or_else(String::new, |r| format!("{} {}", r.method, r.setting))
        };
        println!(
            "target {key}: lieflow adaptive {adaptive:.4} ms ({}), DOP853 {theirs:.4} ms ({}), ratio {:.2}",
            which(&|r| r.method.starts_with("lieflow adaptive"), adaptive),
            which(&|r| r.method.starts_with("DOP853"), theirs),
            adaptive / theirs
        );
        println!(
            "target {key}: lieflow {ours:.4} ms, DOP853 {theirs:.4} ms, ratio {:.2}",
            ours / theirs
        );
        let num = |v: f64| {
            if v.is_finite() {
                format!("{v}")
            } else {
                "null".to_owned()
            }
        };
        json.push_str(&format!(
            ",\"lieflow_ms_{key}\":{},\"dop853_ms_{key}\":{},\"ratio_{key}\":{},\"adaptive_ms_{key}\":{},\"adaptive_ratio_{key}\":{}",
            num(ours),
            num(theirs),
            num(ours / theirs),
            num(adaptive),
            num(adaptive / theirs)
        ));
    }
    println!("{json}}}");
}
