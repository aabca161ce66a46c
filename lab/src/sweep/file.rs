//! The sweep file's format (serde types): the base scene, the parameters with their values,
//! grids or random draws, and the plot.

use serde::Deserialize;
use std::path::PathBuf;

/// The sweep file (version 1).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SweepFile {
    /// Format version: 1.
    pub version: u32,
    /// The base scene, relative to the sweep file.
    pub scene: PathBuf,
    /// `"grid"` (default): the Cartesian product of every parameter's values; `"random"`:
    /// `members` draws.
    #[serde(default = "default_mode")]
    pub mode: String,
    /// Members of a random sweep.
    pub members: Option<usize>,
    /// Seed of a random sweep (default 0).
    #[serde(default)]
    pub seed: u64,
    /// The parameters.
    pub parameters: Vec<ParameterSpec>,
    /// The SVG's axes.
    pub plot: Option<PlotSpec>,
}

pub(crate) fn default_mode() -> String {
    "grid".into()
}

/// One varied field.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ParameterSpec {
    /// The scene field, e.g. `effects[1].coefficient`, `integrator.dt`,
    /// `bodies[0].position[1]`.
    pub path: String,
    /// Explicit values.
    pub values: Option<Vec<f64>>,
    /// A grid.
    pub grid: Option<GridSpec>,
    /// A random draw (random mode).
    pub random: Option<RandomSpec>,
}

/// `count` values from `from` to `to`, evenly spaced or (`scale = "log"`) geometrically.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GridSpec {
    /// First value.
    pub from: f64,
    /// Last value.
    pub to: f64,
    /// Number of values, at least 1.
    pub count: usize,
    /// `"linear"` (default) or `"log"`.
    #[serde(default = "default_scale")]
    pub scale: String,
}

/// A uniform draw in `[low, high)`, or log-uniform (`scale = "log"`, both positive).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RandomSpec {
    /// Lower bound.
    pub low: f64,
    /// Upper bound.
    pub high: f64,
    /// `"linear"` (default) or `"log"`.
    #[serde(default = "default_scale")]
    pub scale: String,
}

pub(crate) fn default_scale() -> String {
    "linear".into()
}

/// The axes of the sweep's SVG.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlotSpec {
    /// A parameter path.
    pub x: String,
    /// An output: one of [`OUTPUTS`].
    pub y: String,
}
