//! The numerical example of Zhang & Deng (2004, §4), reproduced.
//!
//! `x' = M(∇H + Gᵀλ)`, `H = (x₃² + x₄²)/2`, `g = (x₁² + x₂² − 1)/2`, `x(0) = (1, 0, 0, −0.15)`,
//! h = 0.1, T = 100, with the §3 projection scheme around the exact drift `exp(h D_H)` or one of
//! its symmetric compositions. Prints a summary, and as the last line a JSON object.
//!
//! ```text
//! cargo run --release --example paper_example -- --scheme triple-jump --dt 0.1 --t-end 100 \
//!     --csv run.csv --plot docs/figures/paper_fig1.svg
//! ```

mod common;

use common::{Args, Json, fatal, scheme_table, time_steps};
use lieflow::flow::CompositionTable;
use lieflow::models::paper;
use lieflow::prelude::*;
use nalgebra::SVector;
use std::io::Write as _;

type V = SVector<f64, 4>;

fn build(
    scheme: &str,
    table: Option<&'static CompositionTable>,
    x0: &V,
) -> Result<Box<dyn Flow<V>>, SetupError> {
    if scheme == "modified" {
        // The paper's §2 scheme: projection half-steps around the flow of H_N1 = H + μ g,
        // here by the implicit midpoint rule, its increment and λ_k solved as one Newton
        // system (ProjectedMidpoint; the same map as Projected around ImplicitMidpoint).
        let flow: ProjectedMidpoint<V, _, _> = ProjectedMidpoint::try_new(
            paper::system(),
            paper::modified_energy(),
            x0,
            ProjectionOptions::default(),
        )?;
        return Ok(Box::new(flow));
    }
    let base = paper::drift().projected(paper::system(), x0, ProjectionOptions::default())?;
    Ok(match table {
        None => Box::new(base),
        Some(t) => Box::new(base.composed(t)),
    })
}

fn phi(x: &V) -> f64 {
    x[0] * x[2] + x[1] * x[3]
}

fn g(x: &V) -> f64 {
    0.5 * (x[0] * x[0] + x[1] * x[1] - 1.0)
}

