//! The scene's bodies: declared one by one or generated (chains, particles on shells, grids),
//! with the constraints their generators declare.

use super::{
    Result, err,
    validate::{finite, norm, positive, sub, vector, vector_or},
};
pub(crate) use crate::scene::bodies::{Bodies, Body};
use crate::scene::constraints::{Constraint, Rod, Sphere};
use crate::scene::error::{FieldPath, SceneErrorKind};
use crate::scene::schema::SceneFile;
use std::collections::HashMap;

pub(crate) use crate::scene::constraints::Declared;

/// Expands bodies and generators; returns the bodies and the generators' own constraints.
pub(crate) fn expand_bodies(file: &SceneFile, dim: usize) -> Result<(Bodies, Vec<Declared>)> {
    let mut bodies = Bodies {
        dim,
        list: Vec::new(),
        groups: HashMap::new(),
        rigid: Vec::new(),
        welded: HashMap::new(),
        positions: std::cell::OnceCell::new(),
    };
    let mut generated = Vec::new();
    let root = FieldPath::root();
    let welds = super::weld::weld_groups(file)?;
    for (i, b) in file.bodies.iter().enumerate() {
        let path = root.key("bodies").index(i);
        if let Some(g) = welds.member_of[i] {
            let group = &welds.groups[g];
            if i == group.frame {
                super::weld::push_welded(&mut bodies, file, group, &mut generated)?;
            }
            continue;
        }
        if let Some(inertia) = &b.inertia {
            let body = super::rigid::rigid_body(b, inertia, dim, &path)?;
            super::rigid::push_rigid(&mut bodies, &b.name, &body, i, &path, &mut generated)?;
            if let Some(entry) = bodies.rigid.last_mut() {
                entry.shape = inertia.drawn_shape();
            }
            continue;
        }
        for (field, set) in [
            ("orientation", b.orientation.is_some()),
            ("angular_velocity", b.angular_velocity.is_some()),
        ] {
            if set {
                return Err(err(
                    SceneErrorKind::Value,
                    path.key(field),
                    format!("`{field}` is for a rigid body: give it an `inertia`"),
                ));
            }
        }
        let mass = b.mass.ok_or_else(|| {
            err(
                SceneErrorKind::Value,
                path.key("mass"),
                "a body needs a `mass`",
            )
        })?;
        let body = Body {
            name: b.name.clone(),
            mass: positive(mass, &path.key("mass"), "mass")?,
            q: vector(&b.position, dim, &path.key("position"))?,
            v: vector_or(&b.velocity, dim, &path.key("velocity"), [0.0; 3])?,
            charge: finite(b.charge, &path.key("charge"))?,
            director: false,
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
        let links = chain_links(c, dim, dir, &path)?;
        let mut members = Vec::with_capacity(c.links);
        let (mut q, mut v) = (anchor, [0.0; 3]);
        for (k, (dir, rate)) in links.into_iter().enumerate() {
            // Each link turns about the previous body: its end moves by L θ̇ (cos θ, sin θ).
            for a in 0..3 {
                q[a] += length * dir[a];
            }
            v[0] -= length * rate * dir[1];
            v[1] += length * rate * dir[0];
            let idx = bodies.push(Body {
                name: format!("{}.{k}", c.name),
                mass,
                q,
                v,
                charge,
                director: false,
            });
            let kind = match members.last() {
                None => Constraint::Rod(Rod {
                    a: idx,
                    b: None,
                    point: anchor,
                    length,
                }),
                Some(&prev) => Constraint::Rod(Rod {
                    a: idx,
                    b: Some(prev),
                    point: [0.0; 3],
                    length,
                }),
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
                director: false,
            });
            generated.push((
                Constraint::Sphere(Sphere {
                    body: idx,
                    center,
                    radius,
                }),
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
                director: false,
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

/// Each link's unit direction and angular velocity (rad/s): `direction` for every link at rest,
/// or from `angles_deg` (from the downward vertical, counter-clockwise: `(sin θ, −cos θ)`) and
/// `angular_velocities_deg` in 2D.
fn chain_links(
    c: &crate::scene::schema::ChainSpec,
    dim: usize,
    dir: [f64; 3],
    path: &FieldPath,
) -> Result<Vec<([f64; 3], f64)>> {
    let per_link = |values: &Vec<f64>, key: &str| -> Result<Vec<f64>> {
        let p = path.key(key);
        if dim != 2 {
            return Err(err(
                SceneErrorKind::Dimension,
                p,
                "link angles are for 2D chains; in 3D give a `direction`",
            ));
        }
        let list = match values.len() {
            1 => vec![values[0]; c.links],
            n if n == c.links => values.clone(),
            n => {
                return Err(err(
                    SceneErrorKind::Value,
                    p,
                    format!(
                        "{n} values for {} links: give one, or one per link",
                        c.links
                    ),
                ));
            }
        };
        for (k, &x) in list.iter().enumerate() {
            finite(x, &p.index(k))?;
        }
        Ok(list.into_iter().map(f64::to_radians).collect())
    };
    match (&c.angles_deg, &c.angular_velocities_deg) {
        (None, None) => Ok(vec![(dir, 0.0); c.links]),
        (None, Some(_)) => Err(err(
            SceneErrorKind::Value,
            path.key("angular_velocities_deg"),
            "angular velocities need `angles_deg`",
        )),
        (Some(angles), rates) => {
            if c.direction.is_some() {
                return Err(err(
                    SceneErrorKind::Value,
                    path.key("angles_deg"),
                    "give `angles_deg` or `direction`, not both",
                ));
            }
            let angles = per_link(angles, "angles_deg")?;
            let rates = match rates {
                Some(r) => per_link(r, "angular_velocities_deg")?,
                None => vec![0.0; c.links],
            };
            Ok(angles
                .iter()
                .zip(rates)
                .map(|(&t, w)| ([t.sin(), -t.cos(), 0.0], w))
                .collect())
        }
    }
}
