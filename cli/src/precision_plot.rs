//! The work–precision figures: error against time, error against step size with fitted slopes,
//! and `max |g|` against time — one line per method, log–log.

use lieflow_lab::precision::PrecisionRow;
use plotters::prelude::*;
use std::path::Path;

type Points = Vec<(f64, f64)>;

/// The methods in order of first appearance, with their `(x, y)` points from `pick`.
fn series(
    rows: &[PrecisionRow],
    pick: impl Fn(&PrecisionRow) -> Option<(f64, f64)>,
) -> Vec<(String, Points)> {
    let mut out: Vec<(String, Points)> = Vec::new();
    for r in rows.iter().filter(|r| r.status == "ok") {
        let Some((x, y)) = pick(r) else { continue };
        if !(x > 0.0 && y > 0.0 && x.is_finite() && y.is_finite()) {
            continue;
        }
        match out.iter_mut().find(|s| s.0 == r.method) {
            Some(s) => s.1.push((x, y)),
            None => out.push((r.method.clone(), vec![(x, y)])),
        }
    }
    for s in &mut out {
        s.1.sort_by(|a, b| a.0.total_cmp(&b.0));
    }
    out
}

fn log_range(values: impl Iterator<Item = f64>) -> std::ops::Range<f64> {
    let (lo, hi) = values.fold((f64::INFINITY, 0.0f64), |(a, b), v| (a.min(v), b.max(v)));
    if !lo.is_finite() || hi <= 0.0 {
        return 1e-16..1.0;
    }
    lo / 3.0..hi * 3.0
}

fn draw(
    path: &Path,
    title: &str,
    x_desc: &str,
    y_desc: &str,
    lines: &[(String, Points)],
) -> Result<(), Box<dyn std::error::Error>> {
    let root = SVGBackend::new(path, (900, 600)).into_drawing_area();
    root.fill(&WHITE)?;
    let xr = log_range(lines.iter().flat_map(|l| l.1.iter().map(|p| p.0)));
    let yr = log_range(lines.iter().flat_map(|l| l.1.iter().map(|p| p.1)));
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(80)
        .build_cartesian_2d(xr.log_scale(), yr.log_scale())?;
    chart
        .configure_mesh()
        .x_desc(x_desc)
        .y_desc(y_desc)
        .x_label_formatter(&|v| format!("{v:.0e}"))
        .y_label_formatter(&|v| format!("{v:.0e}"))
        .draw()?;
    for (i, (name, pts)) in lines.iter().enumerate() {
        let color = Palette99::pick(i).to_rgba();
        chart
            .draw_series(LineSeries::new(pts.iter().copied(), color.stroke_width(2)))?
            .label(name.clone())
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2))
            });
        chart.draw_series(pts.iter().map(|&p| Circle::new(p, 3, color.filled())))?;
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(SeriesLabelPosition::LowerLeft)
        .draw()?;
    root.present()?;
    Ok(())
}

/// Writes `<stem>_time.svg`, `<stem>_dt.svg` and `<stem>_g.svg` into `dir`; returns their paths.
pub fn figures(
    dir: &Path,
    stem: &str,
    title: &str,
    rows: &[PrecisionRow],
    slopes: &[(String, f64)],
) -> Result<Vec<String>, Box<dyn std::error::Error>> {
    let time = dir.join(format!("{stem}_time.svg"));
    draw(
        &time,
        &format!("{title}: error at the final time against run time"),
        "time (s, minimum of the timed runs)",
        "max-norm error at T",
        &series(rows, |r| Some((r.time_min?, r.error?))),
    )?;
    let dt = dir.join(format!("{stem}_dt.svg"));
    let mut by_dt = series(rows, |r| Some((r.dt?, r.error?)));
    for (name, _) in &mut by_dt {
        if let Some(s) = slopes.iter().find(|s| &s.0 == name) {
            *name = format!("{name} (slope {:.2})", s.1);
        }
    }
    draw(
        &dt,
        &format!("{title}: error against step size, with fitted slopes"),
        "step size h",
        "max-norm error at T",
        &by_dt,
    )?;
    let g = dir.join(format!("{stem}_g.svg"));
    draw(
        &g,
        &format!("{title}: constraint residual max |g| against run time"),
        "time (s)",
        "max |g| over the run",
        &series(rows, |r| Some((r.time_min?, r.max_abs_g?.max(1e-18)))),
    )?;
    Ok(vec![time, dt, g]
        .into_iter()
        .map(|p| p.display().to_string())
        .collect())
}
