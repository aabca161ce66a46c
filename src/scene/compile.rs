//! Scene → model and scheme: validation with located errors, the assembly of only the declared
//! terms, the choice of scheme, and the initial-state checks.

use super::error::{FieldPath, SceneError, SceneErrorKind};
use super::gram::MassGram;
use super::model::{
    ConstraintKind, ConstraintTerm, Counter, EffectKind, PairLaw, Potential, PotentialTerm,
    SceneModel, StructureTerm,
};
use super::run::{ModelRun, RunPlan, Simulation};
use super::schema::{
    Builtin, ConstraintSpec, EffectSpec, Flags, IntegratorSpec, SCENE_VERSION, SceneFile,
};
use crate::error::{LinearSolveError, SetupError};
use crate::flow::coefficients::table_by_name;
use crate::flow::{
    CompositionTable, ConstrainedDiscreteGradient, Coupling, DiscreteGradient, Flow, FlowExt,
    ImplicitMidpoint, Projected, ProjectedMidpoint, ProjectionOptions, Scheme, from_fn,
};
use crate::linalg::LinearSolver;
use crate::nonlinear::{NewtonOptions, SMALL_MAX};
use crate::real::Real;
use crate::system::{Case, HolonomicConstraint, System, Unconstrained};
use crate::vector::Vector;
use faer::Col;
use num_traits::Zero as _;
use std::collections::HashMap;
use std::sync::Arc;

type Result<T> = std::result::Result<T, SceneError>;

/// The most bodies a scene may generate (the state alone is then 2·3·10⁷ doubles, 480 MB).
pub const MAX_BODIES: usize = 10_000_000;

/// The most steps a run may plan (`t_end / dt`).
pub const MAX_STEPS: usize = 1_000_000_000_000;

/// The most pairs a pair potential may visit per evaluation (it has no cut-off).
pub const MAX_PAIRS: usize = 50_000_000;

/// The largest number of unknowns (`n`, or `n + m` for the joint midpoint system) on which the
/// implicit schemes factor a dense Newton matrix at every step.
pub const DENSE_MAX_DIM: usize = 400;

/// What a compiled scene assembled: printed by `lieflow check`.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Assembly {
    /// The scene's name.
    pub name: String,
    /// Dimension of the space (scenes of bodies).
    pub dim: Option<usize>,
    /// Number of bodies.
    pub bodies: usize,
    /// Length of the state.
    pub state_len: usize,
    /// Constraint terms by type and their rows, e.g. `("rod", 12)`.
    pub constraints: Vec<(String, usize)>,
    /// Total constraint rows `m`.
    pub constraint_rows: usize,
    /// The assembled terms: `(label, kind)`.
    pub effects: Vec<(String, String)>,
    /// Declared parts switched off by flags.
    pub disabled: Vec<String>,
    /// The skew part `J` of `M` canonical (no magnetic field).
    pub canonical: bool,
    /// `M` has a dissipative part.
    pub dissipative: bool,
    /// The paper's case: `degenerate` (`⟨g,g⟩ = 0`) or `non-degenerate`; `None` without constraints.
    pub case: Option<String>,
    /// The projection variant (`decoupled`, `coupled`, `symmetric`).
    pub projection: Option<String>,
    /// The scheme, described.
    pub scheme: String,
    /// Its order.
    pub order: u32,
    /// The multiplier solver backend.
    pub solver: Option<String>,
    /// Steps planned.
    pub steps: usize,
    /// The initial projection, if the scene asked for one: `(max |Δq|, max |Δp|)`.
    pub initial_projection: Option<(f64, f64)>,
    /// Redundant constraints removed (`redundant = "drop-dependent"`), by label.
    pub dropped_constraints: Vec<String>,
}

/// A compiled scene: the simulation, what was assembled, and the run's plan.
pub struct Compiled {
    /// The simulation, ready to step.
    pub simulation: Box<dyn Simulation>,
    /// What was assembled.
    pub assembly: Assembly,
    /// Steps and diagnostics.
    pub plan: RunPlan,
    /// The assembled model (`None` for built-in models).
    pub model: Option<Arc<SceneModel>>,
}

impl std::fmt::Debug for Compiled {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Compiled")
            .field("assembly", &self.assembly)
            .field("plan", &self.plan)
            .finish_non_exhaustive()
    }
}

fn err(kind: SceneErrorKind, path: FieldPath, msg: impl Into<String>) -> SceneError {
    SceneError::new(kind, path, msg)
}

/// A body after generators are expanded.
struct Body {
    name: String,
    mass: f64,
    q: [f64; 3],
    v: [f64; 3],
    charge: f64,
}

/// A constraint term as declared: its geometry, its label, where it is in the file.
type Declared = (ConstraintKind, String, FieldPath);

/// Bodies, names and selectors.
struct Bodies {
    dim: usize,
    list: Vec<Body>,
    groups: HashMap<String, Vec<usize>>,
}

impl Bodies {
    fn add_group(&mut self, name: &str, members: Vec<usize>, path: &FieldPath) -> Result<()> {
        if name.is_empty() || name == "*" || name.contains('.') {
            return Err(err(
                SceneErrorKind::Reference,
                path.clone(),
                format!("the name '{name}' is reserved or empty (no '.', not '*')"),
            ));
        }
        if self.groups.insert(name.to_owned(), members).is_some() {
            return Err(err(
                SceneErrorKind::Reference,
                path.clone(),
                format!("the name '{name}' is used twice"),
            ));
        }
        Ok(())
    }

    fn push(&mut self, body: Body) -> usize {
        self.list.push(body);
        self.list.len() - 1
    }

    /// Refuses `more` bodies at `path` if they would take the scene past [`MAX_BODIES`].
    fn reserve(&mut self, more: usize, path: &FieldPath) -> Result<()> {
        if more > MAX_BODIES - self.list.len().min(MAX_BODIES) {
            return Err(err(
                SceneErrorKind::Unsupported,
                path.clone(),
                format!("the scene would have more than {MAX_BODIES} bodies"),
            ));
        }
        self.list.reserve(more);
        Ok(())
    }

    /// The bodies a selector names.
    fn select(&self, sel: &str, path: &FieldPath) -> Result<Vec<usize>> {
        if sel == "*" {
            return Ok((0..self.list.len()).collect());
        }
        if let Some(g) = self.groups.get(sel) {
            return Ok(g.clone());
        }
        if let Some((group, index)) = sel.rsplit_once('.')
            && let (Some(g), Ok(i)) = (self.groups.get(group), index.parse::<usize>())
        {
            return g.get(i).map(|&b| vec![b]).ok_or_else(|| {
                err(
                    SceneErrorKind::Reference,
                    path.clone(),
                    format!(
                        "'{sel}': '{group}' has {} bodies (0 … {})",
                        g.len(),
                        g.len().saturating_sub(1)
                    ),
                )
            });
        }
        Err(err(
            SceneErrorKind::Reference,
            path.clone(),
            format!(
                "'{sel}' names no body or group (bodies, chains, shells and grids are named; '*' is all)"
            ),
        ))
    }

    /// The bodies the selectors name, each once, in order of first mention (`O(N)` with a mask).
    fn select_all(&self, sels: &[String], path: &FieldPath) -> Result<Vec<usize>> {
        let mut seen = vec![false; self.list.len()];
        let mut out = Vec::new();
        for (i, s) in sels.iter().enumerate() {
            for b in self.select(s, &path.index(i))? {
                if !std::mem::replace(&mut seen[b], true) {
                    out.push(b);
                }
            }
        }
        Ok(out)
    }

    /// `None` → all bodies.
    fn select_opt(&self, sels: &Option<Vec<String>>, path: &FieldPath) -> Result<Vec<usize>> {
        match sels {
            None => Ok((0..self.list.len()).collect()),
            Some(s) => self.select_all(s, path),
        }
    }
}

/// `x` if `ok(x)`, else a `Value` error at `path` saying what `x` must be.
fn check(x: f64, path: &FieldPath, ok: bool, must: impl FnOnce() -> String) -> Result<f64> {
    if ok {
        Ok(x)
    } else {
        Err(err(
            SceneErrorKind::Value,
            path.clone(),
            format!("{}, not {x}", must()),
        ))
    }
}

fn finite(x: f64, path: &FieldPath) -> Result<f64> {
    check(x, path, x.is_finite(), || "the value must be finite".into())
}

fn positive(x: f64, path: &FieldPath, what: &str) -> Result<f64> {
    check(x, path, x.is_finite() && x > 0.0, || {
        format!("the {what} must be positive and finite")
    })
}

fn non_negative(x: f64, path: &FieldPath, what: &str) -> Result<f64> {
    check(x, path, x.is_finite() && x >= 0.0, || {
        format!("the {what} must be non-negative and finite")
    })
}

/// A `dim`-vector as `[f64; 3]` (zero-padded).
fn vector(v: &[f64], dim: usize, path: &FieldPath) -> Result<[f64; 3]> {
    if v.len() != dim {
        return Err(err(
            SceneErrorKind::Dimension,
            path.clone(),
            format!("{} entries, but the scene is {dim}-dimensional", v.len()),
        ));
    }
    let mut out = [0.0; 3];
    for (i, &x) in v.iter().enumerate() {
        out[i] = finite(x, &path.index(i))?;
    }
    Ok(out)
}

