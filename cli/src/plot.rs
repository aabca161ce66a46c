//! The run's SVG, one panel per quantity against `t`: the energy `H − H₀` (and, when the run
//! books dissipated or supplied energy, the balance `H − H₀ + dissipated − supplied`), the
//! constraint residuals `max |g|` and `max |φ|` (log scale; each point the largest over the
//! steps it stands for, so the plotted maximum is the summary's), the bodies' paths at equal
//! aspect with a legend (2D; in 3D the x–y and x–z projections), and the declared outputs
//! (at most [`OUTPUT_PANELS`]).

use crate::number::num;
use crate::plot_axes::{bounds, equal_aspect, log_bounds};
use lieflow::scene::Sample;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

/// Points kept for each curve (runs are decimated to about this many).
const POINTS: usize = 2000;
/// Bodies whose paths are drawn at most.
const PATHS: usize = 24;
/// Bodies named in a path panel's legend at most (more are drawn, unnamed).
const LEGEND: usize = 12;
/// Declared outputs drawn at most (all are in the CSV).
pub const OUTPUT_PANELS: usize = 6;
/// Heights of a time panel and of a path panel, in pixels (the width is 900).
const TIME_PANEL: u32 = 300;
const PATH_PANEL: u32 = 520;
/// The layout of every panel: margin, x-label and y-label areas, caption height.
const MARGIN: u32 = 10;
const X_LABELS: u32 = 35;
const Y_LABELS: u32 = 80;
const CAPTION: u32 = 26;

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

/// Which samples of a run become points.
#[derive(Debug, Clone, Copy)]
pub enum Spacing {
    /// A run of this many steps: every `steps / POINTS`-th.
    Steps(usize),
    /// A run over `(t₀, t_end)` of steps not counted before (the controller's own): the first
    /// sample at or after each of `POINTS` evenly spaced times.
    Time((f64, f64)),
}

/// Decimated samples of a run.
pub struct Series {
    every: usize,
    /// With [`Spacing::Time`]: the interval between points and the time of the next one.
    timed: Option<(f64, f64)>,
    /// The step of the last point recorded.
    recorded: Option<usize>,
    /// `(t, H − H₀)`.
    energy: Vec<(f64, f64)>,
    /// `(t, H − H₀ + dissipated − supplied)`, when the run books either.
    balance: Vec<(f64, f64)>,
    /// `(t, max |g|)` and `(t, max |φ|)` over the steps since the previous point (exact zeros
    /// are left out: a log axis has no place for them).
    g: Vec<(f64, f64)>,
    phi: Vec<(f64, f64)>,
    /// The largest `|g|`, `|φ|` since the last point.
    bucket: (f64, f64),
    /// Per drawn body, its positions.
    paths: Vec<Vec<[f64; 3]>>,
    names: Vec<String>,
    /// Per drawn body, its slot in the state (a rigid body's directors, `<body>#dᵢ`, are not
    /// drawn: its centre is).
    slots: Vec<usize>,
    dim: usize,
    e0: Option<f64>,
    /// Per drawn output, its name and `(t, value)`.
    outputs: Vec<(String, Vec<(f64, f64)>)>,
}

impl Series {
    /// A series for a run spaced by `spacing` of `bodies = (dim, count)` named `names`.
    pub fn new(
        spacing: Spacing,
        bodies: Option<(usize, usize)>,
        names: &[String],
        outputs: &[String],
    ) -> Self {
        let (dim, count) = bodies.map_or((0, 0), |(d, n)| (d, n));
        let slots: Vec<usize> = (0..count)
            .filter(|&b| names.get(b).is_none_or(|n| !n.contains('#')))
            .take(PATHS)
            .collect();
        let drawn = slots.len();
        let (every, timed) = match spacing {
            Spacing::Steps(steps) => ((steps / POINTS).max(1), None),
            Spacing::Time((t0, t_end)) => (1, Some(((t_end - t0) / POINTS as f64, t0))),
        };
        Self {
            every,
            timed,
            recorded: None,
            energy: Vec::new(),
            balance: Vec::new(),
            g: Vec::new(),
            phi: Vec::new(),
            bucket: (0.0, 0.0),
            paths: vec![Vec::new(); drawn],
            names: slots
                .iter()
                .map(|&b| names.get(b).cloned().unwrap_or_else(|| format!("body {b}")))
                .collect(),
            slots,
            dim,
            e0: None,
            outputs: outputs
                .iter()
                .take(OUTPUT_PANELS)
                .map(|n| (n.clone(), Vec::new()))
                .collect(),
        }
    }

