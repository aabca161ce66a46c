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

use lieflow::scene::{FieldPath, Scene, SceneError, SceneErrorKind, run};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

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

fn default_mode() -> String {
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

fn default_scale() -> String {
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

/// The result of one member: its parameters and its run's summary, or why it failed.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MemberRow {
    /// The member id.
    pub id: usize,
    /// `path → value`, in the file's order.
    pub parameters: Vec<(String, f64)>,
    /// Final time reached.
    pub t: f64,
    /// Steps taken.
    pub steps: usize,
    /// `max |g|` over the run.
    pub max_abs_g: Option<f64>,
    /// `H` at the start and at the end.
    pub energy_initial: Option<f64>,
    /// See `energy_initial`.
    pub energy_final: Option<f64>,
    /// `max |H − H₀|`.
    pub max_abs_energy_error: Option<f64>,
    /// Energy dissipated (with damping).
    pub dissipated: Option<f64>,
    /// `max |x|` of the final state.
    pub final_state_max_abs: f64,
    /// The error kind (`Setup` for a scene the parameters made invalid, else the step
    /// error's kind) and message, if the member failed; its row then holds what it reached.
    pub error: Option<(String, String)>,
}

impl MemberRow {
    /// The named output ([`OUTPUTS`]).
    pub fn output(&self, name: &str) -> Option<f64> {
        match name {
            "t" => Some(self.t),
            "steps" => Some(self.steps as f64),
            "max_abs_g" => self.max_abs_g,
            "energy_initial" => self.energy_initial,
            "energy_final" => self.energy_final,
            "max_abs_energy_error" => self.max_abs_energy_error,
            "dissipated" => self.dissipated,
            "final_state_max_abs" => Some(self.final_state_max_abs),
            _ => None,
        }
    }
    /// The value of parameter `path`.
    pub fn parameter(&self, path: &str) -> Option<f64> {
        self.parameters
            .iter()
            .find(|(p, _)| p == path)
            .map(|&(_, v)| v)
    }
}

fn bad(what: impl Into<String>) -> SceneError {
    SceneError::new(SceneErrorKind::Value, FieldPath::root(), what.into())
}

/// A path segment: a key or an index.
enum Seg<'a> {
    Key(&'a str),
    Index(usize),
}

fn parse_path(path: &str) -> Result<Vec<Seg<'_>>, SceneError> {
    let mut segs = Vec::new();
    for part in path.split('.') {
        let (key, mut rest) = match part.find('[') {
            Some(i) => (&part[..i], &part[i..]),
            None => (part, ""),
        };
        if key.is_empty() {
            return Err(bad(format!("parameter path '{path}': empty key")));
        }
        segs.push(Seg::Key(key));
        while let Some(r) = rest.strip_prefix('[') {
            let end = r
                .find(']')
                .ok_or_else(|| bad(format!("parameter path '{path}': missing ']'")))?;
            let i = r[..end].parse().map_err(|_| {
                bad(format!(
                    "parameter path '{path}': bad index '{}'",
                    &r[..end]
                ))
            })?;
            segs.push(Seg::Index(i));
            rest = &r[end + 1..];
        }
        if !rest.is_empty() {
            return Err(bad(format!("parameter path '{path}': unexpected '{rest}'")));
        }
    }
    Ok(segs)
}

/// The TOML value for `value` in a field that holds `old`: an integer where the base scene has
/// an integer and the value is integral (`links`, `order`), else a float.
fn value_like(old: Option<&toml::Value>, value: f64) -> toml::Value {
    match old {
        Some(toml::Value::Integer(_)) if value.fract() == 0.0 && value.abs() < 9.0e15 => {
            toml::Value::Integer(value as i64)
        }
        _ => toml::Value::Float(value),
    }
}

