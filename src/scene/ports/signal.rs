//! A scene input's signal: its table in the file and the [`Signal`] it compiles to.

use super::expr::Expr;
use crate::port::{Held, Signal};
use crate::scene::error::{FieldPath, SceneErrorKind};
use crate::scene::validate::{Result, err, finite, positive};
use serde::Deserialize;
use std::sync::Arc;

/// `u(t)` of an input, by `type`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(tag = "type", rename_all = "kebab-case", deny_unknown_fields)]
pub enum SignalSpec {
    /// `u = value`.
    Constant {
        /// The value.
        value: f64,
    },
    /// `before` until `at`, `after` from then on.
    Step {
        /// Switching time.
        at: f64,
        /// Value before (default 0).
        #[serde(default)]
        before: f64,
        /// Value after.
        after: f64,
    },
    /// `from` until `start`, linear to `to` at `end`, `to` after.
    Ramp {
        /// Start of the ramp.
        start: f64,
        /// End of the ramp (after `start`).
        end: f64,
        /// Value before (default 0).
        #[serde(default)]
        from: f64,
        /// Value after.
        to: f64,
    },
    /// `offset + amplitude · sin(ω t + phase)`, with `omega` (rad per unit time) or
    /// `frequency` (cycles per unit time), not both.
    Sine {
        /// Amplitude.
        amplitude: f64,
        /// Angular frequency.
        #[serde(default)]
        omega: Option<f64>,
        /// Frequency (`ω = 2π f`).
        #[serde(default)]
        frequency: Option<f64>,
        /// Phase (rad, default 0).
        #[serde(default)]
        phase: f64,
        /// Offset (default 0).
        #[serde(default)]
        offset: f64,
    },
    /// Piecewise-linear through `points = [[t, u], …]` (increasing `t`), or through the rows
    /// `t,u` of a CSV `file` (relative to the scene file's directory, or else to the working
    /// directory; `#` lines and a header row
    /// that does not parse as numbers are skipped). Held constant outside.
    Table {
        /// Inline points.
        #[serde(default)]
        points: Option<Vec<[f64; 2]>>,
        /// A CSV file of `t,u` rows.
        #[serde(default)]
        file: Option<String>,
    },
    /// An expression of `t` (see the format's documentation: `+ − * / ^`, `sin cos tan exp ln
    /// sqrt abs tanh min max`, `pi`), integrated by 5-point Gauss–Legendre per sub-step.
    Expression {
        /// The expression, e.g. `"2 * sin(3 * t) * exp(-t / 4)"`.
        expr: String,
    },
    /// A value held between steps and set by the embedder (zero-order hold); `value` until
    /// it is first set (default 0).
    Held {
        /// The initial value.
        #[serde(default)]
        value: f64,
    },
}

impl SignalSpec {
    /// The signal, its values checked, located at `path`.
    pub(crate) fn compile(
        &self,
        path: &FieldPath,
        base_dir: Option<&std::path::Path>,
    ) -> Result<Signal<f64>> {
        Ok(match self {
            Self::Constant { value } => Signal::Constant(finite(*value, &path.key("value"))?),
            Self::Step { at, before, after } => Signal::Step {
                at: finite(*at, &path.key("at"))?,
                before: finite(*before, &path.key("before"))?,
                after: finite(*after, &path.key("after"))?,
            },
            Self::Ramp {
                start,
                end,
                from,
                to,
            } => {
                let start = finite(*start, &path.key("start"))?;
                let end = finite(*end, &path.key("end"))?;
                if end <= start {
                    return Err(err(
                        SceneErrorKind::Value,
                        path.key("end"),
                        format!("the ramp ends at {end}, not after its start {start}"),
                    ));
                }
                Signal::Ramp {
                    start,
                    end,
                    from: finite(*from, &path.key("from"))?,
                    to: finite(*to, &path.key("to"))?,
                }
            }
            Self::Sine {
                amplitude,
                omega,
                frequency,
                phase,
                offset,
            } => {
                let omega = match (omega, frequency) {
                    (Some(w), None) => finite(*w, &path.key("omega"))?,
                    (None, Some(f)) => {
                        2.0 * std::f64::consts::PI
                            * positive(*f, &path.key("frequency"), "frequency")?
                    }
                    _ => {
                        return Err(err(
                            SceneErrorKind::Value,
                            path.clone(),
                            "a sine takes `omega` (rad per unit time) or `frequency`, exactly one",
                        ));
                    }
                };
                Signal::Sine {
                    amplitude: finite(*amplitude, &path.key("amplitude"))?,
                    omega,
                    phase: finite(*phase, &path.key("phase"))?,
                    offset: finite(*offset, &path.key("offset"))?,
                }
            }
            Self::Table { points, file } => {
                let points: Vec<(f64, f64)> = match (points, file) {
                    (Some(p), None) => p.iter().map(|&[t, u]| (t, u)).collect(),
                    (None, Some(f)) => read_table(&table_path(f, base_dir), &path.key("file"))?,
                    _ => {
                        return Err(err(
                            SceneErrorKind::Value,
                            path.clone(),
                            "a table takes `points` or `file`, exactly one",
                        ));
                    }
                };
                let at = if file.is_some() { "file" } else { "points" };
                Signal::table(&points).ok_or_else(|| {
                    err(
                        SceneErrorKind::Value,
                        path.key(at),
                        format!(
                            "a table needs at least one point, finite values and strictly increasing times ({} points given)",
                            points.len()
                        ),
                    )
                })?
            }
            Self::Expression { expr } => {
                let e = Expr::parse(expr)
                    .map_err(|m| err(SceneErrorKind::Value, path.key("expr"), m))?;
                Signal::Function(Arc::new(move |t| e.eval(t)))
            }
            Self::Held { value } => Signal::Held(Held::new(finite(*value, &path.key("value"))?)),
        })
    }
}

/// Where a table `file` is: beside the scene file when it is there (and the path is relative),
/// otherwise as written (relative to the working directory).
pub(crate) fn table_path(file: &str, base_dir: Option<&std::path::Path>) -> String {
    match base_dir {
        Some(dir) if std::path::Path::new(file).is_relative() && dir.join(file).is_file() => {
            dir.join(file).display().to_string()
        }
        _ => file.to_owned(),
    }
}

/// The `t,u` rows of a CSV file.
fn read_table(file: &str, path: &FieldPath) -> Result<Vec<(f64, f64)>> {
    let text = std::fs::read_to_string(file).map_err(|e| {
        err(
            SceneErrorKind::Io,
            path.clone(),
            format!("cannot read '{file}': {e}"),
        )
    })?;
    let mut points = Vec::new();
    for (line_no, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        let parsed = match fields.as_slice() {
            [t, u] => t.parse::<f64>().ok().zip(u.parse::<f64>().ok()),
            _ => None,
        };
        match parsed {
            Some(p) => points.push(p),
            // A header row before any data.
            None if points.is_empty() && fields.len() == 2 => {}
            None => {
                return Err(err(
                    SceneErrorKind::Value,
                    path.clone(),
                    format!(
                        "'{file}' line {}: expected `t,u`, found '{line}'",
                        line_no + 1
                    ),
                ));
            }
        }
    }
    Ok(points)
}
