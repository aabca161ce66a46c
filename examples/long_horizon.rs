//! Work against precision at a long horizon: the paper's example to `T = 10⁴` by lieflow's
//! composed projection schemes and by a peer's DOP853 on the reduced ODE, in one process.
//!
//! ```text
//! cargo run --release --example long_horizon
//! cargo run --release --example long_horizon -- --t-end 1000 --csv wp.csv --plot wp.svg
//! ```
//!
//! The peer is `differential-equations`' DOP853 (Hairer's explicit 8(5,3) Runge–Kutta pair with
//! step-size control) on the ODE with the multiplier eliminated — the index reduction a user
//! without a constrained integrator writes: `x' = M(∇H + μ(x) Gᵀ)`, `μ = (x₃² + x₄²)/(x₁² + 2x₂²)`
//! (the multiplier that keeps `φ = ⟨g, H⟩` constant), at `rtol = atol` from 1e-10 to 1e-14. Its
//! constraint drifts; lieflow's stays at round-off.
//!
//! The error of every run is measured at `T` against [`paper::exact`] — the closed-form solution
//! (a spectrally accurate quadrature of `t(θ)`, inverted by Newton; ≈ 1e-12 at `T = 10⁴`), not
//! against any of the runs being judged. Times are the best of `--repeat` runs (stepping only,
//! nothing observed); `max |g|` comes from a separate observed run.
//!
//! The last line of stdout is a JSON summary: the peer's best error and its time, and the
//! fastest lieflow run with error ≤ `--target` (default 1e-8) and its time.

#[path = "common/mod.rs"]
mod common;

use common::{Args, Json, fatal};
use differential_equations::prelude::*;
use lieflow::flow::coefficients::table_by_name;
use lieflow::models::paper;
use lieflow::prelude::*;
use nalgebra::SVector;
use std::cell::Cell;
use std::io::Write as _;
use std::time::Instant;

type V = SVector<f64, 4>;

const V0: f64 = -0.15;

/// The reduced ODE of the paper's example (λ eliminated), for the peer.
struct Reduced;

impl ODE<f64, [f64; 4]> for Reduced {
    fn diff(&self, _t: f64, x: &[f64; 4], dx: &mut [f64; 4]) {
        let mu = (x[2] * x[2] + x[3] * x[3]) / (x[0] * x[0] + 2.0 * x[1] * x[1]);
        // M (∇H + μ Gᵀ), ∇H = (0, 0, x₃, x₄), Gᵀ = (x₁, x₂, 0, 0).
        dx[0] = x[2];
        dx[1] = x[3];
        dx[2] = -mu * x[0];
        dx[3] = -2.0 * mu * x[1];
    }
}

/// Keeps only what the comparison needs: the last accepted state and, when asked, the largest
/// `|g|` over the accepted steps (a solout that stores nothing, so the timed runs do not pay
/// for output).
#[derive(Clone)]
struct Track<'a> {
    last: &'a Cell<[f64; 4]>,
    max_g: Option<&'a Cell<f64>>,
}

impl Solout<f64, [f64; 4]> for Track<'_> {
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
        self.last.set(*y);
        if let Some(m) = self.max_g {
            m.set(m.get().max(g(y).abs()));
        }
        ControlFlag::Continue
    }
}

fn g(x: &[f64]) -> f64 {
    0.5 * (x[0] * x[0] + x[1] * x[1] - 1.0)
}

/// One row of the table.
struct Row {
    method: String,
    setting: String,
    error: f64,
    max_g: f64,
    ms: f64,
    /// Steps taken (accepted steps for the peer).
    steps: u64,
    /// Right-hand-side evaluations (peer) or multiplier-residual evaluations (lieflow).
    evaluations: u64,
}

fn max_err(x: &[f64], exact: &[f64; 4]) -> f64 {
    (0..4).map(|i| (x[i] - exact[i]).abs()).fold(0.0, f64::max)
}

fn peer(tol: f64, t_end: f64, repeat: usize, exact: &[f64; 4]) -> Row {
    let x0 = [1.0, 0.0, 0.0, V0];
    let run = |max_g: Option<&Cell<f64>>| {
        let last = Cell::new(x0);
        let start = Instant::now();
        let solution = IVP::ode(&Reduced, 0.0, t_end, x0)
            .solout(Track { last: &last, max_g })
            .method(
                ExplicitRungeKutta::dop853()
                    .rtol(tol)
                    .atol(tol)
                    .max_steps(usize::MAX),
            )
            .solve()
            .unwrap_or_else(|e| fatal(&format!("DOP853 at tol {tol:e}: {e:?}")));
        let seconds = start.elapsed().as_secs_f64();
        (
            last.get(),
            seconds,
            solution.steps.accepted as u64,
            solution.evals.function as u64,
        )
    };
    let max_g = Cell::new(0.0);
    let (x, _, steps, evaluations) = run(Some(&max_g));
    let best = (0..repeat)
        .map(|_| run(None).1)
        .fold(f64::INFINITY, f64::min);
    Row {
        method: "DOP853 (reduced ODE)".into(),
        setting: format!("tol {tol:.0e}"),
        error: max_err(&x, exact),
        max_g: max_g.get(),
        ms: best * 1e3,
        steps,
        evaluations,
    }
}