fn vector_or(
    v: &Option<Vec<f64>>,
    dim: usize,
    path: &FieldPath,
    default: [f64; 3],
) -> Result<[f64; 3]> {
    match v {
        Some(v) => vector(v, dim, path),
        None => Ok(default),
    }
}

fn norm(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// Expands bodies and generators; returns the bodies and the generators' own constraints.
fn expand_bodies(file: &SceneFile, dim: usize) -> Result<(Bodies, Vec<Declared>)> {
    let mut bodies = Bodies {
        dim,
        list: Vec::new(),
        groups: HashMap::new(),
    };
    let mut generated = Vec::new();
    let root = FieldPath::root();
    for (i, b) in file.bodies.iter().enumerate() {
        let path = root.key("bodies").index(i);
        let body = Body {
            name: b.name.clone(),
            mass: positive(b.mass, &path.key("mass"), "mass")?,
            q: vector(&b.position, dim, &path.key("position"))?,
            v: vector_or(&b.velocity, dim, &path.key("velocity"), [0.0; 3])?,
            charge: finite(b.charge, &path.key("charge"))?,
        };
        bodies.reserve(1, &path)?;
        let idx = bodies.push(body);
        bodies.add_group(&b.name, vec![idx], &path.key("name"))?;
    }
    for (i, c) in file.chains.iter().enumerate() {
        let path = root.key("chains").index(i);
        if c.links == 0 {
            return Err(err(
                SceneErrorKind::Value,
                path.key("links"),
                "a chain needs at least one link",
            ));
        }
        bodies.reserve(c.links, &path.key("links"))?;
        let mass = positive(c.mass, &path.key("mass"), "mass")?;
        let length = positive(c.length, &path.key("length"), "length")?;
        let charge = finite(c.charge, &path.key("charge"))?;
        let anchor = vector_or(&c.anchor, dim, &path.key("anchor"), [0.0; 3])?;
        let dir = vector_or(&c.direction, dim, &path.key("direction"), [1.0, 0.0, 0.0])?;
        let n = norm(dir);
        if n == 0.0 {
            return Err(err(
                SceneErrorKind::Value,
                path.key("direction"),
                "the direction must not be zero",
            ));
        }
        let dir = dir.map(|x| x / n);
        let mut members = Vec::with_capacity(c.links);
        for k in 0..c.links {
            let s = (k + 1) as f64 * length;
            let q = [
                anchor[0] + s * dir[0],
                anchor[1] + s * dir[1],
                anchor[2] + s * dir[2],
            ];
            let idx = bodies.push(Body {
                name: format!("{}.{k}", c.name),
                mass,
                q,
                v: [0.0; 3],
                charge,
            });
            let kind = match members.last() {
                None => ConstraintKind::Rod {
                    a: idx,
                    b: None,
                    point: anchor,
                    length,
                },
                Some(&prev) => ConstraintKind::Rod {
                    a: idx,
                    b: Some(prev),
                    point: [0.0; 3],
                    length,
                },
            };
            generated.push((
                kind,
                format!("chains[{i}] '{}' link {k}", c.name),
                path.key("links"),
            ));
            members.push(idx);
        }
        bodies.add_group(&c.name, members, &path.key("name"))?;
    }
    for (i, s) in file.shells.iter().enumerate() {
        let path = root.key("shells").index(i);
        let radius = positive(s.radius, &path.key("radius"), "radius")?;
        let mass = positive(s.mass, &path.key("mass"), "mass")?;
        let charge = finite(s.charge, &path.key("charge"))?;
        let center = vector_or(&s.center, dim, &path.key("center"), [0.0; 3])?;
        let mut points: Vec<([f64; 3], [f64; 3])> = Vec::new();
        match (&s.rings, &s.positions) {
            (Some(rings), None) => {
                if s.velocities.is_some() {
                    return Err(err(
                        SceneErrorKind::Value,
                        path.key("velocities"),
                        "`velocities` go with explicit `positions`; ring particles start at rest",
                    ));
                }
                let total = rings
                    .iter()
                    .try_fold(0usize, |a, &c| a.checked_add(c))
                    .unwrap_or(usize::MAX);
                bodies.reserve(total, &path.key("rings"))?;
                let rp = path.key("rings");
                if dim == 2 && rings.len() != 1 {
                    return Err(err(
                        SceneErrorKind::Dimension,
                        rp,
                        "in 2D, `rings` has one entry: the number of particles on the circle",
                    ));
                }
                let nr = rings.len();
                for (k, &count) in rings.iter().enumerate() {
                    if count == 0 {
                        return Err(err(
                            SceneErrorKind::Value,
                            rp.index(k),
                            "a ring needs at least one particle",
                        ));
                    }
                    for j in 0..count {
                        let u = if dim == 2 {
                            let a = 2.0 * std::f64::consts::PI * j as f64 / count as f64;
                            [a.cos(), a.sin(), 0.0]
                        } else {
                            let theta = (k as f64 + 0.5) * std::f64::consts::PI / nr as f64;
                            let phi = 2.0 * std::f64::consts::PI * (j as f64 + 0.5 * k as f64)
                                / count as f64;
                            [
                                theta.sin() * phi.cos(),
                                theta.sin() * phi.sin(),
                                theta.cos(),
                            ]
                        };
                        points.push((
                            [
                                center[0] + radius * u[0],
                                center[1] + radius * u[1],
                                center[2] + radius * u[2],
                            ],
                            [0.0; 3],
                        ));
                    }
                }
            }
            (None, Some(pos)) => {
                let pp = path.key("positions");
                bodies.reserve(pos.len(), &pp)?;
                for (j, p) in pos.iter().enumerate() {
                    let q = vector(p, dim, &pp.index(j))?;
                    let r = norm(sub(q, center));
                    if (r - radius).abs() > 1e-12 * radius {
                        return Err(err(
                            SceneErrorKind::OffConstraints,
                            pp.index(j),
                            format!(
                                "at distance {r} from the centre, not on the sphere of radius {radius}"
                            ),
                        ));
                    }
                    points.push((q, [0.0; 3]));
                }
                if let Some(vels) = &s.velocities {
                    let vp = path.key("velocities");
                    if vels.len() != pos.len() {
                        return Err(err(
                            SceneErrorKind::Dimension,
                            vp,
                            format!("{} velocities for {} positions", vels.len(), pos.len()),
                        ));
                    }
                    for (j, v) in vels.iter().enumerate() {
                        points[j].1 = vector(v, dim, &vp.index(j))?;
                    }
                }
            }
            _ => {
                return Err(err(
                    SceneErrorKind::Value,
                    path.clone(),
                    "a shell takes either `rings` or `positions`, exactly one of them",
                ));
            }
        }
        let mut members = Vec::new();
        for (j, (q, v)) in points.into_iter().enumerate() {
            let idx = bodies.push(Body {
                name: format!("{}.{j}", s.name),
                mass,
                q,
                v,
                charge,
            });
            generated.push((
                ConstraintKind::Sphere {
                    body: idx,
                    center,
                    radius,
                },
                format!("shells[{i}] '{}' particle {j}", s.name),
                path.clone(),
            ));
            members.push(idx);
        }
        bodies.add_group(&s.name, members, &path.key("name"))?;
    }
    for (i, g) in file.grids.iter().enumerate() {
        let path = root.key("grids").index(i);
        let spacing = positive(g.spacing, &path.key("spacing"), "spacing")?;
        let mass = positive(g.mass, &path.key("mass"), "mass")?;
        let charge = finite(g.charge, &path.key("charge"))?;
        let origin = vector_or(&g.origin, dim, &path.key("origin"), [0.0; 3])?;
        let v = vector_or(&g.velocity, dim, &path.key("velocity"), [0.0; 3])?;
        if g.counts.len() != dim {
            return Err(err(
                SceneErrorKind::Dimension,
                path.key("counts"),
                format!(
                    "{} entries, but the scene is {dim}-dimensional",
                    g.counts.len()
                ),
            ));
        }
        if let Some(k) = g.counts.iter().position(|&c| c == 0) {
            return Err(err(
                SceneErrorKind::Value,
                path.key("counts").index(k),
                "at least one particle per axis",
            ));
        }
        let total = g
            .counts
            .iter()
            .try_fold(1usize, |a, &c| a.checked_mul(c))
            .unwrap_or(usize::MAX);
        bodies.reserve(total, &path.key("counts"))?;
        let mut members = Vec::with_capacity(total);
        for j in 0..total {
            let mut rest = j;
            let mut q = origin;
            for axis in (0..dim).rev() {
                q[axis] += spacing * (rest % g.counts[axis]) as f64;
                rest /= g.counts[axis];
            }
            members.push(bodies.push(Body {
                name: format!("{}.{j}", g.name),
                mass,
                q,
                v,
                charge,
            }));
        }
        bodies.add_group(&g.name, members, &path.key("name"))?;
    }
    if bodies.list.is_empty() {
        return Err(err(
            SceneErrorKind::Value,
            root,
            "the scene has no bodies (declare [[bodies]], [[chains]], [[shells]] or [[grids]], or a [builtin] model)",
        ));
    }
    Ok((bodies, generated))
}

fn constraint_terms(
    file: &SceneFile,
    bodies: &Bodies,
    generated: Vec<Declared>,
) -> Result<Vec<Declared>> {
    let dim = bodies.dim;
    let mut out = generated;
    let root = FieldPath::root().key("constraints");
    for (i, c) in file.constraints.iter().enumerate() {
        let path = root.index(i);
        match c {
            ConstraintSpec::Pin { bodies: sel, point } => {
                let list = bodies.select_all(sel, &path.key("bodies"))?;
                if point.is_some() && list.len() != 1 {
                    return Err(err(
                        SceneErrorKind::Value,
                        path.key("point"),
                        "a pin with a `point` names exactly one body",
                    ));
                }
                for b in list {
                    let point = vector_or(point, dim, &path.key("point"), bodies.list[b].q)?;
                    out.push((
                        ConstraintKind::Pin { body: b, point },
                        format!("constraints[{i}] pin '{}'", bodies.list[b].name),
                        path.clone(),
                    ));
                }
            }
            ConstraintSpec::Rod {
                bodies: sel,
                point,
                length,
            } => {
                let bp = path.key("bodies");
                let ends: Vec<usize> = sel
                    .iter()
                    .enumerate()
                    .map(|(j, s)| {
                        let v = bodies.select(s, &bp.index(j))?;
                        if v.len() == 1 {
                            Ok(v[0])
                        } else {
                            Err(err(
                                SceneErrorKind::Reference,
                                bp.index(j),
                                format!("'{s}' names {} bodies; a rod end is one body", v.len()),
                            ))
                        }
                    })
                    .collect::<Result<_>>()?;
                let (a, b, p) = match (ends.as_slice(), point) {
                    (&[a, b], None) if a != b => (a, Some(b), [0.0; 3]),
                    (&[a], Some(p)) => (a, None, vector(p, dim, &path.key("point"))?),
                    _ => {
                        // Point at the `point` when it is the extra piece.
                        let at = if point.is_some() && ends.len() != 1 {
                            path.key("point")
                        } else {
                            bp
                        };
                        return Err(err(
                            SceneErrorKind::Value,
                            at,
                            "a rod joins two different bodies, or one body and a fixed `point`",
                        ));
                    }
                };
                let other = b.map_or(p, |b| bodies.list[b].q);
                let initial = norm(sub(bodies.list[a].q, other));
                let length = match length {
                    Some(l) => positive(*l, &path.key("length"), "length")?,
                    None => positive(
                        initial,
                        &path.key("bodies"),
                        "initial distance of the rod's ends",
                    )?,
                };
                let names = match b {
                    Some(b) => format!("'{}'–'{}'", bodies.list[a].name, bodies.list[b].name),
                    None => format!("'{}'–point", bodies.list[a].name),
                };
                out.push((
                    ConstraintKind::Rod {
                        a,
                        b,
                        point: p,
                        length,
                    },
                    format!("constraints[{i}] rod {names}"),
                    path.clone(),
                ));
            }
            ConstraintSpec::Sphere {
                bodies: sel,
                center,
                radius,
            } => {
                let center = vector_or(center, dim, &path.key("center"), [0.0; 3])?;
                let radius = radius
                    .map(|r| positive(r, &path.key("radius"), "radius"))
                    .transpose()?;
                for b in bodies.select_all(sel, &path.key("bodies"))? {
                    let r = match radius {
                        Some(r) => r,
                        None => positive(
                            norm(sub(bodies.list[b].q, center)),
                            &path.key("bodies"),
                            "initial distance from the centre",
                        )?,
                    };
                    out.push((
                        ConstraintKind::Sphere {
                            body: b,
                            center,
                            radius: r,
                        },
                        format!("constraints[{i}] sphere '{}'", bodies.list[b].name),
                        path.clone(),
                    ));
                }
            }
            ConstraintSpec::Plane {
                bodies: sel,
                normal,
                offset,
            } => {
                let n = vector(normal, dim, &path.key("normal"))?;
                let len = norm(n);
                if len == 0.0 {
                    return Err(err(
                        SceneErrorKind::Value,
                        path.key("normal"),
                        "the normal must not be zero",
                    ));
                }
                let n = n.map(|x| x / len);
                let list = bodies.select_all(sel, &path.key("bodies"))?;
                let offset = offset.map(|o| finite(o, &path.key("offset"))).transpose()?;
                for &b in &list {
                    let off = match offset {
                        Some(o) => o,
                        None => {
                            n[0] * bodies.list[list[0]].q[0]
                                + n[1] * bodies.list[list[0]].q[1]
                                + n[2] * bodies.list[list[0]].q[2]
                        }
                    };
                    out.push((
                        ConstraintKind::Plane {
                            body: b,
                            normal: n,
                            offset: off,
                        },
                        format!("constraints[{i}] plane '{}'", bodies.list[b].name),
                        path.clone(),
                    ));
                }
            }
        }
    }
    Ok(out)
}

/// Effects split by where they go: potential terms, and the merged `M` terms.
struct Effects {
    potentials: Vec<PotentialTerm>,
    damping: Option<StructureTerm<f64>>,
    magnetic: Option<StructureTerm<[f64; 3]>>,
    disabled: Vec<String>,
}

fn assemble_effects(file: &SceneFile, bodies: &Bodies) -> Result<Effects> {
    let dim = bodies.dim;
    let flags = &file.flags;
    let n = bodies.list.len();
    let mut fx = Effects {
        potentials: Vec::new(),
        damping: None,
        magnetic: None,
        disabled: Vec::new(),
    };
    let (mut damping, mut damping_labels) = (vec![0.0; n], Vec::new());
    let (mut magnetic, mut magnetic_labels) = (vec![[0.0; 3]; n], Vec::new());
    let root = FieldPath::root().key("effects");
    for (i, e) in file.effects.iter().enumerate() {
        let path = root.index(i);
        let (kind, name, on) = match e {
            EffectSpec::Gravity { name, .. } => (EffectKind::Gravity, name, flags.gravity),
            EffectSpec::Spring { name, .. } => (EffectKind::Spring, name, flags.springs),
            EffectSpec::Pair { name, .. } => (EffectKind::Pair, name, flags.pair),
            EffectSpec::Trap { name, .. } => (EffectKind::Trap, name, flags.trap),
            EffectSpec::Damping { name, .. } => (EffectKind::Damping, name, flags.damping),
            EffectSpec::Magnetic { name, .. } => (EffectKind::Magnetic, name, flags.magnetic),
        };
        let label = name.clone().unwrap_or_else(|| kind.name().to_owned());
        // Validate even what is switched off: a flag must not hide an error in the file.
        let potential = match e {
            EffectSpec::Gravity { g, bodies: sel, .. } => {
                let g = vector(g, dim, &path.key("g"))?;
                let forces = bodies
                    .select_opt(sel, &path.key("bodies"))?
                    .into_iter()
                    .map(|b| {
                        let m = bodies.list[b].mass;
                        (b, g.map(|x| m * x))
                    })
                    .collect();
                Some(Potential::Gravity { forces })
            }
            EffectSpec::Spring {
                bodies: sel,
                stiffness,
                rest_length,
                ..
            } => {
                let bp = path.key("bodies");
                let ends = bodies.select_all(sel, &bp)?;
                if sel.len() != 2 || ends.len() != 2 {
                    return Err(err(
                        SceneErrorKind::Value,
                        bp,
                        "a spring joins exactly two different bodies",
                    ));
                }
                let k = non_negative(*stiffness, &path.key("stiffness"), "stiffness")?;
                let rest = match rest_length {
                    Some(l) => non_negative(*l, &path.key("rest_length"), "rest length")?,
                    None => norm(sub(bodies.list[ends[0]].q, bodies.list[ends[1]].q)),
                };
                Some(Potential::Pairs {
                    pairs: vec![(ends[0], ends[1])],
                    law: PairLaw::Spring { stiffness: k, rest },
                })
            }
            EffectSpec::Pair {
                bodies: sel,
                law,
                strength,
                power,
                epsilon,
                sigma,
                ..
            } => {
                let group = bodies.select_opt(sel, &path.key("bodies"))?;
                let need = |v: &Option<f64>, key: &str| -> Result<f64> {
                    v.ok_or_else(|| {
                        err(
                            SceneErrorKind::Value,
                            path.key("law"),
                            format!("the law '{law}' needs `{key}`"),
                        )
                    })
                };
                // Parameters of another law are an error, not silently dropped.
                let used: &[&str] = match law.as_str() {
                    "inverse-power" => &["strength", "power"],
                    "log" => &["strength"],
                    "lennard-jones" => &["epsilon", "sigma"],
                    _ => &["strength", "power", "epsilon", "sigma"],
                };
                for (key, value) in [
                    ("strength", strength),
                    ("power", power),
                    ("epsilon", epsilon),
                    ("sigma", sigma),
                ] {
                    if value.is_some() && !used.contains(&key) {
                        return Err(err(
                            SceneErrorKind::Value,
                            path.key(key),
                            format!(
                                "the law '{law}' takes no `{key}` (it takes {})",
                                used.join(", ")
                            ),
                        ));
                    }
                }
                let law = match law.as_str() {
                    "inverse-power" => PairLaw::InversePower {
                        strength: finite(need(strength, "strength")?, &path.key("strength"))?,
                        power: positive(power.unwrap_or(1.0), &path.key("power"), "power")?,
                    },
                    "log" => PairLaw::Log {
                        strength: finite(need(strength, "strength")?, &path.key("strength"))?,
                    },
                    "lennard-jones" => PairLaw::LennardJones {
                        epsilon: positive(
                            need(epsilon, "epsilon")?,
                            &path.key("epsilon"),
                            "epsilon",
                        )?,
                        sigma: positive(need(sigma, "sigma")?, &path.key("sigma"), "sigma")?,
                    },
                    other => {
                        return Err(err(
                            SceneErrorKind::Value,
                            path.key("law"),
                            format!("unknown law '{other}' (inverse-power, log, lennard-jones)"),
                        ));
                    }
                };
                let count = group.len() * group.len().saturating_sub(1) / 2;
                if count > MAX_PAIRS {
                    return Err(err(
                        SceneErrorKind::Unsupported,
                        path.key("bodies"),
                        format!(
                            "{} bodies make {count} pairs; a pair potential visits every pair each evaluation (no cut-off), limit {MAX_PAIRS}: use a smaller group",
                            group.len()
                        ),
                    ));
                }
                let mut pairs = Vec::with_capacity(count);
                for (x, &a) in group.iter().enumerate() {
                    for &b in &group[x + 1..] {
                        pairs.push((a, b));
                    }
                }
                Some(Potential::Pairs { pairs, law })
            }
            EffectSpec::Trap {
                stiffness,
                center,
                bodies: sel,
                ..
            } => Some(Potential::Trap {
                stiffness: non_negative(*stiffness, &path.key("stiffness"), "stiffness")?,
                center: vector_or(center, dim, &path.key("center"), [0.0; 3])?,
                bodies: bodies.select_opt(sel, &path.key("bodies"))?,
            }),
            EffectSpec::Damping {
                coefficient,
                bodies: sel,
                ..
            } => {
                let c = non_negative(
                    *coefficient,
                    &path.key("coefficient"),
                    "damping coefficient",
                )?;
                let list = bodies.select_opt(sel, &path.key("bodies"))?;
                if on {
                    for b in list {
                        damping[b] += c;
                    }
                    damping_labels.push(label.clone());
                }
                None
            }
            EffectSpec::Magnetic {
                field, bodies: sel, ..
            } => {
                let fp = path.key("field");
                let b = match (dim, field.len()) {
                    (2, 1) => [0.0, 0.0, finite(field[0], &fp.index(0))?],
                    (3, 3) => vector(field, 3, &fp)?,
                    (d, len) => {
                        return Err(err(
                            SceneErrorKind::Dimension,
                            fp,
                            format!(
                                "{len} entries: the field has 1 entry (B_z) in 2D and 3 in 3D (dim = {d})"
                            ),
                        ));
                    }
                };
                let list = bodies.select_opt(sel, &path.key("bodies"))?;
                if on {
                    for i in list {
                        let e = bodies.list[i].charge;
                        for k in 0..3 {
                            magnetic[i][k] += e * b[k];
                        }
                    }
                    magnetic_labels.push(label.clone());
                }
                None
            }
        };
        if !on {
            fx.disabled
                .push(format!("effects[{i}] {} ({})", label, kind.name()));
            continue;
        }
        if let Some(potential) = potential {
            fx.potentials.push(PotentialTerm {
                label,
                kind,
                potential,
                counter: Counter::default(),
            });
        }
    }
    // A damping or field that acts on nothing (zero coefficients, no charge, no bodies) has no
    // term: the model stays conservative (or canonical) and says so.
    if !damping_labels.is_empty() && !damping.iter().any(|&c| c > 0.0) {
        fx.disabled.push(format!(
            "{} (damping: zero on every body, no term)",
            damping_labels.join("+")
        ));
        damping_labels.clear();
    }
    if !magnetic_labels.is_empty() && !magnetic.iter().any(|b| *b != [0.0; 3]) {
        fx.disabled.push(format!(
            "{} (magnetic: no charged body, no term)",
            magnetic_labels.join("+")
        ));
        magnetic_labels.clear();
    }
    if !damping_labels.is_empty() {
        fx.damping = Some(StructureTerm {
            label: damping_labels.join("+"),
            per_body: damping,
            counter: Counter::default(),
        });
    }
    if !magnetic_labels.is_empty() {
        fx.magnetic = Some(StructureTerm {
            label: magnetic_labels.join("+"),
            per_body: magnetic,
            counter: Counter::default(),
        });
    }
    Ok(fx)
}

/// The scheme a scene asks for: the composition table (`None`: Strang) and its order.
fn choose_scheme(
    integ: &IntegratorSpec,
    dissipative: bool,
) -> Result<(Option<&'static CompositionTable>, u32)> {
    let path = FieldPath::root().key("integrator");
    let (table, order) = match integ.scheme.as_str() {
        "auto" => {
            let order = integ.order.unwrap_or(2);
            let table = match order {
                2 => None,
                4 => table_by_name("suzuki4"),
                6 => table_by_name("kahan-li6"),
                8 => table_by_name("kahan-li8"),
                o => {
                    return Err(err(
                        SceneErrorKind::Value,
                        path.key("order"),
                        format!("order {o}: the compositions have orders 2, 4, 6 and 8"),
                    ));
                }
            };
            (table, order)
        }
        "strang" | "discrete-gradient" | "midpoint" | "modified" => (None, 2),
        name => match table_by_name(name) {
            Some(t) => (Some(t), t.order),
            None => {
                return Err(err(
                    SceneErrorKind::Value,
                    path.key("scheme"),
                    format!(
                        "unknown scheme '{name}' (auto, strang, discrete-gradient, midpoint, modified, triple-jump, suzuki4, yoshida6, kahan-li6, suzuki-umeno8, kahan-li8)"
                    ),
                ));
            }
        },
    };
    if let Some(o) = integ.order
        && o != order
    {
        return Err(err(
            SceneErrorKind::Value,
            path.key("order"),
            format!("order {o}, but scheme '{}' has order {order}", integ.scheme),
        ));
    }
    if dissipative && order > 2 {
        let field = if integ.order.is_some() {
            "order"
        } else {
            "scheme"
        };
        return Err(err(
            SceneErrorKind::Unsupported,
            path.key(field),
            format!(
                "an order-{order} composition takes negative sub-steps, which run the damping backwards (energy grows, unstable when stiff); with damping use order = 2 (Strang with the exact damping flow), or switch the damping off with [flags] damping = false"
            ),
        ));
    }
    Ok((table, order))
}

fn plan(integ: &IntegratorSpec, flags: &Flags) -> Result<(usize, bool, bool, bool)> {
    let path = FieldPath::root().key("integrator");
    let dt = positive(integ.dt, &path.key("dt"), "step size")?;
    let t_end = positive(integ.t_end, &path.key("t_end"), "final time")?;
    let steps = (t_end / dt).round();
    if steps > MAX_STEPS as f64 {
        return Err(err(
            SceneErrorKind::Value,
            path.key("dt"),
            format!("t_end / dt = {steps:.3e} steps, more than {MAX_STEPS:.0e}"),
        ));
    }
    if steps < 1.0 {
        return Err(err(
            SceneErrorKind::Value,
            path.key("t_end"),
            format!("t_end = {t_end} is less than half a step (dt = {dt})"),
        ));
    }
    let (mut energy, mut residuals, mut profile) = (false, false, false);
    for (i, d) in integ.diagnostics.iter().enumerate() {
        match d.as_str() {
            "energy" => energy = true,
            "constraints" => residuals = true,
            "profile" => profile = true,
            other => {
                return Err(err(
                    SceneErrorKind::Value,
                    path.key("diagnostics").index(i),
                    format!("unknown diagnostic '{other}' (energy, constraints, profile)"),
                ));
            }
        }
    }
    Ok((
        steps as usize,
        energy && flags.energy,
        residuals && flags.residuals,
        profile,
    ))
}

/// Compiles a parsed scene (no source text: errors carry paths but no line numbers).
pub fn compile(file: &SceneFile) -> Result<Compiled> {
    compile_impl(file, false)
}

/// As [`compile`], but a composition of order above 2 may run damping backwards: for reference
/// runs of mildly damped scenes only, where an order-8 composition's accuracy matters more than
/// the damping's sign in its backward sub-steps.
pub fn compile_reference(file: &SceneFile) -> Result<Compiled> {
    compile_impl(file, true)
}

fn compile_impl(file: &SceneFile, backward: bool) -> Result<Compiled> {
    let root = FieldPath::root();
    if file.version != SCENE_VERSION {
        return Err(err(
            SceneErrorKind::Version,
            root.key("version"),
            format!(
                "version {} is not supported; this library reads version {SCENE_VERSION}",
                file.version
            ),
        ));
    }
    if let Some(b) = &file.builtin {
        if !file.bodies.is_empty()
            || !file.chains.is_empty()
            || !file.shells.is_empty()
            || !file.grids.is_empty()
            || !file.constraints.is_empty()
            || !file.effects.is_empty()
        {
            return Err(err(
                SceneErrorKind::Value,
                root.key("builtin"),
                "a built-in model takes no bodies, constraints or effects of its own",
            ));
        }
        return compile_builtin(file, b);
    }
    let dim = match file.dim {
        Some(d @ (2 | 3)) => d,
        Some(d) => {
            return Err(err(
                SceneErrorKind::Dimension,
                root.key("dim"),
                format!("dim = {d}: scenes are 2- or 3-dimensional"),
            ));
        }
        None => {
            return Err(err(
                SceneErrorKind::Syntax,
                root.key("dim"),
                "missing `dim` (2 or 3)",
            ));
        }
    };
    let (steps, energy, residuals, profile) = plan(&file.integrator, &file.flags)?;
    let (bodies, generated) = expand_bodies(file, dim)?;
    let mut disabled = Vec::new();
    let constraints = constraint_terms(file, &bodies, generated)?;
    let constraints = if file.flags.constraints {
        constraints
    } else {
        if !constraints.is_empty() {
            disabled.push(format!("{} constraints", constraints.len()));
        }
        Vec::new()
    };
    let fx = assemble_effects(file, &bodies)?;
    disabled.extend(fx.disabled);
    let mut row = 0;
    let terms: Vec<ConstraintTerm> = constraints
        .into_iter()
        .map(|(kind, label, path)| {
            let t = ConstraintTerm {
                kind,
                row,
                label,
                path,
            };
            row += t.rows(dim);
            t
        })
        .collect();
    let effects: Vec<(String, String)> =
        std::iter::once(("kinetic".to_owned(), "kinetic".to_owned()))
            .chain(
                fx.potentials
                    .iter()
                    .map(|t| (t.label.clone(), t.kind.name().to_owned())),
            )
            .chain(
                fx.damping
                    .iter()
                    .map(|t| (t.label.clone(), "damping".to_owned())),
            )
            .chain(
                fx.magnetic
                    .iter()
                    .map(|t| (t.label.clone(), "magnetic".to_owned())),
            )
            .collect();
    let masses: Vec<f64> = bodies.list.iter().map(|b| b.mass).collect();
    let mut model = SceneModel::new(
        dim,
        masses,
        fx.potentials,
        terms,
        fx.damping,
        fx.magnetic,
        profile,
    );
    let dropped_constraints = match file.integrator.redundant.as_str() {
        "refuse" => Vec::new(),
        "drop-dependent" => {
            let q0: Vec<f64> = bodies
                .list
                .iter()
                .flat_map(|b| b.q[..dim].to_vec())
                .collect();
            drop_dependent(&mut model, &q0)?
        }
        other => {
            return Err(err(
                SceneErrorKind::Value,
                root.key("integrator").key("redundant"),
                format!("unknown value '{other}': use \"refuse\" (default) or \"drop-dependent\""),
            ));
        }
    };
    let model = Arc::new(model);
    let n = model.state_len();
    let nq = n / 2;
    let mut x0 = Col::<f64>::zeros(n);
    for (b, body) in bodies.list.iter().enumerate() {
        for k in 0..dim {
            x0[b * dim + k] = body.q[k];
            x0[nq + b * dim + k] = body.mass * body.v[k];
        }
    }
    let (table, order) = choose_scheme(&file.integrator, model.is_dissipative() && !backward)?;
    let m = model.m;
    let mut initial_projection = None;
    if m > 0 {
        let off = off_constraints(&model, &x0);
        if let Some((value, row, level)) = off {
            if file.integrator.project_initial {
                initial_projection = Some(project_initial(&model, &mut x0).map_err(|e| {
                    err(
                        SceneErrorKind::OffConstraints,
                        root.key("integrator").key("project_initial"),
                        e,
                    )
                })?);
            } else {
                let (path, label) = constraint_term(&model, row)
                    .map_or((root.clone(), String::new()), |c| {
                        (c.path.clone(), c.label.clone())
                    });
                return Err(err(
                    SceneErrorKind::OffConstraints,
                    path,
                    format!(
                        "the initial state is off the constraints: {level} residual {value:.3e} at {label}; fix the positions/velocities, or set `integrator.project_initial = true` to project them (mass-weighted, reported)"
                    ),
                ));
            }
        }
        check_independent(&model, &x0.as_slice()[..nq])?;
    }
    let dt = file.integrator.dt;
    let dissipative = model.is_dissipative();
    let shared = model.clone();
    let mut case = None;
    let mut projection = None;
    let mut solver = None;
    let scheme_name;
    let discrete_gradient = file.integrator.scheme == "discrete-gradient";
    let flow: Box<dyn Flow<Col<f64>>> = if discrete_gradient {
        let setup = |e: SetupError| setup_error(&model, e);
        let newton = NewtonOptions::default();
        if m == 0 {
            scheme_name = "discrete gradient (Gonzalez)";
            Box::new(
                DiscreteGradient::<Col<f64>, Arc<SceneModel>, Arc<SceneModel>>::try_new(
                    model.clone(),
                    model.clone(),
                    &x0,
                    newton,
                )
                .map_err(setup)?,
            )
        } else {
            scheme_name =
                "constrained discrete gradient (Gonzalez) with hidden-constraint projection";
            let system = System::new(model.clone(), model.clone(), model.clone());
            let options = projection_options(&model, x0.as_slice(), f64::EPSILON);
            case = Some("degenerate".to_owned());
            Box::new(
                ConstrainedDiscreteGradient::<Col<f64>, _, _, _>::try_new(system, &x0, options)
                    .map_err(setup)?,
            )
        }
    } else if file.integrator.scheme == "midpoint" {
        // The implicit midpoint rule for all of H under M (dense Newton on n unknowns), projected
        // when there are constraints: the §3 scheme with a general inner flow.
        let setup = |e: SetupError| setup_error(&model, e);
        let midpoint = || {
            ImplicitMidpoint::<Col<f64>, Arc<SceneModel>, Arc<SceneModel>>::try_new(
                model.clone(),
                model.clone(),
                &x0,
                NewtonOptions::default(),
            )
            .map_err(setup)
        };
        if m == 0 {
            scheme_name = "implicit midpoint rule";
            with_table_backward(midpoint()?, table, backward)
        } else {
            scheme_name = "projection around the implicit midpoint rule";
            let system = || System::new(model.clone(), model.clone(), model.clone());
            let options = projection_options(&model, x0.as_slice(), f64::EPSILON);
            case = Some("degenerate".to_owned());
            // The same map with the midpoint increment and λ_k as one Newton system where that
            // path applies (the decoupled case; above 4 constraints its general path factors
            // a dense (n + m)-square matrix at every step, so only up to DENSE_MAX_DIM
            // unknowns); nested solves otherwise.
            let joint = if m <= SMALL_MAX || x0.nrows() + m <= DENSE_MAX_DIM {
                match ProjectedMidpoint::<Col<f64>, _, _, _, _>::try_new(
                    system(),
                    model.clone(),
                    &x0,
                    options,
                ) {
                    Ok(joint) => Some(joint),
                    Err(SetupError::Dimension { .. }) => None,
                    Err(e) => return Err(setup(e)),
                }
            } else {
                None
            };
            match joint {
                Some(joint) => with_table_backward(joint, table, backward),
                None => with_table_backward(
                    midpoint()?
                        .projected(system(), &x0, options)
                        .map_err(setup)?,
                    table,
                    backward,
                ),
            }
        }
    } else if file.integrator.scheme == "modified" {
        return Err(err(
            SceneErrorKind::Unsupported,
            root.key("integrator").key("scheme"),
            "the §2 scheme (`modified`) is offered for the built-in paper model only",
        ));
    } else {
        let (flow, name, desc) = splitting_flow(&model, &x0, table, backward, f64::EPSILON)
            .map_err(|e| setup_error(&model, e))?;
        scheme_name = name;
        if let Some((scheme, small, kind)) = desc {
            case = Some(
                match scheme {
                    Scheme::Symmetric => "non-degenerate",
                    _ => "degenerate",
                }
                .to_owned(),
            );
            projection = Some(
                match scheme {
                    Scheme::Decoupled => "decoupled",
                    Scheme::Coupled => "coupled",
                    Scheme::Symmetric => "symmetric",
                }
                .to_owned(),
            );
            solver = Some(if small {
                "small (stack, closed-form Jacobians)".to_owned()
            } else {
                kind
            });
        }
        flow
    };
    let scheme = match table {
        None => scheme_name.to_owned(),
        Some(t) => format!(
            "{} composed by {} ({} stages)",
            scheme_name, t.name, t.stages
        ),
    };
    let mut constraint_counts: Vec<(String, usize)> = Vec::new();
    for t in &model.constraints {
        let kind = match t.kind {
            ConstraintKind::Pin { .. } => "pin",
            ConstraintKind::Rod { .. } => "rod",
            ConstraintKind::Sphere { .. } => "sphere",
            ConstraintKind::Plane { .. } => "plane",
        };
        match constraint_counts.iter_mut().find(|(k, _)| k == kind) {
            Some(e) => e.1 += t.rows(dim),
            None => constraint_counts.push((kind.to_owned(), t.rows(dim))),
        }
    }
    let assembly = Assembly {
        name: file.name.clone().unwrap_or_else(|| "scene".to_owned()),
        dim: Some(dim),
        bodies: model.bodies(),
        state_len: n,
        constraints: constraint_counts,
        constraint_rows: m,
        effects,
        disabled,
        canonical: model.is_canonical(),
        dissipative,
        case,
        projection,
        scheme,
        order,
        solver,
        steps,
        initial_projection,
        dropped_constraints,
    };
    let system = System::new(model.clone(), model.clone(), model.clone());
    let simulation = Box::new(ModelRun::new(flow, system, x0, dt, m, Some(shared)));
    Ok(Compiled {
        simulation,
        assembly,
        plan: RunPlan {
            steps,
            energy,
            residuals,
        },
        model: Some(model),
    })
}

/// The label of the constraint term that owns row `row`.
fn constraint_term(model: &SceneModel, row: usize) -> Option<&ConstraintTerm> {
    model.constraints.iter().rev().find(|c| c.row <= row)
}

/// Removes dependent constraints one at a time (`redundant = "drop-dependent"`): factor
/// `G W⁻¹ Gᵀ` at the initial positions; a pivot that vanishes names a row that depends on the
/// rows before it in the factorization's order, and its constraint goes. Returns the labels of
/// the dropped constraints. A dependent row inside a multi-row constraint (a pin) is refused:
/// dropping the whole pin would remove independent rows too.
fn drop_dependent(model: &mut SceneModel, q: &[f64]) -> Result<Vec<String>> {
    let mut dropped = Vec::new();
    while model.m > 0 {
        let result = MassGram::new(model, q).and_then(|mut g| g.factor(model, q));
        let row = match result {
            Ok(()) => break,
            Err(LinearSolveError::Singular { pivot, .. }) => pivot,
            Err(LinearSolveError::StructurallySingular { column }) => column,
            Err(e) => return Err(setup_error(model, SetupError::Linear(e))),
        };
        let Some(index) = model.constraints.iter().rposition(|c| c.row <= row) else {
            break;
        };
        let term = &model.constraints[index];
        if term.rows(model.dim) != 1 {
            return Err(err(
                SceneErrorKind::Redundant,
                term.path.clone(),
                format!(
                    "{} is redundant in one of its {} rows; only single-row constraints are dropped (declare it as rods)",
                    term.label,
                    term.rows(model.dim)
                ),
            ));
        }
        // A dependent constraint that contradicts the others (a second rod of another length)
        // is not redundant but inconsistent: dropping it would run with it violated.
        let value = model.term_residual(q, index).unwrap_or(0.0);
        let scale = row_scales(model, q)[term.row].0;
        if value.abs() > f64::EPSILON.sqrt() * scale {
            return Err(err(
                SceneErrorKind::OffConstraints,
                term.path.clone(),
                format!(
                    "{} depends on the others but is not satisfied at the initial state (residual {value:.3e}): it contradicts them, and is not dropped",
                    term.label
                ),
            ));
        }
        dropped.push(term.label.clone());
        model.retain_constraints(|i| i != index);
    }
    Ok(dropped)
}

/// Refuses redundant constraints (a rod listed twice, an over-constraining loop): the
/// constraint gradients must be independent at the initial positions, i.e. the mass-weighted
/// Gram matrix `G W⁻¹ Gᵀ` non-singular. The projection's own analysis is skipped for scenes (the
/// case is known), and without this check a duplicated constraint would only fail at the first
/// step, with a singular Newton matrix that names no constraint.
fn check_independent(model: &SceneModel, q: &[f64]) -> Result<()> {
    let singular = |e: LinearSolveError| match e {
        LinearSolveError::Singular { pivot, ratio, .. } => SetupError::RankDeficient {
            constraint: pivot,
            ratio,
        },
        LinearSolveError::StructurallySingular { column } => SetupError::RankDeficient {
            constraint: column,
            ratio: 0.0,
        },
        other => SetupError::Linear(other),
    };
    let mut gram = MassGram::new(model, q).map_err(|e| setup_error(model, singular(e)))?;
    gram.factor(model, q)
        .map_err(|e| setup_error(model, singular(e)))
}

/// Turns a projection's setup error into a scene error that names the constraint and points at
/// where it is declared.
fn setup_error(model: &SceneModel, e: SetupError) -> SceneError {
    let at = |row: usize| {
        constraint_term(model, row).map_or_else(
            || (FieldPath::root(), format!("row {row}")),
            |c| (c.path.clone(), c.label.clone()),
        )
    };
    match e {
        SetupError::RankDeficient { constraint, ratio } => {
            let (path, label) = at(constraint);
            err(
                SceneErrorKind::Redundant,
                path,
                format!(
                    "the constraints are redundant: {label} depends on the others (pivot ratio {ratio:.1e}); remove it or one of those it repeats"
                ),
            )
        }
        SetupError::SingularMultiplierMatrix { .. } => err(
            SceneErrorKind::Redundant,
            FieldPath::root(),
            format!("the constraints are redundant or singular at the initial state: {e}"),
        ),
        other => err(SceneErrorKind::Setup, FieldPath::root(), other.to_string()),
    }
}

/// Projection options for a scene: position constraints with forces on the momenta only
/// (`M Gᵀλ = (0, −G_qᵀλ)` whatever the damping and field), so the degenerate case and the
/// decoupled variant hold by construction; naming them skips the dense bracket analysis. The
/// residual tolerance is scaled like the chain's (`16 ε ℓ L`: `ℓ` the smallest constraint
/// length, `L` the scene's extent), the rounding level of `g = (|u|² − ℓ²)/2`.
fn projection_options<T: Real>(model: &SceneModel<T>, x0: &[T], eps: T) -> ProjectionOptions<T> {
    let nq = model.state_len() / 2;
    let extent = x0[..nq].iter().fold(T::zero(), |a, &b| a.max(b.abs()));
    let mut ell = T::infinity();
    for c in &model.constraints {
        let l = match c.kind {
            ConstraintKind::Rod { length, .. } => length,
            ConstraintKind::Sphere { radius, .. } => radius,
            _ => continue,
        };
        ell = ell.min(l);
    }
    if !ell.is_finite() {
        ell = extent.max(T::one());
    }
    // The scene's own scale, not clamped to 1: a micrometre chain rounds at ε ℓ L with L ~ 1e-5.
    let big = extent.max(ell);
    let big = if big > T::zero() { big } else { T::one() };
    let ftol = T::lit(16.0) * eps * ell * big;
    // `eps` is the scalar's unit round-off: f64's, or ~1e-32 for double-double (whose
    // `epsilon()` is not its round-off), and the defaults' tolerances are rebuilt from it.
    let newton = NewtonOptions::default()
        .with_ftol(ftol)
        .with_xtol(T::lit(16.0) * eps)
        .with_fd_step(eps.sqrt());
    let options = ProjectionOptions::default()
        .with_case(Case::Degenerate)
        .with_coupling(Coupling::Decoupled)
        .with_newton(newton);
    if eps > T::epsilon() {
        // An extended-precision run starts from the f64 state, on the constraints to f64
        // round-off only: the first step projects it (the scene has checked it already).
        options.with_manifold_tol(None)
    } else {
        options
    }
}

/// The splitting of a scene's terms (see the module docs of `scene`): the free flight alone, or
/// `free flight(h/2) ∘ kick(h) ∘ free flight(h/2)` without constraints; with constraints the
/// projection around `kick(h/2) ∘ free flight(h) ∘ kick(h/2)`; composed by `table`. For any
/// storage and scalar (`eps` its unit round-off): `Col<f64>` for runs, `DVector` of a
/// double-double scalar for references. Returns the flow, its description and, when projected,
/// the projection variant, whether it takes the small path, and its linear solver. `backward`
/// lets a composition run a dissipative sub-flow backwards (reference runs only).
///
/// # Errors
/// The projection's setup errors at `x0` ([`SetupError`]).
#[allow(clippy::type_complexity)]
pub fn splitting_flow<V: Vector + 'static>(
    model: &Arc<SceneModel<V::Real>>,
    x0: &V,
    table: Option<&'static CompositionTable>,
    backward: bool,
    eps: V::Real,
) -> std::result::Result<
    (
        Box<dyn Flow<V>>,
        &'static str,
        Option<(Scheme, bool, String)>,
    ),
    SetupError,
