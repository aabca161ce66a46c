//! Parameter sweeps: one base scene, the fields to vary addressed by path,
//! and every member run on its own thread of a [rayon](https://docs.rs/rayon) pool — the
//! ensemble of SciML's `EnsembleProblem`, the job array of a batch system.
//!
//! A sweep file:
//!
//! ```toml
//! version = 1
//! scene = "damped_pendulum.toml"        # relative to the sweep file
//! mode = "grid"                         # every combination ("grid") or `members` draws ("random")
//!
//! [[parameters]]
//! path = "effects[1].coefficient"       # a scene field: keys and [indices]
//! values = [0.1, 0.3, 1.0]              # a list …
//!
//! [[parameters]]
//! path = "integrator.dt"
//! grid = { from = 1e-3, to = 1e-2, count = 4, scale = "log" }   # … or a grid
//!
//! [plot]                                # the sweep's SVG: an output against a parameter
//! x = "effects[1].coefficient"
//! y = "energy_final"
//! ```
//!
//! With `mode = "random"`, `members = N` and `seed = S`, each parameter gives
//! `random = { low, high, scale = "linear" | "log" }` (or `values`, drawn from uniformly); the
//! draws come from SplitMix64 (Steele, Lea & Flood, OOPSLA 2014) seeded per member, so member
//! `i` is the same whatever else runs.
//!
//! [`Sweep::members`] lists the members in id order; [`run_member`] runs one (single-threaded,
//! deterministic); [`run_all`] runs them on `threads` threads and returns the rows in id order —
//! the same rows, bit for bit, for any number of threads, since members share nothing.

mod file;
mod rows;
mod values;

pub use file::{GridSpec, ParameterSpec, PlotSpec, RandomSpec, SweepFile};
use lieflow::scene::path::{parse_path, set_path};
use lieflow::scene::{FieldPath, Scene, SceneError, SceneErrorKind};
pub use rows::{MemberRow, run_all, run_all_until, run_member, to_jsonl};
use std::path::Path;
use values::{SplitMix, grid_values};

/// The outputs a row carries (and the plot can show).
pub const OUTPUTS: [&str; 8] = [
    "t",
    "steps",
    "max_abs_g",
    "energy_initial",
    "energy_final",
    "max_abs_energy_error",
    "dissipated",
    "final_state_max_abs",
];

/// A parsed sweep: the file, the base scene as a TOML table, and the parameter values.
#[derive(Debug, Clone)]
pub struct Sweep {
    /// The file.
    pub file: SweepFile,
    base: toml::Table,
    /// Per parameter: its values (grid mode) — empty in random mode.
    values: Vec<Vec<f64>>,
}

/// One member: its id, its parameter values (in the file's order) and its scene.
#[derive(Debug, Clone, PartialEq)]
pub struct Member {
    /// 0-based id, the row order.
    pub id: usize,
    /// `(path, value)` per parameter.
    pub parameters: Vec<(String, f64)>,
}

fn bad(what: impl Into<String>) -> SceneError {
    SceneError::new(SceneErrorKind::Value, FieldPath::root(), what.into())
}

impl Sweep {
    /// Reads a sweep file and its base scene.
    pub fn from_path(path: &Path) -> Result<Self, SceneError> {
        let name = path.display().to_string();
        let text = lieflow::scene::read_scene_file(path)?;
        let file: SweepFile =
            toml::from_str(&text).map_err(|e| SceneError::from_toml_error(&e, &name, &text))?;
        let dir = path.parent().unwrap_or(Path::new("."));
        let scene_path = dir.join(&file.scene);
        let scene_text = lieflow::scene::read_scene_file(&scene_path).map_err(|e| {
            SceneError::new(
                SceneErrorKind::Io,
                FieldPath::root().key("scene"),
                format!("the base scene: {}", e.message),
            )
        })?;
        Self::new(file, &scene_text, &scene_path.display().to_string())
    }

