//! The run's SVG: energy error and constraint residual over time, the bodies' paths in 2D, and
//! the scene's declared outputs over time (one panel each, at most [`OUTPUT_PANELS`]).

use lieflow::scene::Sample;
use plotters::prelude::*;
use std::path::Path;

/// Points kept for each curve (runs are decimated to about this many).
const POINTS: usize = 2000;
/// Bodies whose paths are drawn at most.
const PATHS: usize = 24;
/// Declared outputs drawn at most (all are in the CSV).
pub const OUTPUT_PANELS: usize = 6;

/// Checks, before a run, that the plot can be written to `path`: an `.svg` name (the plot is
/// SVG; a `.png` would hold SVG bytes) in a directory that takes the file. Creates the file
/// (the run overwrites it), so that an unwritable path fails now, not after the run.
pub fn check_target(path: &Path) -> Result<(), String> {
    let svg = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("svg"));
    if !svg {
        return Err(format!(
            "{}: the plot is SVG; give a file name ending in .svg",
            path.display()
        ));
    }
    std::fs::File::create(path)
        .map(drop)
        .map_err(|e| format!("cannot write {}: {e}", path.display()))
}

/// Decimated samples of a run.
pub struct Series {
    every: usize,
    /// `(t, H − H₀)`.
    energy: Vec<(f64, f64)>,
    /// `(t, max |g|)`.
    residual: Vec<(f64, f64)>,
    /// Per drawn body, its 2D positions.
    paths: Vec<Vec<(f64, f64)>>,
    bodies: Option<(usize, usize)>,
    e0: Option<f64>,
    /// Per drawn output, its name and `(t, value)`.
    outputs: Vec<(String, Vec<(f64, f64)>)>,
}

impl Series {
    /// A series for a run of `steps` steps of `bodies = (dim, count)`.
    pub fn new(steps: usize, bodies: Option<(usize, usize)>, outputs: &[String]) -> Self {
        let drawn = match bodies {
            Some((2, n)) => n.min(PATHS),
            _ => 0,
        };
        Self {
            every: (steps / POINTS).max(1),
            energy: Vec::new(),
            residual: Vec::new(),
            paths: vec![Vec::new(); drawn],
            bodies,
            e0: None,
            outputs: outputs
                .iter()
                .take(OUTPUT_PANELS)
                .map(|n| (n.clone(), Vec::new()))
                .collect(),
        }
    }

    /// Records a sample: every `every`-th, or any with `force` (the last one of a run) unless
    /// it is already the last recorded.
    pub fn push(&mut self, s: &Sample<'_>, force: bool) {
        let due = s.step.is_multiple_of(self.every);
        if !(due || force) || (force && due) {
            return;
        }
        if let Some(e) = s.energy {
            let e0 = *self.e0.get_or_insert(e);
            self.energy.push((s.t, e - e0));
        }
        if let Some(g) = s.g {
            self.residual.push((s.t, g.max(1e-18)));
        }
        if let Some((2, _)) = self.bodies {
            for (b, path) in self.paths.iter_mut().enumerate() {
                path.push((s.x[2 * b], s.x[2 * b + 1]));
            }
        }
        for ((_, curve), &v) in self.outputs.iter_mut().zip(s.outputs) {
            if v.is_finite() {
                curve.push((s.t, v));
            }
        }
    }