> {
    let nq = model.state_len() / 2;
    let mut scratch = vec![V::Real::zero(); nq];
    let kick = {
        let model = model.clone();
        from_fn(move |t: V::Real, x: &mut V| model.kick(t, x.as_mut_slice(), &mut scratch))
    };
    let dissipative = model.is_dissipative();
    let drift = {
        let model = model.clone();
        from_fn(move |t: V::Real, x: &mut V| model.free_flight(t, x.as_mut_slice()))
            .dissipative_if(dissipative)
    };
    let has_potential = !model.potentials.is_empty();
    if model.m == 0 {
        return Ok(if has_potential {
            (
                with_table_backward(drift.strang(kick), table, backward),
                "free flight ∘ kick ∘ free flight (Strang)",
                None,
            )
        } else {
            (Box::new(drift), "free flight (exact)", None)
        });
    }
    let system = System::new(model.clone(), model.clone(), model.clone());
    let options = projection_options(model, x0.as_slice(), eps);
    if has_potential {
        let p = kick.strang(drift).projected(system, x0, options)?;
        Ok(boxed_projection(
            p,
            table,
            backward,
            "projection around kick ∘ free flight ∘ kick (Strang, RATTLE)",
        ))
    } else {
        let p = drift.projected(system, x0, options)?;
        Ok(boxed_projection(
            p,
            table,
            backward,
            "projection around free flight (exact)",
        ))
    }
}

