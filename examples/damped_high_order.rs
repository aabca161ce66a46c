//! Work against precision on a damped problem, both sides hand-written: the damped pendulum
//! (`models::DampedPendulum`, damping 0.5, from the horizontal at rest, `T = 10`) by lieflow's
//! extrapolated projected Strang step of orders 4, 6, 8 — every sub-step forward, so the
//! damping never runs backwards — and by a peer's DOP853 on the index-1 ODE with its multiplier
//! in closed form, in one process.
//!
//! ```text
//! cargo run --release --example damped_high_order
//! cargo run --release --example damped_high_order -- --repeat 5 --t-end 20
//! ```
//!
//! The peer is `differential-equations`' DOP853 (Hairer's 8(5,3) pair with step-size control)
//! on `q' = p`, `p' = −q μ − c p − e_y`, `μ = (|p|² − y)/|q|²` (from `d/dt (q·p) = 0`), on
//! `[f64; 4]`: a right-hand side of a dozen flops, the peer at its best on this problem. lieflow
//! runs the model's own exact damped flow (`LinearFlow`) inside the projection. The error of
//! every run is measured at `T` against a reference that neither side produced alone: the
//! peer at tolerance 1e-15 and lieflow's order 8 at `h = 1/400`, which must agree (their gap is
//! printed). Times are the best of `--repeat` runs, nothing observed.
//!
//! The last line of stdout is a JSON summary: for each target error 1e-6, 1e-8, 1e-10, the
//! fastest lieflow run that reaches it, the fastest peer run that reaches it, and their ratio.

#[path = "common/mod.rs"]
mod common;

use common::{Args, Json, fatal};
use differential_equations::prelude::*;
use lieflow::models::DampedPendulum;
use lieflow::prelude::*;
use nalgebra::SVector;
use std::cell::Cell;
use std::time::Instant;

type V = SVector<f64, 4>;

const C: f64 = 0.5;

/// The index-1 ODE of the damped pendulum.
struct Index1;

impl ODE<f64, [f64; 4]> for Index1 {
    fn diff(&self, _t: f64, x: &[f64; 4], dx: &mut [f64; 4]) {
        let mu = (x[2] * x[2] + x[3] * x[3] - x[1]) / (x[0] * x[0] + x[1] * x[1]);
        *dx = [
            x[2],
            x[3],
            -x[0] * mu - C * x[2],
            -1.0 - x[1] * mu - C * x[3],
        ];
    }
}

struct Last<'a>(&'a Cell<[f64; 4]>);

impl Solout<f64, [f64; 4]> for Last<'_> {
    fn solout<I>(
        &mut self,
        _t: f64,
        _t_prev: f64,
        y: &[f64; 4],
        _y_prev: &[f64; 4],
        _interpolator: &mut I,
        _solution: &mut Solution<f64, [f64; 4]>,
    ) -> ControlFlag<f64, [f64; 4]>
    where
        I: Interpolation<f64, [f64; 4]> + ?Sized,
    {
        self.0.set(*y);
        ControlFlag::Continue
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
        let last = Cell::new(start);
        let clock = Instant::now();
        let solution = IVP::ode(&Index1, 0.0, t_end, start)
            .solout(Last(&last))
            .method(
                ExplicitRungeKutta::dop853()
                    .rtol(tol)
                    .atol(tol)
                    .max_steps(usize::MAX),
            )
            .solve()
            .unwrap_or_else(|e| fatal(&format!("DOP853 at tol {tol:e}: {e:?}")));
        (
            last.get(),
            clock.elapsed().as_secs_f64(),
            solution.evals.function as u64,
        )
    };
    let (x, _, evaluations) = run();
    let best = (0..repeat).map(|_| run().1).fold(f64::INFINITY, f64::min);
    Row {
        method: "DOP853 (index-1 ODE)".into(),
        setting: format!("tol {tol:.0e}"),
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

fn main() {
    let args = Args::parse(
        "Damped pendulum work-precision: lieflow's extrapolated projections (orders 4, 6, 8, \
         positive sub-steps) against DOP853 with a closed-form right-hand side.",
        &[
            ("t-end", "T", "final time (default 10)"),
            (
                "repeat",
                "N",
                "timed runs per configuration, best kept (default 3)",
            ),
        ],
    );
    let t_end = args.positive("t-end", 10.0);
    let repeat = args.get("repeat", 3usize).max(1);
    // The reference: the two sides at their finest must agree.
    let a = peer(1e-15, t_end, 1).x;
    let b = lieflow_run(8, 1.0 / 400.0, t_end, 1).x;
    let gap = (0..4).map(|i| (a[i] - b[i]).abs()).fold(0.0, f64::max);
    println!("reference gap (DOP853 tol 1e-15 vs order 8 at h = 1/400): {gap:.1e}");
    let reference = b;
    let mut rows = Vec::new();
    for tol in [1e-6, 1e-8, 1e-10, 1e-12, 1e-14] {
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
    let error = |r: &Row| {
        (0..4)
            .map(|i| (r.x[i] - reference[i]).abs())
            .fold(0.0, f64::max)
    };
    println!(
        "{:<32} {:>10} {:>10} {:>10} {:>10} {:>8}",
        "method", "setting", "error", "max|g|", "ms", "evals"
    );
    for r in &rows {
        println!(
            "{:<32} {:>10} {:>10.2e} {:>10.1e} {:>10.4} {:>8}",
            r.method,
            r.setting,
            error(r),
            r.max_g,
            r.ms,
            r.evaluations
        );
    }
    let mut json = Json::default()
        .num("t", t_end)
        .num("damping", C)
        .num("reference_gap", gap);
    for (target, key) in [(1e-6, "1e-6"), (1e-8, "1e-8"), (1e-10, "1e-10")] {
        let fastest = |peer: bool| {
            rows.iter()
                .filter(|r| r.method.starts_with("DOP853") == peer && error(r) <= target)
                .map(|r| r.ms)
                .fold(f64::INFINITY, f64::min)
        };
        let (ours, theirs) = (fastest(false), fastest(true));
        println!(
            "target {key}: lieflow {ours:.4} ms, DOP853 {theirs:.4} ms, ratio {:.2}",
            ours / theirs
        );
        json = json
            .num(&format!("lieflow_ms_{key}"), ours)
            .num(&format!("dop853_ms_{key}"), theirs)
            .num(&format!("ratio_{key}"), ours / theirs);
    }
    json.print();
}