    /// Draws the panels that have data into `path`.
    pub fn draw(&self, path: &Path, title: &str) -> Result<(), Box<dyn std::error::Error>> {
        let panels = usize::from(!self.energy.is_empty())
            + usize::from(!self.residual.is_empty())
            + usize::from(!self.paths.is_empty())
            + self.outputs.len();
        if panels == 0 {
            return Err("nothing to plot: the energy and constraint diagnostics are off and the scene is not 2D".into());
        }
        let root = SVGBackend::new(path, (900, 320 * panels as u32)).into_drawing_area();
        root.fill(&WHITE)?;
        let root = root.titled(title, ("sans-serif", 20))?;
        let areas = root.split_evenly((panels, 1));
        let mut next = areas.iter();
        let t_max = self
            .energy
            .last()
            .or(self.residual.last())
            .or(self.outputs.first().and_then(|o| o.1.last()))
            .map_or(1.0, |p| p.0)
            .max(1e-300);
        if !self.energy.is_empty() {
            let area = next.next().expect("a panel per series");
            let (lo, hi) = bounds(self.energy.iter().map(|p| p.1));
            let mut chart = ChartBuilder::on(area)
                .margin(10)
                .x_label_area_size(35)
                .y_label_area_size(90)
                .caption("energy H(t) - H(0)", ("sans-serif", 16))
                .build_cartesian_2d(0.0..t_max, lo..hi)?;
            chart
                .configure_mesh()
                .x_desc("t")
                .y_label_formatter(&|v| format!("{v:.2e}"))
                .draw()?;
            chart.draw_series(LineSeries::new(
                self.energy.iter().copied(),
                BLUE.stroke_width(1),
            ))?;
        }
        if !self.residual.is_empty() {
            let area = next.next().expect("a panel per series");
            let hi = self.residual.iter().map(|p| p.1).fold(1e-17, f64::max) * 10.0;
            let mut chart = ChartBuilder::on(area)
                .margin(10)
                .x_label_area_size(35)
                .y_label_area_size(90)
                .caption("constraint residual max |g(x)|", ("sans-serif", 16))
                .build_cartesian_2d(0.0..t_max, (1e-18..hi).log_scale())?;
            chart
                .configure_mesh()
                .x_desc("t")
                .y_label_formatter(&|v| format!("{v:.0e}"))
                .draw()?;
            chart.draw_series(LineSeries::new(
                self.residual.iter().copied(),
                RED.stroke_width(1),
            ))?;
        }
        if !self.paths.is_empty() {
            let area = next.next().expect("a panel per series");
            let (x0, x1) = bounds(self.paths.iter().flatten().map(|p| p.0));
            let (y0, y1) = bounds(self.paths.iter().flatten().map(|p| p.1));
            let mut chart = ChartBuilder::on(area)
                .margin(10)
                .x_label_area_size(35)
                .y_label_area_size(90)
                .caption("paths", ("sans-serif", 16))
                .build_cartesian_2d(x0..x1, y0..y1)?;
            chart.configure_mesh().x_desc("x").y_desc("y").draw()?;
            for (i, p) in self.paths.iter().enumerate() {
                let color = Palette99::pick(i).mix(0.8);
                chart.draw_series(LineSeries::new(p.iter().copied(), color.stroke_width(1)))?;
            }
        }
        for (i, (name, curve)) in self.outputs.iter().enumerate() {
            let area = next.next().expect("a panel per series");
            let (lo, hi) = bounds(curve.iter().map(|p| p.1));
            let mut chart = ChartBuilder::on(area)
                .margin(10)
                .x_label_area_size(35)
                .y_label_area_size(90)
                .caption(format!("output {name}"), ("sans-serif", 16))
                .build_cartesian_2d(0.0..t_max, lo..hi)?;
            chart
                .configure_mesh()
                .x_desc("t")
                .y_desc(name.as_str())
                .y_label_formatter(&|v| format!("{v:.3e}"))
                .draw()?;
            chart.draw_series(LineSeries::new(
                curve.iter().copied(),
                Palette99::pick(i + 3).stroke_width(1),
            ))?;
        }
        root.present()?;
        Ok(())
    }
}

/// A range around the values with a margin (never empty).
fn bounds(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    if !lo.is_finite() {
        return (-1.0, 1.0);
    }
    let pad = ((hi - lo) * 0.05)
        .max(1e-12 * lo.abs().max(hi.abs()))
        .max(1e-300);
    (lo - pad, hi + pad)
}