/// A scene's projected flow, composed and boxed, with its description and what it assembled.
#[allow(clippy::type_complexity)]
fn boxed_projection<V, F>(
    p: Projected<
        V,
        F,
        Arc<SceneModel<V::Real>>,
        Arc<SceneModel<V::Real>>,
        Arc<SceneModel<V::Real>>,
    >,
    table: Option<&'static CompositionTable>,
    backward: bool,
    name: &'static str,
) -> (
    Box<dyn Flow<V>>,
    &'static str,
    Option<(Scheme, bool, String)>,
)
where
    V: Vector + 'static,
    F: Flow<V> + 'static,
{
    let desc = (
        p.scheme(),
        p.uses_small_path(),
        format!("{:?}", p.newton().linear_solver().kind()),
    );
    (with_table_backward(p, table, backward), name, Some(desc))
}

/// Per constraint row: the size `ρ` of the terms its residual rounds (a rod `(|u|² − L²)/2`
/// rounds at `ε L (L + |q_a| + |q_b|)`, a plane at `ε (|q| + |offset|)`, …) and its length `ℓ`
/// (the factor between a velocity and its hidden-constraint residual).
fn row_scales(model: &SceneModel, q: &[f64]) -> Vec<(f64, f64)> {
    let d = model.dim;
    let at = |b: usize| (0..d).fold(0.0f64, |a, k| a.max(q[b * d + k].abs()));
    let size = |p: &[f64; 3]| p.iter().fold(0.0f64, |a, x| a.max(x.abs()));
    let mut out = vec![(1.0, 1.0); model.m];
    for c in &model.constraints {
        match &c.kind {
            ConstraintKind::Pin { body, point } => {
                for k in 0..d {
                    out[c.row + k] = (1.0 + at(*body) + size(point), 1.0);
                }
            }
            ConstraintKind::Rod {
                a,
                b,
                point,
                length,
            } => {
                let far = at(*a) + b.map_or_else(|| size(point), at);
                out[c.row] = (length * (length + far), *length);
            }
            ConstraintKind::Sphere {
                body,
                center,
                radius,
            } => out[c.row] = (radius * (radius + at(*body) + size(center)), *radius),
            ConstraintKind::Plane { body, offset, .. } => {
                out[c.row] = (1.0 + at(*body) + offset.abs(), 1.0)
            }
        }
    }
    out
}

