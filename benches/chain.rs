//! Scaling of the sparse path: one RATTLE step (projected kick–drift–kick) of the N-link
//! pendulum chain for N = 10³, 10⁴, 10⁵ with the sparse LU, and N = 10², 10³ with the dense LU
//! for comparison. Same shape, same step `h = 10⁻⁶` (below the chain's stability bound `h ≤ 1/N`
//! for every N, so the Newton work per step is comparable).
//!
//! After criterion's measurements, the bench times every configuration again in the same
//! process (median of 9 runs of about 0.25 s each), prints the table and the ratio
//! `ns/step(10⁵) / ns/step(10⁴)` (linear cost: about 10), and writes `chain_scaling.csv` and
//! the log-log plot `chain_scaling.svg` into `$LIEFLOW_FIGURES` when that is set:
//!
//! ```text
//! LIEFLOW_FIGURES=docs/figures cargo bench --bench chain
//! ```

use criterion::{Criterion, criterion_group};
use faer::Col;
use lieflow::linalg::{SolverChoice, SolverKind};
use lieflow::models::PendulumChain;
use lieflow::prelude::*;
use std::hint::black_box;
use std::time::Instant;

type V = Col<f64>;

const H: f64 = 1e-6;

/// A chain of `n` links, its RATTLE flow with the given backend, and a state after 3 steps
/// (warm multipliers and Jacobians).
fn setup(n: usize, kind: SolverKind) -> (impl Flow<V>, V) {
    let model = PendulumChain::<f64>::uniform(2, n).unwrap();
    let mut x: V = model.at_rest(|i| 0.1 * (std::f64::consts::PI * i as f64 / n as f64).sin());
    let options = model.projection_options();
    let options = options.with_newton(options.newton.with_solver(SolverChoice::Force(kind)));
    let mut flow = model
        .kick::<V>()
        .strang(model.drift())
        .projected(model.system(), &x, options)
        .unwrap();
    for _ in 0..3 {
        flow.step(H, &mut x).unwrap();
    }
    (flow, x)
}

const CONFIGS: [(SolverKind, &str, usize); 5] = [
    (SolverKind::Sparse, "sparse", 1_000),
    (SolverKind::Sparse, "sparse", 10_000),
    (SolverKind::Sparse, "sparse", 100_000),
    (SolverKind::Dense, "dense", 100),
    (SolverKind::Dense, "dense", 1_000),
];

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("chain_step");
    group.sample_size(10);
    group.warm_up_time(std::time::Duration::from_millis(500));
    group.measurement_time(std::time::Duration::from_secs(2));
    for (kind, name, n) in CONFIGS {
        let (mut flow, mut x) = setup(n, kind);
        group.bench_function(format!("{name}/{n}"), |b| {
            b.iter(|| flow.step(black_box(H), &mut x).unwrap())
        });
    }
    group.finish();
}

/// Median ns/step over 9 runs of about 0.25 s each (at least 5 steps per run): long enough
/// runs that scheduler noise on a shared machine averages out within a run, and a median over
/// runs against the outliers.
fn time_config(kind: SolverKind, n: usize) -> (f64, f64) {
    let (mut flow, mut x) = setup(n, kind);
    // Steps per run from one timed step.
    let start = Instant::now();
    flow.step(H, &mut x).unwrap();
    let one = start.elapsed().as_secs_f64();
    let per_run = ((0.25 / one) as usize).clamp(5, 2000);
    let before = flow.stats().newton_iterations;
    let mut runs: Vec<f64> = (0..9)
        .map(|_| {
            let start = Instant::now();
            for _ in 0..per_run {
                flow.step(H, &mut x).unwrap();
            }
            start.elapsed().as_nanos() as f64 / per_run as f64
        })
        .collect();
    runs.sort_by(f64::total_cmp);
    let iterations = (flow.stats().newton_iterations - before) as f64 / (9 * per_run) as f64;
    (runs[4], iterations)
}

fn scaling_summary() {
    println!("\nchain scaling (h = {H}, median of 9 runs of ~0.25 s, same process):");
    println!(
        "{:<8} {:>8} {:>14} {:>16}",
        "backend", "N", "ns/step", "Newton it./step"
    );
    let mut rows = Vec::new();
    for (kind, name, n) in CONFIGS {
        let (ns, it) = time_config(kind, n);
        println!("{name:<8} {n:>8} {ns:>14.0} {it:>16.2}");
        rows.push((name, n, ns, it));
    }
    let ns = |name: &str, n: usize| {
        rows.iter()
            .find(|r| r.0 == name && r.1 == n)
            .map(|r| r.2)
            .unwrap()
    };
    let ratio = ns("sparse", 100_000) / ns("sparse", 10_000);
    println!("sparse ns/step ratio N = 1e5 / N = 1e4: {ratio:.2} (linear: 10)");
    println!(
        "dense / sparse at N = 1000: {:.1}",
        ns("dense", 1000) / ns("sparse", 1000)
    );
    if let Ok(dir) = std::env::var("LIEFLOW_FIGURES") {
        let dir = std::path::Path::new(&dir);
        let mut csv = String::from("backend,links,ns_per_step,newton_iterations_per_step\n");
        for (name, n, ns, it) in &rows {
            csv.push_str(&format!("{name},{n},{ns:.0},{it:.2}\n"));
        }
        std::fs::write(dir.join("chain_scaling.csv"), csv).unwrap();
        plot(&dir.join("chain_scaling.svg"), &rows).unwrap();
        println!("wrote {}", dir.join("chain_scaling.svg").display());
    }
}

fn plot(
    path: &std::path::Path,
    rows: &[(&str, usize, f64, f64)],
) -> Result<(), Box<dyn std::error::Error>> {
    use plotters::prelude::*;
    let root = SVGBackend::new(path, (640, 440)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption("N-link chain, one RATTLE step", ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d((50f64..2e5).log_scale(), (1e4f64..1e9).log_scale())?;
    chart
        .configure_mesh()
        .x_desc("links N")
        .y_desc("ns / step")
        .draw()?;
    for (name, color) in [("sparse", BLUE), ("dense", RED)] {
        let pts: Vec<(f64, f64)> = rows
            .iter()
            .filter(|r| r.0 == name)
            .map(|r| (r.1 as f64, r.2))
            .collect();
        chart
            .draw_series(LineSeries::new(pts.clone(), color.stroke_width(2)))?
            .label(format!("{name} LU"))
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color));
        chart.draw_series(pts.iter().map(|&p| Circle::new(p, 4, color.filled())))?;
    }
    // The linear reference through the sparse N = 1000 point.
    if let Some(r) = rows.iter().find(|r| r.0 == "sparse" && r.1 == 1000) {
        let c = r.2 / 1000.0;
        chart
            .draw_series(LineSeries::new(
                [(1e3, c * 1e3), (1e5, c * 1e5)],
                BLACK.mix(0.4).stroke_width(1),
            ))?
            .label("linear")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK.mix(0.4)));
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .position(SeriesLabelPosition::UpperLeft)
        .draw()?;
    root.present()?;
    Ok(())
}

criterion_group!(benches, bench);

fn main() {
    benches();
    Criterion::default().configure_from_args().final_summary();
    scaling_summary();
}