    /// Records a sample: the residuals of every one (into the current point's maximum), the
    /// rest every `every`-th, or with `force` (the last one of a run) unless it is already the
    /// last recorded.
    pub fn push(&mut self, s: &Sample<'_>, force: bool) {
        if force {
            if self.recorded == Some(s.step) {
                return;
            }
        } else {
            self.bucket.0 = self.bucket.0.max(s.g.unwrap_or(0.0));
            self.bucket.1 = self.bucket.1.max(s.phi.unwrap_or(0.0));
            let due = match &mut self.timed {
                None => s.step.is_multiple_of(self.every),
                Some((interval, next)) => {
                    let due = s.t >= *next;
                    while *interval > 0.0 && *next <= s.t {
                        *next += *interval;
                    }
                    due
                }
            };
            if !due {
                return;
            }
        }
        self.recorded = Some(s.step);
        if let Some(e) = s.energy {
            let e0 = *self.e0.get_or_insert(e);
            self.energy.push((s.t, e - e0));
            if s.dissipated.is_some() || s.supplied.is_some() {
                let budget = s.dissipated.unwrap_or(0.0) - s.supplied.unwrap_or(0.0);
                self.balance.push((s.t, e - e0 + budget));
            }
        }
        let (g, phi) = std::mem::take(&mut self.bucket);
        if s.g.is_some() && g > 0.0 {
            self.g.push((s.t, g));
        }
        if s.phi.is_some() && phi > 0.0 {
            self.phi.push((s.t, phi));
        }
        let d = self.dim;
        for (&b, path) in self.slots.iter().zip(self.paths.iter_mut()) {
            let mut p = [0.0; 3];
            p[..d].copy_from_slice(&s.x[b * d..(b + 1) * d]);
            path.push(p);
        }
        for ((_, curve), &v) in self.outputs.iter_mut().zip(s.outputs) {
            if v.is_finite() {
                curve.push((s.t, v));
            }
        }
    }

    /// Draws the panels that have data into `path`.
    pub fn draw(&self, path: &Path, title: &str) -> Result<(), Box<dyn std::error::Error>> {
        let path_panels = match (self.paths.is_empty(), self.dim) {
            (true, _) => 0,
            (false, 3) => 2,
            (false, _) => 1,
        };
        let time_panels = usize::from(!self.energy.is_empty())
            + usize::from(!self.g.is_empty())
            + usize::from(!self.phi.is_empty())
            + self.outputs.len();
        if time_panels + path_panels == 0 {
            return Err("nothing to plot: the energy and constraint diagnostics are off and the scene has no bodies".into());
        }
        let height = TIME_PANEL * time_panels as u32 + PATH_PANEL * path_panels as u32 + 40;
        let root = SVGBackend::new(path, (900, height)).into_drawing_area();
        root.fill(&WHITE)?;
        let root = root.titled(title, ("sans-serif", 20))?;
        let mut rest = root;
        let mut next = |h: u32| {
            let (top, bottom) = rest.split_vertically(h);
            rest = bottom;
            top
        };
        let t_max = self
            .energy
            .last()
            .or(self.g.last())
            .or(self.outputs.first().and_then(|o| o.1.last()))
            .map_or(1.0, |p| p.0)
            .max(1e-300);
        if !self.energy.is_empty() {
            let mut curves = vec![("H(t) - H(0)", &self.energy, BLUE)];
            if !self.balance.is_empty() {
                curves.push(("H - H(0) + dissipated - supplied", &self.balance, RED));
            }
            linear_panel(&next(TIME_PANEL), "energy", t_max, &curves)?;
        }
        for (series, what, color) in [(&self.g, "g", RED), (&self.phi, "phi", MAGENTA)] {
            if !series.is_empty() {
                let max = series.iter().map(|p| p.1).fold(0.0, f64::max);
                let caption = format!("constraint residual max |{what}| (largest {})", num(max, 3));
                log_panel(&next(TIME_PANEL), &caption, t_max, series, color)?;
            }
        }
        if path_panels > 0 {
            for axes in if self.dim == 3 {
                &[(0, 1), (0, 2)][..]
            } else {
                &[(0, 1)][..]
            } {
                self.path_panel(&next(PATH_PANEL), *axes)?;
            }
        }
        for (i, (name, curve)) in self.outputs.iter().enumerate() {
            let color = Palette99::pick(i + 3).to_rgba();
            let label = format!("output {name}");
            linear_panel(&next(TIME_PANEL), &label, t_max, &[(name, curve, color)])?;
        }
        rest.present()?;
        Ok(())
    }