/// `Some((value, row, "position"|"velocity"))` for the row that violates `g = 0` or `G v = 0`
/// most beyond `√ε` relative to its own scale ([`row_scales`]).
fn off_constraints(model: &Arc<SceneModel>, x: &Col<f64>) -> Option<(f64, usize, &'static str)> {
    let m = model.m;
    let nq = model.state_len() / 2;
    let scales = row_scales(model, &x.as_slice()[..nq]);
    let tol = f64::EPSILON.sqrt();
    let mut g = vec![0.0; m];
    HolonomicConstraint::<Col<f64>>::residual(model, x, &mut g);
    let worst = |g: &[f64], scale: &dyn Fn(usize) -> f64| {
        g.iter()
            .enumerate()
            .map(|(i, v)| (v.abs() / scale(i), v.abs(), i))
            .fold((0.0f64, 0.0, 0usize), |a, b| if b.0 > a.0 { b } else { a })
    };
    let (ratio, v, r) = worst(&g, &|i| scales[i].0);
    if ratio > tol {
        return Some((v, r, "position"));
    }
    let vel = velocity_state(model, x);
    let vscale = vel.as_slice()[..nq]
        .iter()
        .fold(0.0f64, |a, &b| a.max(b.abs()));
    if vscale == 0.0 {
        return None;
    }
    HolonomicConstraint::<Col<f64>>::jacobian_apply(model, x, &vel, &mut g);
    let (ratio, v, r) = worst(&g, &|i| scales[i].1 * vscale);
    (ratio > tol).then_some((v, r, "velocity"))
}

