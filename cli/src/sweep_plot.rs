//! The sweep's figure: a chosen output against a chosen parameter, one point per member that
//! reports the output (linear axes; failed members are left out and counted in the caption).

use lieflow_lab::sweep::MemberRow;
use plotters::prelude::*;
use std::path::Path;

fn range(values: impl Iterator<Item = f64> + Clone) -> std::ops::Range<f64> {
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
        (a.min(v), b.max(v))
    });
    if !lo.is_finite() || !hi.is_finite() {
        return 0.0..1.0;
    }
    let pad = if hi > lo {
        0.05 * (hi - lo)
    } else {
        0.5 * lo.abs().max(1.0)
    };
    lo - pad..hi + pad
}

/// Draws `y` against parameter `x` for `rows` into an SVG at `path`.
pub fn scatter(
    path: &Path,
    title: &str,
    x: &str,
    y: &str,
    rows: &[MemberRow],
) -> Result<(), Box<dyn std::error::Error>> {
    let points: Vec<(f64, f64)> = rows
        .iter()
        .filter(|r| r.error.is_none())
        .filter_map(|r| Some((r.parameter(x)?, r.output(y)?)))
        .filter(|(a, b)| a.is_finite() && b.is_finite())
        .collect();
    // A parameter spread over more than two decades (a log-uniform draw, a log grid) is shown
    // on a log axis: its log10.
    let (lo, hi) = points.iter().fold((f64::INFINITY, 0.0f64), |(a, b), p| {
        (a.min(p.0), b.max(p.0))
    });
    let log_x = lo > 0.0 && hi / lo > 100.0;
    let points: Vec<(f64, f64)> = if log_x {
        points.into_iter().map(|(a, b)| (a.log10(), b)).collect()
    } else {
        points
    };
    let x_desc = if log_x {
        format!("log10 {x}")
    } else {
        x.to_owned()
    };
    let failed = rows.iter().filter(|r| r.error.is_some()).count();
    let root = SVGBackend::new(path, (900, 600)).into_drawing_area();
    root.fill(&WHITE)?;
    let caption = if failed > 0 {
        format!("{title} ({} members, {failed} failed)", rows.len())
    } else {
        format!("{title} ({} members)", rows.len())
    };
    let mut chart = ChartBuilder::on(&root)
        .caption(caption, ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(90)
        .build_cartesian_2d(
            range(points.iter().map(|p| p.0)),
            range(points.iter().map(|p| p.1)),
        )?;
    chart.configure_mesh().x_desc(x_desc).y_desc(y).draw()?;
    chart.draw_series(points.iter().map(|&p| Circle::new(p, 3, BLUE.filled())))?;
    root.present()?;
    Ok(())
}