    /// The paths in the plane of coordinates `(a, b)`, at equal aspect, with a legend.
    fn path_panel(
        &self,
        area: &DrawingArea<SVGBackend<'_>, Shift>,
        (a, b): (usize, usize),
    ) -> Result<(), Box<dyn std::error::Error>> {
        let axis = ["x", "y", "z"];
        let xs = bounds(self.paths.iter().flatten().map(|p| p[a]));
        let ys = bounds(self.paths.iter().flatten().map(|p| p[b]));
        let (w, h) = area.dim_in_pixel();
        let pixels = (
            f64::from(w.saturating_sub(2 * MARGIN + Y_LABELS)),
            f64::from(h.saturating_sub(2 * MARGIN + X_LABELS + CAPTION)),
        );
        let ((x0, x1), (y0, y1)) = equal_aspect(xs, ys, pixels);
        let caption = format!("paths, {}-{} plane (equal aspect)", axis[a], axis[b]);
        let mut chart = ChartBuilder::on(area)
            .margin(MARGIN)
            .caption(caption, ("sans-serif", 16))
            .x_label_area_size(X_LABELS)
            .y_label_area_size(Y_LABELS)
            .build_cartesian_2d(x0..x1, y0..y1)?;
        chart
            .configure_mesh()
            .x_desc(axis[a])
            .y_desc(axis[b])
            .x_label_formatter(&|v| tick(*v, x1 - x0))
            .y_label_formatter(&|v| tick(*v, y1 - y0))
            .draw()?;
        for (i, (p, name)) in self.paths.iter().zip(&self.names).enumerate() {
            let color = Palette99::pick(i).mix(0.85);
            let drawn = chart.draw_series(LineSeries::new(
                p.iter().map(|q| (q[a], q[b])),
                color.stroke_width(1),
            ))?;
            if i < LEGEND {
                drawn
                    .label(name.as_str())
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], color));
            }
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()?;
        Ok(())
    }
}

/// A named curve `(t, value)` and its colour.
type Curve<'a, C> = (&'a str, &'a Vec<(f64, f64)>, C);

/// A panel of curves against `t` on a linear axis, with a legend when there are several;
/// ticks in the command's number format (a tick at zero reads `0`).
fn linear_panel<C: Color + Copy>(
    area: &DrawingArea<SVGBackend<'_>, Shift>,
    caption: &str,
    t_max: f64,
    curves: &[Curve<'_, C>],
) -> Result<(), Box<dyn std::error::Error>> {
    let (lo, hi) = bounds(curves.iter().flat_map(|c| c.1.iter().map(|p| p.1)));
    let span = hi - lo;
    let mut chart = ChartBuilder::on(area)
        .margin(MARGIN)
        .caption(caption, ("sans-serif", 16))
        .x_label_area_size(X_LABELS)
        .y_label_area_size(Y_LABELS)
        .build_cartesian_2d(0.0..t_max, lo..hi)?;
    chart
        .configure_mesh()
        .x_desc("t")
        .x_label_formatter(&|v| num(*v, 4))
        .y_label_formatter(&|v| tick(*v, span))
        .draw()?;
    for (name, curve, color) in curves {
        let style = color.stroke_width(1);
        chart
            .draw_series(LineSeries::new(curve.iter().copied(), style))?
            .label(*name)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], style));
    }
    if curves.len() > 1 {
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()?;
    }
    Ok(())
}

/// A panel of one positive curve against `t` on a log axis spanning whole decades, at least
/// two: drawn as `log₁₀` on a linear axis with a labelled tick at every decade (`1e-15`).
fn log_panel(
    area: &DrawingArea<SVGBackend<'_>, Shift>,
    caption: &str,
    t_max: f64,
    curve: &[(f64, f64)],
    color: RGBColor,
) -> Result<(), Box<dyn std::error::Error>> {
    let (lo, hi) = log_bounds(curve.iter().map(|p| p.1));
    let (a, b) = (lo.log10().round(), hi.log10().round());
    let decades = (b - a) as usize;
    let mut chart = ChartBuilder::on(area)
        .margin(MARGIN)
        .caption(caption, ("sans-serif", 16))
        .x_label_area_size(X_LABELS)
        .y_label_area_size(Y_LABELS)
        .build_cartesian_2d(0.0..t_max, a..b)?;
    chart
        .configure_mesh()
        .x_desc("t")
        .y_labels(decades + 1)
        .x_label_formatter(&|v| num(*v, 4))
        .y_label_formatter(&|v| {
            if (v - v.round()).abs() < 1e-6 {
                format!("1e{}", v.round())
            } else {
                String::new()
            }
        })
        .draw()?;
    chart.draw_series(LineSeries::new(
        curve.iter().map(|&(t, v)| (t, v.log10())),
        color.stroke_width(1),
    ))?;
    Ok(())
}

/// A tick label on a linear axis of length `span`: a tick within rounding of zero is `0`, not
/// `-2.22e-16`.
fn tick(v: f64, span: f64) -> String {
    if v.abs() <= 1e-9 * span {
        "0".to_owned()
    } else {
        num(v, 3)
    }
}