/// `(v, 0)` as a state-sized vector whose first half holds the velocities `p/m`.
fn velocity_state(model: &SceneModel, x: &Col<f64>) -> Col<f64> {
    let n = model.state_len();
    let (nq, d) = (n / 2, model.dim);
    let mut v = Col::<f64>::zeros(n);
    for (b, w) in model.inv_masses.iter().enumerate() {
        for k in 0..d {
            v[b * d + k] = w * x[nq + b * d + k];
        }
    }
    v
}

/// Projects `x` onto `g = 0`, then its velocities onto `G v = 0`, in the mass metric:
/// `q ← q − W⁻¹Gᵀ (G W⁻¹ Gᵀ)⁻¹ g` (Gauss–Newton, to round-off), `v ← v − W⁻¹Gᵀ (G W⁻¹ Gᵀ)⁻¹ G v`.
/// Returns `(max |Δq|, max |Δp|)`.
fn project_initial(
    model: &Arc<SceneModel>,
    x: &mut Col<f64>,
) -> std::result::Result<(f64, f64), String> {
    let n = model.state_len();
    let (nq, d, m) = (n / 2, model.dim, model.m);
    let x_start = x.clone();
    let w_inv: Vec<f64> = (0..nq).map(|i| model.inv_masses[i / d]).collect();
    let mut g = vec![0.0; m];
    let mut gram = MassGram::new(model, &x.as_slice()[..nq]).map_err(|e| e.to_string())?;
    // δ = W⁻¹ Gᵀ (G W⁻¹ Gᵀ)⁻¹ rhs, on the positions.
    let mut solve = |x: &Col<f64>, rhs: &mut [f64]| -> std::result::Result<Col<f64>, String> {
        gram.factor(model, &x.as_slice()[..nq]).map_err(|e| {
            format!("the constraints are redundant or singular at the initial state ({e})")
        })?;
        gram.solve(rhs).map_err(|e| e.to_string())?;
        let mut delta = Col::<f64>::zeros(n);
        HolonomicConstraint::<Col<f64>>::jacobian_transpose_apply_add(
            model, x, rhs, 1.0, &mut delta,
        );
        for i in 0..nq {
            delta[i] *= w_inv[i];
        }
        Ok(delta)
    };
    let mut converged = false;
    for _ in 0..50 {
        HolonomicConstraint::<Col<f64>>::residual(model, x, &mut g);
        let scales = row_scales(model, &x.as_slice()[..nq]);
        if g.iter()
            .zip(&scales)
            .all(|(v, s)| v.abs() <= 8.0 * f64::EPSILON * s.0)
        {
            converged = true;
            break;
        }
        let delta = solve(x, &mut g)?;
        for i in 0..nq {
            x[i] -= delta[i];
        }
    }
    if !converged {
        return Err("projecting the initial positions onto the constraints did not converge in 50 Gauss–Newton steps".into());
    }
    let vel = velocity_state(model, x);
    HolonomicConstraint::<Col<f64>>::jacobian_apply(model, x, &vel, &mut g);
    let delta = solve(x, &mut g)?;
    for i in 0..nq {
        // Δp = m Δv.
        x[nq + i] -= delta[i] / w_inv[i];
    }
    let dq = (0..nq).fold(0.0f64, |a, i| a.max((x[i] - x_start[i]).abs()));
    let dp = (0..nq).fold(0.0f64, |a, i| a.max((x[nq + i] - x_start[nq + i]).abs()));
    Ok((dq, dp))
}