fn lieflow_run(scheme: &str, dt: f64, t_end: f64, repeat: usize, exact: &[f64; 4]) -> Row {
    let Some(table) = table_by_name(scheme) else {
        fatal(&format!("unknown scheme '{scheme}'"));
    };
    let x0: V = paper::initial_state();
    let build = || {
        paper::drift()
            .projected(paper::system(), &x0, ProjectionOptions::default())
            .unwrap_or_else(|e| fatal(&e))
            .composed(table)
    };
    let steps = (t_end / dt).round() as usize;
    // Observed run: max |g| and the final state.
    let mut flow = build();
    let mut x = x0;
    let mut max_g = 0.0f64;
    integrate(&mut flow, &mut x, 0.0, dt, steps, &mut |_, _, x: &V| {
        max_g = max_g.max(g(x.as_slice()).abs())
    })
    .unwrap_or_else(|e| fatal(&format!("{scheme}: {e}")));
    let evaluations = flow.stats().residual_evaluations;
    // Timed runs: a fresh flow each, nothing observed.
    let best = (0..repeat)
        .map(|_| {
            let mut flow = build();
            let mut y = x0;
            let start = Instant::now();
            for k in 0..steps {
                flow.step(std::hint::black_box(dt), &mut y)
                    .unwrap_or_else(|e| fatal(&format!("{scheme} step {k}: {e}")));
            }
            start.elapsed().as_secs_f64()
        })
        .fold(f64::INFINITY, f64::min);
    Row {
        method: format!("lieflow {scheme}"),
        setting: format!("h {dt}"),
        error: max_err(x.as_slice(), exact),
        max_g,
        ms: best * 1e3,
        steps: steps as u64,
        evaluations,
    }
}

fn main() {
    let args = Args::parse(
        "Long-horizon work-precision: lieflow's composed projections against a peer DOP853 on \
         the paper's example (errors against the closed-form solution).",
        &[
            ("t-end", "T", "final time (default 10000)"),
            (
                "repeat",
                "N",
                "timed runs per configuration, best kept (default 3)",
            ),
            ("target", "E", "error target for the verdict (default 1e-8)"),
            ("csv", "FILE", "write the table as CSV"),
            (
                "plot",
                "FILE.svg",
                "write error against time (log-log) as SVG",
            ),
        ],
    );
    let t_end = args.positive("t-end", 1e4);
    let repeat: usize = args.get("repeat", 3).max(1);
    let target = args.positive("target", 1e-8);
    let exact = paper::exact(t_end, V0);

    let mut rows = Vec::new();
    for tol in [1e-10, 1e-11, 1e-12, 1e-13, 1e-14] {
        rows.push(peer(tol, t_end, repeat, &exact));
    }
    for (scheme, dts) in [
        ("yoshida6", &[1.0, 0.5, 0.25][..]),
        ("kahan-li6", &[1.0, 0.5, 0.25][..]),
        ("suzuki-umeno8", &[2.0, 1.0, 0.5][..]),
        ("kahan-li8", &[2.0, 1.0, 0.5][..]),
    ] {
        for &dt in dts {
            if dt <= t_end {
                rows.push(lieflow_run(scheme, dt, t_end, repeat, &exact));
            }
        }
    }

    println!(
        "Paper example (Zhang & Deng 2004, §4) to T = {t_end}: error at T against the closed form"
    );
    println!(
        "{:<26} {:<10} {:>10} {:>10} {:>10} {:>9} {:>10}",
        "method", "setting", "error", "max |g|", "time ms", "steps", "evals"
    );
    for r in &rows {
        println!(
            "{:<26} {:<10} {:>10.2e} {:>10.2e} {:>10.2} {:>9} {:>10}",
            r.method, r.setting, r.error, r.max_g, r.ms, r.steps, r.evaluations
        );
    }
    let is_peer = |r: &&Row| r.method.starts_with("DOP853");
    let best_peer = rows
        .iter()
        .filter(is_peer)
        .min_by(|a, b| a.error.total_cmp(&b.error))
        .unwrap_or_else(|| fatal(&"no peer run"));
    let fastest = rows
        .iter()
        .filter(|r| !is_peer(r) && r.error <= target)
        .min_by(|a, b| a.ms.total_cmp(&b.ms));
    println!(
        "peer's best error: {:.2e} ({}, {:.2} ms)",
        best_peer.error, best_peer.setting, best_peer.ms
    );
    match fastest {
        Some(f) => println!(
            "fastest lieflow run with error <= {target:e}: {} {} — {:.2e} in {:.2} ms ({:.2}x the peer's best-error time)",
            f.method,
            f.setting,
            f.error,
            f.ms,
            f.ms / best_peer.ms
        ),
        None => println!("no lieflow run reached error <= {target:e}"),
    }

    if let Some(path) = args.opt("csv") {
        write_csv(path, &rows).unwrap_or_else(|e| fatal(&format!("writing {path}: {e}")));
        eprintln!("wrote {path}");
    }
    if let Some(path) = args.opt("plot") {
        plot(path, &rows, t_end).unwrap_or_else(|e| fatal(&format!("plotting {path}: {e}")));
        eprintln!("wrote {path}");
    }

    let best = fastest.unwrap_or(best_peer);
    let steps = fastest.map_or(0, |f| f.steps);
    Json::default()
        .str("example", "long_horizon")
        .num("t", t_end)
        .arr("x", &exact)
        .int("steps", steps)
        .num("max_abs_g", fastest.map_or(f64::NAN, |f| f.max_g))
        .num(
            "ns_per_step",
            fastest.map_or(f64::NAN, |f| f.ms * 1e6 / f.steps as f64),
        )
        .str("lieflow_method", &best.method)
        .str("lieflow_setting", &best.setting)
        .num("lieflow_error", fastest.map_or(f64::NAN, |f| f.error))
        .num("lieflow_ms", fastest.map_or(f64::NAN, |f| f.ms))
        .num("peer_best_error", best_peer.error)
        .num("peer_best_ms", best_peer.ms)
        .num("peer_max_abs_g", best_peer.max_g)
        .num("target", target)
        .print();
}