    /// A sweep of the base scene `scene_text` (checked by compiling it once).
    pub fn new(file: SweepFile, scene_text: &str, scene_name: &str) -> Result<Self, SceneError> {
        if file.version != 1 {
            return Err(bad(format!(
                "sweep version {} (this lieflow reads version 1)",
                file.version
            )));
        }
        Scene::from_toml(scene_text, scene_name)?.compile()?;
        let base: toml::Table =
            toml::from_str(scene_text).map_err(|e| bad(e.message().to_owned()))?;
        if file.parameters.is_empty() {
            return Err(bad("a sweep needs at least one [[parameters]]"));
        }
        let mut values = Vec::new();
        for p in &file.parameters {
            parse_path(&p.path)?;
            let given = [p.values.is_some(), p.grid.is_some(), p.random.is_some()];
            if given.iter().filter(|&&b| b).count() != 1 {
                return Err(bad(format!(
                    "parameter '{}': give exactly one of values, grid, random",
                    p.path
                )));
            }
            match file.mode.as_str() {
                "grid" => {
                    let v = match (&p.values, &p.grid) {
                        (Some(v), _) if !v.is_empty() && v.iter().all(|x| x.is_finite()) => {
                            v.clone()
                        }
                        (Some(_), _) => {
                            return Err(bad(format!(
                                "parameter '{}': values must be finite, at least one",
                                p.path
                            )));
                        }
                        (_, Some(g)) => grid_values(g, &p.path)?,
                        _ => {
                            return Err(bad(format!(
                                "parameter '{}': a grid sweep takes values or grid, not random",
                                p.path
                            )));
                        }
                    };
                    values.push(v);
                }
                "random" => {
                    if let Some(v) = &p.values
                        && (v.is_empty() || !v.iter().all(|x| x.is_finite()))
                    {
                        return Err(bad(format!(
                            "parameter '{}': values must be finite, at least one",
                            p.path
                        )));
                    }
                    if let Some(r) = &p.random {
                        let ok = r.low.is_finite()
                            && r.high.is_finite()
                            && r.low < r.high
                            && (r.scale == "linear" || (r.scale == "log" && r.low > 0.0));
                        if !ok {
                            return Err(bad(format!(
                                "parameter '{}': random needs finite low < high (positive for log)",
                                p.path
                            )));
                        }
                    }
                    if p.grid.is_some() {
                        return Err(bad(format!(
                            "parameter '{}': a random sweep takes random or values",
                            p.path
                        )));
                    }
                    values.push(Vec::new());
                }
                m => return Err(bad(format!("unknown mode '{m}' (grid or random)"))),
            }
        }
        if file.mode == "grid"
            && values
                .iter()
                .try_fold(1usize, |acc, v| acc.checked_mul(v.len()))
                .is_none()
        {
            return Err(bad("the grid has more members than a usize counts"));
        }
        if file.mode == "random" && file.members.is_none_or(|m| m == 0) {
            return Err(bad("a random sweep needs members >= 1"));
        }
        if let Some(plot) = &file.plot {
            if !file.parameters.iter().any(|p| p.path == plot.x) {
                return Err(bad(format!("plot.x '{}' is not a parameter", plot.x)));
            }
            if !OUTPUTS.contains(&plot.y.as_str()) {
                return Err(bad(format!(
                    "plot.y '{}' is not an output ({})",
                    plot.y,
                    OUTPUTS.join(", ")
                )));
            }
        }
        let sweep = Self { file, base, values };
        // Every path must name a field of the scene: set each on the base and read the result
        // as a scene (an index past the end, a misspelt key are refused here, before any
        // member runs; a value a member's scene refuses stays that member's failure).
        if let Some(first) = sweep.members().next() {
            sweep.scene(&first).map_err(|e| {
                bad(format!(
                    "the parameters do not fit the base scene {scene_name}: {}",
                    e.message.trim_end()
                ))
            })?;
        }
        Ok(sweep)
    }

    /// The number of members.
    pub fn len(&self) -> usize {
        match self.file.mode.as_str() {
            "random" => self.file.members.unwrap_or(0),
            _ => self.values.iter().map(Vec::len).product(),
        }
    }

    /// `true` without members.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Member `id`: grid members enumerate the Cartesian product with the last parameter
    /// fastest; random members draw from a generator seeded by `seed` and `id`.
    pub fn member(&self, id: usize) -> Member {
        let ps = &self.file.parameters;
        let parameters = if self.file.mode == "random" {
            let mut rng =
                SplitMix(self.file.seed ^ (id as u64).wrapping_mul(0xd134_2543_de82_ef95));
            ps.iter()
                .map(|p| {
                    let u = rng.next_f64();
                    let v = match (&p.random, &p.values) {
                        (Some(r), _) if r.scale == "log" => {
                            (r.low.ln() + (r.high.ln() - r.low.ln()) * u).exp()
                        }
                        (Some(r), _) => r.low + (r.high - r.low) * u,
                        (None, Some(vs)) => vs[((u * vs.len() as f64) as usize).min(vs.len() - 1)],
                        _ => f64::NAN,
                    };
                    (p.path.clone(), v)
                })
                .collect()
        } else {
            let mut rest = id;
            let mut out = vec![(String::new(), 0.0); ps.len()];
            for (k, p) in ps.iter().enumerate().rev() {
                let n = self.values[k].len();
                out[k] = (p.path.clone(), self.values[k][rest % n]);
                rest /= n;
            }
            out
        };
        Member { id, parameters }
    }

    /// Every member, in id order.
    pub fn members(&self) -> impl Iterator<Item = Member> + '_ {
        (0..self.len()).map(|id| self.member(id))
    }

    /// Member `m`'s scene: the base with the member's values set.
    pub fn scene(&self, m: &Member) -> Result<Scene, SceneError> {
        let mut t = self.base.clone();
        for (path, v) in &m.parameters {
            set_path(&mut t, path, *v)?;
        }
        let file = toml::Value::Table(t)
            .try_into()
            .map_err(|e: toml::de::Error| bad(e.message().trim_end().to_owned()))?;
        Ok(Scene::from_file(file))
    }
}