/// The built-in models, with the scene's integrator.
fn compile_builtin(file: &SceneFile, b: &Builtin) -> Result<Compiled> {
    use crate::models::{
        paper, pendulum_chain::PendulumChain, spherical_pendulum::SphericalPendulum,
    };
    use nalgebra::SVector;
    let path = FieldPath::root().key("builtin");
    let (steps, energy, residuals, profile) = plan(&file.integrator, &file.flags)?;
    // What a built-in model does not use is an error, not silently ignored.
    let unused = |what: &str, at: FieldPath| {
        Err(err(
            SceneErrorKind::Unsupported,
            at,
            format!("{what} does not apply to a built-in model"),
        ))
    };
    let root = FieldPath::root();
    if file.dim.is_some() {
        return unused("`dim` (use `builtin.dim` for the chain)", root.key("dim"));
    }
    if file.integrator.project_initial {
        return unused(
            "`project_initial`",
            root.key("integrator").key("project_initial"),
        );
    }
    if file.integrator.redundant != "refuse" {
        return unused("`redundant`", root.key("integrator").key("redundant"));
    }
    if profile {
        return unused(
            "the `profile` diagnostic",
            root.key("integrator").key("diagnostics"),
        );
    }
    let f = &file.flags;
    if !(f.gravity && f.springs && f.pair && f.trap && f.damping && f.magnetic && f.constraints) {
        return unused("switching effects or constraints off", root.key("flags"));
    }
    if b.model != "pendulum-chain" && (b.links.is_some() || b.dim.is_some()) {
        return unused(
            "`links` and `dim` (only the chain has them)",
            path.key("links"),
        );
    }
    let (table, order) = choose_scheme(&file.integrator, false)?;
    let scheme = file.integrator.scheme.as_str();
    if scheme == "discrete-gradient"
        || (b.model != "paper" && matches!(scheme, "midpoint" | "modified"))
    {
        return Err(err(
            SceneErrorKind::Unsupported,
            FieldPath::root().key("integrator").key("scheme"),
            format!(
                "the built-in model '{}' does not offer the scheme '{scheme}'",
                b.model
            ),
        ));
    }
    let dt = file.integrator.dt;
    let setup = |e: SetupError| err(SceneErrorKind::Setup, path.clone(), e.to_string());
    let compose = |t: Option<&'static CompositionTable>, name: &str| match t {
        None => name.to_owned(),
        Some(t) => format!("{name} composed by {} ({} stages)", t.name, t.stages),
    };
    let (simulation, assembly): (Box<dyn Simulation>, Assembly) = match b.model.as_str() {
        "paper" => {
            type V = SVector<f64, 4>;
            let x0: V = paper::initial_state();
            let (flow, inner): (Box<dyn Flow<V>>, &str) = match file.integrator.scheme.as_str() {
                // The paper's §2 scheme: projection around the flow of H_N1 = H + μ g by the
                // implicit midpoint rule.
                // The midpoint increment and λ_k are solved as one Newton system
                // (ProjectedMidpoint: the same map as Projected around ImplicitMidpoint).
                "modified" => {
                    let p = ProjectedMidpoint::<V, _, _, _, _>::try_new(
                        paper::system(),
                        paper::modified_energy(),
                        &x0,
                        ProjectionOptions::default(),
                    )
                    .map_err(setup)?;
                    (
                        with_table(p, table),
                        "§2: projection around the implicit midpoint rule for H + μ g",
                    )
                }
                "midpoint" => {
                    let p = ProjectedMidpoint::<V, _, _, _, _>::try_new(
                        paper::system(),
                        paper::Energy,
                        &x0,
                        ProjectionOptions::default(),
                    )
                    .map_err(setup)?;
                    (
                        with_table(p, table),
                        "projection around the implicit midpoint rule",
                    )
                }
                _ => {
                    let p = paper::drift()
                        .projected(paper::system(), &x0, ProjectionOptions::default())
                        .map_err(setup)?;
                    (with_table(p, table), "projection around the drift (exact)")
                }
            };
            let assembly = builtin_assembly(
                file,
                "Zhang & Deng (2004) §4",
                4,
                1,
                false,
                compose(table, inner),
                order,
                steps,
            );
            (
                Box::new(ModelRun::new(flow, paper::system(), x0, dt, 1, None)),
                assembly,
            )
        }
        "rigid-body" => {
            use crate::models::RigidBody;
            type V = SVector<f64, 3>;
            if table.is_some() {
                let field = if file.integrator.scheme == "auto" {
                    "order"
                } else {
                    "scheme"
                };
                return Err(err(
                    SceneErrorKind::Unsupported,
                    FieldPath::root().key("integrator").key(field),
                    "the rigid body runs the implicit midpoint rule (order 2) only",
                ));
            }
            let body = RigidBody::<f64>::gni();
            let y0: V = RigidBody::gni_initial_state();
            let flow: Box<dyn Flow<V>> = Box::new(
                ImplicitMidpoint::<V, _, _>::try_new(
                    body.structure(),
                    body,
                    &y0,
                    NewtonOptions::default(),
                )
                .map_err(setup)?,
            );
            let mut assembly = builtin_assembly(
                file,
                "free rigid body (Lie-Poisson, GNI constants)",
                3,
                0,
                false,
                "implicit midpoint rule".to_owned(),
                2,
                steps,
            );
            assembly.constraints.clear();
            assembly.case = None;
            let system = System::new(body.structure(), body, Unconstrained);
            (
                Box::new(ModelRun::new(flow, system, y0, dt, 0, None)),
                assembly,
            )
        }
        "spherical-pendulum" => {
            type V = SVector<f64, 6>;
            let pend = SphericalPendulum::try_new(1.0, 1.0, 9.81).expect("valid constants");
            let x0: V = pend.state(1.0, 1.0);
            let p = pend
                .kick()
                .strang(pend.drift())
                .projected(pend.system(), &x0, ProjectionOptions::default())
                .map_err(setup)?;
            let flow: Box<dyn Flow<V>> = with_table(p, table);
            let assembly = builtin_assembly(
                file,
                "spherical pendulum (RATTLE)",
                6,
                1,
                true,
                compose(table, "projection around kick ∘ drift ∘ kick (RATTLE)"),
                order,
                steps,
            );
            (
                Box::new(ModelRun::new(flow, pend.system(), x0, dt, 1, None)),
                assembly,
            )
        }
        "pendulum-chain" => {
            let links = b.links.unwrap_or(10);
            if links > MAX_BODIES {
                return Err(err(
                    SceneErrorKind::Unsupported,
                    path.key("links"),
                    format!("more than {MAX_BODIES} links"),
                ));
            }
            let dim = b.dim.unwrap_or(2);
            let chain = PendulumChain::<f64>::uniform(dim, links)
                .map_err(|e| err(SceneErrorKind::Value, path.clone(), e.to_string()))?;
            let x0: Col<f64> = chain.at_rest(|_| 0.5);
            let p = chain
                .kick()
                .strang(chain.drift())
                .projected(chain.system(), &x0, chain.projection_options())
                .map_err(setup)?;
            let flow: Box<dyn Flow<Col<f64>>> = with_table(p, table);
            let assembly = builtin_assembly(
                file,
                "pendulum chain",
                chain.state_len(),
                links,
                true,
                compose(table, "projection around kick ∘ drift ∘ kick (RATTLE)"),
                order,
                steps,
            );
            (
                Box::new(ModelRun::new(flow, chain.system(), x0, dt, links, None)),
                assembly,
            )
        }
        other => {
            return Err(err(
                SceneErrorKind::Value,
                path.key("model"),
                format!(
                    "unknown built-in model '{other}' (paper, spherical-pendulum, pendulum-chain, rigid-body)"
                ),
            ));
        }
    };
    Ok(Compiled {
        simulation,
        assembly,
        plan: RunPlan {
            steps,
            energy,
            residuals,
        },
        model: None,
    })
}