fn write_csv(path: &str, rows: &[Row]) -> std::io::Result<()> {
    let mut f = std::io::BufWriter::new(std::fs::File::create(path)?);
    writeln!(
        f,
        "method,setting,error,max_abs_g,time_ms,steps,evaluations"
    )?;
    for r in rows {
        writeln!(
            f,
            "{},{},{:e},{:e},{},{},{}",
            r.method, r.setting, r.error, r.max_g, r.ms, r.steps, r.evaluations
        )?;
    }
    f.flush()
}

fn plot(path: &str, rows: &[Row], t_end: f64) -> Result<(), Box<dyn std::error::Error>> {
    use plotters::prelude::*;
    let (tmin, tmax) = rows.iter().fold((f64::INFINITY, 0.0f64), |(a, b), r| {
        (a.min(r.ms), b.max(r.ms))
    });
    let (emin, emax) = rows.iter().fold((f64::INFINITY, 0.0f64), |(a, b), r| {
        (a.min(r.error.max(1e-16)), b.max(r.error))
    });
    let root = SVGBackend::new(path, (760, 480)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(
            format!("Paper example to T = {t_end}: error at T against run time"),
            ("sans-serif", 18),
        )
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(
            (tmin / 1.5..tmax * 1.5).log_scale(),
            (emin / 3.0..emax * 3.0).log_scale(),
        )?;
    chart
        .configure_mesh()
        .x_desc("time (ms)")
        .y_desc("max-norm error at T")
        .y_label_formatter(&|v| format!("{v:.0e}"))
        .draw()?;
    let groups: Vec<&str> = rows.iter().fold(Vec::new(), |mut g, r| {
        if !g.contains(&r.method.as_str()) {
            g.push(r.method.as_str());
        }
        g
    });
    for (i, name) in groups.iter().enumerate() {
        let color = Palette99::pick(i).to_rgba();
        let pts: Vec<(f64, f64)> = rows
            .iter()
            .filter(|r| r.method == *name)
            .map(|r| (r.ms, r.error.max(1e-16)))
            .collect();
        chart
            .draw_series(LineSeries::new(pts.clone(), color.stroke_width(2)))?
            .label(*name)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color));
        chart.draw_series(pts.iter().map(|&p| Circle::new(p, 4, color.filled())))?;
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .position(SeriesLabelPosition::UpperRight)
        .draw()?;
    root.present()?;
    Ok(())
}
