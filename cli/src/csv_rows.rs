//! The run's CSV: a header naming the scene and scheme, then every `every`-th sample (and the
//! last one), written as the run goes; an I/O error is kept and reported after the run.
//!
//! Columns: `step, t`, the state by name (`q.<body>.<axis>`, `p.<body>.<axis>`), the
//! velocities `v.<body>.<axis> = p/m` for scenes of bodies, `energy, max_abs_g, max_abs_phi`,
//! one `lambda.<constraint>` per constraint row (the multipliers `(λ_k + λ_{k+1})/2` of the step
//! that reached the row's state; empty in the initial row), then the declared outputs.

use lieflow::scene::{Assembly, Sample};
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;

/// What a row holds besides the state, and the names of its columns.
pub(crate) struct Columns {
    /// The state's component names.
    pub(crate) state: Vec<String>,
    /// `1/m` per position coordinate, for the velocities (scenes of bodies).
    pub(crate) inv_mass: Option<Vec<f64>>,
    /// One name per constraint row.
    pub(crate) multipliers: Vec<String>,
    /// The declared outputs.
    pub(crate) outputs: Vec<String>,
}

/// An observer of a run that writes its samples as CSV rows.
pub(crate) struct CsvRows {
    w: BufWriter<File>,
    columns: Columns,
    every: usize,
    /// The steps planned (`None`: not known before, the controller's own steps).
    steps: Option<usize>,
    /// The last sample seen was written (a run that stops early ends with its last state).
    last_written: bool,
    error: Option<std::io::Error>,
}

impl CsvRows {
    /// Creates `path` and writes the header.
    pub(crate) fn create(
        path: &Path,
        columns: Columns,
        a: &Assembly,
        every: usize,
        steps: Option<usize>,
    ) -> Result<Self, String> {
        let f = File::create(path).map_err(|e| format!("cannot create {}: {e}", path.display()))?;
        let mut rows = Self {
            w: BufWriter::new(f),
            columns,
            every,
            steps,
            last_written: true,
            error: None,
        };
        if let Err(e) = write_header(&mut rows.w, &rows.columns, a) {
            rows.error = Some(e);
        }
        Ok(rows)
    }

    /// Writes `s` if it is an `every`-th step or the last planned one.
    pub(crate) fn observe(&mut self, s: &Sample<'_>) {
        self.last_written = false;
        if s.step.is_multiple_of(self.every) || Some(s.step) == self.steps {
            self.last_written = true;
            self.write(s);
        }
    }

    /// Writes the final sample unless it was written, flushes, and returns the first I/O error.
    pub(crate) fn finish(mut self, last: &Sample<'_>) -> Option<std::io::Error> {
        if !self.last_written {
            self.write(last);
        }
        if let Err(e) = self.w.flush() {
            self.error.get_or_insert(e);
        }
        self.error
    }

    fn write(&mut self, s: &Sample<'_>) {
        if let Err(e) = write_row(&mut self.w, &self.columns, s) {
            self.error.get_or_insert(e);
        }
    }
}

fn write_header(w: &mut impl Write, c: &Columns, a: &Assembly) -> std::io::Result<()> {
    writeln!(
        w,
        "# lieflow {} scene: {}; scheme: {}",
        env!("CARGO_PKG_VERSION"),
        a.name,
        a.scheme
    )?;
    write!(w, "step,t")?;
    for name in &c.state {
        write!(w, ",{name}")?;
    }
    if c.inv_mass.is_some() {
        for name in c.state.iter().filter_map(|n| n.strip_prefix("p.")) {
            write!(w, ",v.{name}")?;
        }
    }
    write!(w, ",energy,max_abs_g,max_abs_phi")?;
    for name in &c.multipliers {
        write!(w, ",lambda.{name}")?;
    }
    for name in &c.outputs {
        write!(w, ",{name}")?;
    }
    writeln!(w)
}

/// A row: every number in its shortest form that reads back to the same `f64` (`{:?}`:
/// scientific below 1e-5 and from 1e16, so a subnormal is `5e-324`, not 324 digits).
fn write_row(w: &mut impl Write, c: &Columns, s: &Sample<'_>) -> std::io::Result<()> {
    write!(w, "{},{:?}", s.step, s.t)?;
    for v in s.x {
        write!(w, ",{v:?}")?;
    }
    if let Some(inv_mass) = &c.inv_mass {
        let p = &s.x[s.x.len() / 2..];
        for (p, w_i) in p.iter().zip(inv_mass) {
            write!(w, ",{:?}", p * w_i)?;
        }
    }
    let opt = |v: Option<f64>| v.map_or_else(String::new, |v| format!("{v:?}"));
    write!(w, ",{},{},{}", opt(s.energy), opt(s.g), opt(s.phi))?;
    for k in 0..c.multipliers.len() {
        match s.multipliers.get(k) {
            Some(v) => write!(w, ",{v:?}")?,
            None => write!(w, ",")?,
        }
    }
    for v in s.outputs {
        write!(w, ",{v:?}")?;
    }
    writeln!(w)
}