#[allow(clippy::too_many_arguments)]
fn builtin_assembly(
    file: &SceneFile,
    what: &str,
    n: usize,
    m: usize,
    canonical: bool,
    scheme: String,
    order: u32,
    steps: usize,
) -> Assembly {
    Assembly {
        name: file.name.clone().unwrap_or_else(|| what.to_owned()),
        dim: None,
        bodies: 0,
        state_len: n,
        constraints: vec![("built-in".to_owned(), m)],
        constraint_rows: m,
        effects: vec![(what.to_owned(), "built-in".to_owned())],
        disabled: Vec::new(),
        canonical,
        dissipative: false,
        case: Some("degenerate".to_owned()),
        projection: None,
        scheme,
        order,
        solver: None,
        steps,
        initial_projection: None,
        dropped_constraints: Vec::new(),
    }
}

/// `flow`, or its composition by `table`, boxed.
fn with_table<V: Vector + 'static, F: Flow<V> + 'static>(
    flow: F,
    table: Option<&'static CompositionTable>,
) -> Box<dyn Flow<V>> {
    with_table_backward(flow, table, false)
}

/// As [`with_table`], the composition allowed to run dissipation backwards when `backward`
/// (reference runs only: [`compile_reference`]).
fn with_table_backward<V: Vector + 'static, F: Flow<V> + 'static>(
    flow: F,
    table: Option<&'static CompositionTable>,
    backward: bool,
) -> Box<dyn Flow<V>> {
    match (table, backward) {
        (None, _) => Box::new(flow),
        (Some(t), false) => Box::new(flow.composed(t)),
        (Some(t), true) => Box::new(flow.composed(t).allow_backward_dissipation()),
    }
}