/// Sets `path` in `table` to `value`: every key and index but the last must exist; the last
/// key may be new (a field the scene leaves at its default).
fn set_path(table: &mut toml::Table, path: &str, value: f64) -> Result<(), SceneError> {
    let segs = parse_path(path)?;
    let missing = |what: &str| {
        bad(format!(
            "parameter path '{path}': the base scene has no {what}"
        ))
    };
    let mut cur: &mut toml::Value = match segs.first() {
        Some(Seg::Key(k)) if segs.len() == 1 => {
            let v = value_like(table.get(*k), value);
            table.insert((*k).to_owned(), v);
            return Ok(());
        }
        Some(Seg::Key(k)) => table
            .get_mut(*k)
            .ok_or_else(|| missing(&format!("'{k}'")))?,
        _ => {
            return Err(bad(format!(
                "parameter path '{path}' must start with a key"
            )));
        }
    };
    for (i, seg) in segs.iter().enumerate().skip(1) {
        let last = i + 1 == segs.len();
        match seg {
            Seg::Key(k) => {
                let t = cur
                    .as_table_mut()
                    .ok_or_else(|| missing(&format!("table before '{k}'")))?;
                if last {
                    let v = value_like(t.get(*k), value);
                    t.insert((*k).to_owned(), v);
                    return Ok(());
                }
                cur = t.get_mut(*k).ok_or_else(|| missing(&format!("'{k}'")))?;
            }
            Seg::Index(j) => {
                let a = cur
                    .as_array_mut()
                    .ok_or_else(|| missing(&format!("array for [{j}]")))?;
                let len = a.len();
                let slot = a
                    .get_mut(*j)
                    .ok_or_else(|| missing(&format!("element [{j}] (it has {len})")))?;
                if last {
                    *slot = value_like(Some(slot), value);
                    return Ok(());
                }
                cur = slot;
            }
        }
    }
    Ok(())
}

/// SplitMix64: a 64-bit state advanced by a Weyl sequence and mixed (Steele, Lea & Flood 2014).
struct SplitMix(u64);