fn main() {
    let args = Args::parse(
        "Zhang & Deng (2004) §4: the constrained generalized Hamiltonian example.",
        &[
            (
                "scheme",
                "NAME",
                "projection (the §3 scheme, default), modified (the §2 scheme: flow of H + mu g by implicit midpoint), triple-jump, suzuki4, yoshida6, kahan-li6, suzuki-umeno8, kahan-li8",
            ),
            ("dt", "H", "step size (default 0.1)"),
            ("t-end", "T", "final time (default 100)"),
            ("csv", "FILE", "write t, x1..x4, g, phi for every step"),
            (
                "plot",
                "FILE.svg",
                "draw the paper's Figure 1: g(x_k) against t",
            ),
        ],
    );
    let scheme = args.get("scheme", "projection".to_string());
    let table = if scheme == "modified" {
        None
    } else {
        scheme_table(&args, &scheme, "projection")
    };
    let dt = args.positive("dt", 0.1);
    let t_end = args.positive("t-end", 100.0);
    let steps = common::steps(&args, dt, t_end);

    let x0: V = paper::initial_state();
    let h0 = paper::h_tilde(&x0);

    // Timed run: stepping only, nothing observed.
    let mut flow = build(&scheme, table, &x0).unwrap_or_else(|e| fatal(&e));
    let ns_per_step = time_steps(&mut *flow, &x0, dt, steps);

    // Observed run: residuals and the invariant after every step.
    let mut flow = build(&scheme, table, &x0).unwrap_or_else(|e| fatal(&e));
    let mut x = x0;
    let (mut max_g, mut max_phi, mut max_dh) = (0.0f64, 0.0f64, 0.0f64);
    let mut series: Vec<(f64, V)> = Vec::with_capacity(steps + 1);
    let record = args.opt("csv").is_some() || args.opt("plot").is_some();
    let report = integrate(
        &mut flow,
        &mut x,
        0.0,
        dt,
        steps,
        &mut |_k: usize, t: f64, x: &V| {
            max_g = max_g.max(g(x).abs());
            max_phi = max_phi.max(phi(x).abs());
            max_dh = max_dh.max((paper::h_tilde(x) - h0).abs());
            if record {
                series.push((t, *x));
            }
        },
    )
    .unwrap_or_else(|e| fatal(&e));

    let exact = paper::exact(report.t, -0.15);
    let err = (0..4).map(|i| (x[i] - exact[i]).abs()).fold(0.0, f64::max);

    if let Some(path) = args.opt("csv") {
        write_csv(path, &series).unwrap_or_else(|e| fatal(&format!("writing {path}: {e}")));
        eprintln!("wrote {path}");
    }
    if let Some(path) = args.opt("plot") {
        plot_g(path, &series, &scheme, dt)
            .unwrap_or_else(|e| fatal(&format!("plotting {path}: {e}")));
        eprintln!("wrote {path}");
    }

    let stats = report.stats;
    println!(
        "Zhang & Deng (2004) §4, scheme '{scheme}', order {}, h = {dt}, T = {}",
        flow.order(),
        report.t
    );
    println!(
        "  final x          = [{:.12}, {:.12}, {:.12}, {:.12}]",
        x[0], x[1], x[2], x[3]
    );
    println!("  max |g|          = {max_g:.3e}   (constraint, every step)");
    println!("  max |phi|        = {max_phi:.3e}   (hidden constraint <g,H>)");
    println!("  max |H~ - H~0|   = {max_dh:.3e}   (H~ = (x3^2 + x4^2/2)/2)");
    println!("  error vs exact   = {err:.3e}   (max-norm at T)");
    println!(
        "  Newton           = {} solves, {} iterations, {:.2} residual evaluations per step",
        stats.newton_solves,
        stats.newton_iterations,
        stats.residual_evaluations as f64 / steps as f64
    );
    println!("  time             = {ns_per_step:.0} ns/step");
    Json::default()
        .str("example", "paper_example")
        .str("scheme", &scheme)
        .num("dt", dt)
        .num("t", report.t)
        .arr("x", x.as_slice())
        .int("steps", steps as u64)
        .num("max_abs_g", max_g)
        .num("max_abs_phi", max_phi)
        .num("h_tilde_max_err", max_dh)
        .num("error_vs_exact", err)
        .int("newton_iterations", stats.newton_iterations)
        .int("residual_evaluations", stats.residual_evaluations)
        .num("ns_per_step", ns_per_step)
        .print();
}

fn write_csv(path: &str, series: &[(f64, V)]) -> std::io::Result<()> {
    let mut f = std::io::BufWriter::new(std::fs::File::create(path)?);
    writeln!(f, "t,x1,x2,x3,x4,g,phi")?;
    for (t, x) in series {
        writeln!(
            f,
            "{t},{:e},{:e},{:e},{:e},{:e},{:e}",
            x[0],
            x[1],
            x[2],
            x[3],
            g(x),
            phi(x)
        )?;
    }
    f.flush()
}

fn plot_g(
    path: &str,
    series: &[(f64, V)],
    scheme: &str,
    dt: f64,
) -> Result<(), Box<dyn std::error::Error>> {
    use plotters::prelude::*;
    let t_max = series.last().map_or(1.0, |s| s.0);
    let gmax = series.iter().map(|(_, x)| g(x).abs()).fold(0.0, f64::max);
    let ymax = if gmax > 0.0 { 1.2 * gmax } else { 1e-16 };
    let root = SVGBackend::new(path, (800, 450)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(
            format!("Zhang & Deng (2004) Fig. 1: constraint g(x_k), scheme {scheme}, h = {dt}"),
            ("sans-serif", 18),
        )
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(80)
        .build_cartesian_2d(0.0..t_max, -ymax..ymax)?;
    chart
        .configure_mesh()
        .x_desc("t")
        .y_desc("g(x_k)")
        .y_label_formatter(&|v| format!("{v:.1e}"))
        .draw()?;
    chart.draw_series(LineSeries::new(
        series.iter().map(|(t, x)| (*t, g(x))),
        BLUE.stroke_width(1),
    ))?;
    root.present()?;
    Ok(())
}