impl SplitMix {
    fn next_f64(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn grid_values(g: &GridSpec, path: &str) -> Result<Vec<f64>, SceneError> {
    if g.count == 0 || !g.from.is_finite() || !g.to.is_finite() {
        return Err(bad(format!(
            "parameter '{path}': a grid needs count >= 1 and finite ends"
        )));
    }
    let n = g.count;
    let t = |i: usize| {
        if n == 1 {
            0.0
        } else {
            i as f64 / (n - 1) as f64
        }
    };
    match g.scale.as_str() {
        "linear" => Ok((0..n).map(|i| g.from + (g.to - g.from) * t(i)).collect()),
        "log" if g.from > 0.0 && g.to > 0.0 => {
            let (a, b) = (g.from.ln(), g.to.ln());
            // The ends exactly as written; the interior geometrically.
            Ok((0..n)
                .map(|i| match i {
                    0 => g.from,
                    _ if i + 1 == n => g.to,
                    _ => (a + (b - a) * t(i)).exp(),
                })
                .collect())
        }
        "log" => Err(bad(format!(
            "parameter '{path}': a log grid needs positive ends"
        ))),
        s => Err(bad(format!(
            "parameter '{path}': unknown scale '{s}' (linear or log)"
        ))),
    }
}

impl Sweep {
    /// Reads a sweep file and its base scene.
    pub fn from_path(path: &Path) -> Result<Self, SceneError> {
        let name = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| {
            SceneError::new(
                SceneErrorKind::Io,
                FieldPath::root(),
                format!("cannot read {name}: {e}"),
            )
        })?;
        let file: SweepFile =
            toml::from_str(&text).map_err(|e| SceneError::from_toml_error(&e, &name, &text))?;
        let dir = path.parent().unwrap_or(Path::new("."));
        let scene_path = dir.join(&file.scene);
        let scene_text = std::fs::read_to_string(&scene_path).map_err(|e| {
            SceneError::new(
                SceneErrorKind::Io,
                FieldPath::root().key("scene"),
                format!("cannot read the base scene {}: {e}", scene_path.display()),
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
        Ok(Self { file, base, values })
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
            .map_err(|e: toml::de::Error| {
                bad(format!("member {}: {}", m.id, e.message().trim_end()))
            })?;
        Ok(Scene::from_file(file))
    }
}

/// Runs one member (single-threaded): its scene compiled and run to the end, no observer.
pub fn run_member(sweep: &Sweep, m: &Member) -> MemberRow {
    let mut row = MemberRow {
        id: m.id,
        parameters: m.parameters.clone(),
        t: 0.0,
        steps: 0,
        max_abs_g: None,
        energy_initial: None,
        energy_final: None,
        max_abs_energy_error: None,
        dissipated: None,
        final_state_max_abs: f64::NAN,
        error: None,
    };
    let compiled = sweep.scene(m).and_then(|s| s.compile());
    let mut c = match compiled {
        Ok(c) => c,
        Err(e) => {
            row.error = Some(("Setup".into(), e.to_string()));
            return row;
        }
    };
    let s = run(c.simulation.as_mut(), &c.plan, &mut |_| {});
    row.t = s.t;
    row.steps = s.steps;
    row.max_abs_g = s.max_abs_g;
    row.energy_initial = s.energy_initial;
    row.energy_final = s.energy_final;
    row.max_abs_energy_error = s.max_abs_energy_error;
    row.dissipated = s.dissipated;
    row.final_state_max_abs = s.x.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    row.error = s.error.map(|f| (f.kind, f.message));
    row
}

/// Runs `members` on a pool of `threads` threads (0: rayon's default, one per core), calling
/// `progress` after each member, and returns the rows in id order with each member's wall time
/// in seconds beside it. Rows do not depend on `threads`.
pub fn run_all(
    sweep: &Sweep,
    members: &[Member],
    threads: usize,
    progress: &(dyn Fn() + Sync),
) -> Result<Vec<(MemberRow, f64)>, String> {
    use rayon::prelude::*;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| format!("cannot start {threads} threads: {e}"))?;
    let mut rows: Vec<(MemberRow, f64)> = pool.install(|| {
        members
            .par_iter()
            .map(|m| {
                let start = std::time::Instant::now();
                let row = run_member(sweep, m);
                progress();
                (row, start.elapsed().as_secs_f64())
            })
            .collect()
    });
    rows.sort_by_key(|(r, _)| r.id);
    Ok(rows)
}

/// One JSON line per row (the deterministic part: no times), in the given order.
pub fn to_jsonl(rows: &[MemberRow]) -> String {
    let mut out = String::new();
    for r in rows {
        out.push_str(&serde_json_line(r));
        out.push('\n');
    }
    out
}

fn serde_json_line(r: &MemberRow) -> String {
    // A small writer (serde_json is the command's dependency, not the library's): numbers in
    // Rust's shortest round-trip form, so equal rows give equal bytes.
    fn num(v: f64) -> String {
        if v.is_finite() {
            format!("{v:?}")
        } else {
            "null".into()
        }
    }
    fn opt(v: Option<f64>) -> String {
        v.map_or_else(|| "null".into(), num)
    }
    fn text(s: &str) -> String {
        let mut o = String::from('"');
        for c in s.chars() {
            match c {
                '"' => o.push_str("\\\""),
                '\\' => o.push_str("\\\\"),
                '\n' => o.push_str("\\n"),
                c if (c as u32) < 0x20 => o.push_str(&format!("\\u{:04x}", c as u32)),
                c => o.push(c),
            }
        }
        o.push('"');
        o
    }
    let params: Vec<String> = r
        .parameters
        .iter()
        .map(|(p, v)| format!("{}:{}", text(p), num(*v)))
        .collect();
    let error = match &r.error {
        None => "null".into(),
        Some((k, m)) => format!("{{\"kind\":{},\"message\":{}}}", text(k), text(m)),
    };
    format!(
        "{{\"id\":{},\"parameters\":{{{}}},\"t\":{},\"steps\":{},\"max_abs_g\":{},\"energy_initial\":{},\"energy_final\":{},\"max_abs_energy_error\":{},\"dissipated\":{},\"final_state_max_abs\":{},\"error\":{}}}",
        r.id,
        params.join(","),
        num(r.t),
        r.steps,
        opt(r.max_abs_g),
        opt(r.energy_initial),
        opt(r.energy_final),
        opt(r.max_abs_energy_error),
        opt(r.dissipated),
        num(r.final_state_max_abs),
        error
    )
}
