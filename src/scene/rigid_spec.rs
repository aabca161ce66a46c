//! A rigid body's inertia and orientation as a scene declares them, and their checks: the
//! inertia from principal moments (with axes), a tensor, or a shape with a mass or a density;
//! the orientation from a quaternion, an axis and angle, or a rotation matrix.

use crate::error::SetupError;
use crate::rigid::{Inertia, Rotation};
use crate::scene::error::{FieldPath, SceneErrorKind};
use crate::scene::validate::{Result, err, positive};
use serde::Deserialize;

/// `inertia = { … }`: exactly one of `moments` (with optional `axes`), `tensor`, or `shape`.
///
/// ```toml
/// inertia = { moments = [1, 2, 3] }                 # principal, along the body's axes
/// inertia = { moments = [1, 2, 3], axes = [[…], […], […]] }
/// inertia = { tensor = [[2, 0, 0], [0, 3, 0.1], [0, 0.1, 4]] }
/// inertia = { shape = "box", size = [0.1, 0.2, 0.3] }        # with the body's `mass`
/// inertia = { shape = "cylinder", radius = 0.1, height = 0.5, density = 7800 }
/// inertia = { shape = "sphere", radius = 0.1 }
/// inertia = { moment = 0.02 }                       # planar scenes: about the plane's normal
/// ```
///
/// In a planar scene (`dim = 2`) the body turns about the plane's normal `z`: any of these
/// whose principal axes include `z` (a box, a cylinder along `z`, a sphere, moments along the
/// body's axes), or `moment`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InertiaSpec {
    /// Principal moments `J₁, J₂, J₃` (kg m²), each at most the sum of the other two.
    #[serde(default)]
    pub moments: Option<Vec<f64>>,
    /// The principal axes in the body's frame, one per moment (default: the body's axes).
    #[serde(default)]
    pub axes: Option<Vec<Vec<f64>>>,
    /// The inertia tensor in the body's frame (symmetric, positive definite, 3 × 3).
    #[serde(default)]
    pub tensor: Option<Vec<Vec<f64>>>,
    /// `"box"` (`size`: its three sides), `"cylinder"` (`radius`, `height`, its axis along the
    /// body's third axis) or `"sphere"` (`radius`), solid and uniform.
    #[serde(default)]
    pub shape: Option<String>,
    /// A box's sides along the body's axes.
    #[serde(default)]
    pub size: Option<Vec<f64>>,
    /// A cylinder's or a sphere's radius.
    #[serde(default)]
    pub radius: Option<f64>,
    /// A cylinder's height.
    #[serde(default)]
    pub height: Option<f64>,
    /// The shape's density (kg/m³): its mass is then the volume times it (give `mass` or
    /// `density`, not both).
    #[serde(default)]
    pub density: Option<f64>,
    /// A planar body's moment of inertia about the plane's normal (kg m², `dim = 2` only).
    #[serde(default)]
    pub moment: Option<f64>,
}

/// `orientation = { … }`: exactly one of `quaternion`, `axis` with `angle_deg`, or `matrix`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OrientationSpec {
    /// `[w, x, y, z]`, normalized when read.
    #[serde(default)]
    pub quaternion: Option<Vec<f64>>,
    /// The rotation's axis (with `angle_deg`).
    #[serde(default)]
    pub axis: Option<Vec<f64>>,
    /// The rotation's angle about `axis`, degrees.
    #[serde(default)]
    pub angle_deg: Option<f64>,
    /// The rotation matrix, by rows (its columns are the body's axes in the world).
    #[serde(default)]
    pub matrix: Option<Vec<Vec<f64>>>,
}

/// A uniform solid's dimensions.
#[derive(Clone, Copy)]
enum Solid {
    Box([f64; 3]),
    Cylinder(f64, f64),
    Sphere(f64),
}

/// A library setup error as a scene error at `path`.
fn located(path: &FieldPath, e: SetupError) -> crate::scene::error::SceneError {
    err(SceneErrorKind::Value, path.clone(), e.to_string())
}

/// Exactly three finite numbers.
fn three(v: &[f64], path: &FieldPath) -> Result<[f64; 3]> {
    match v {
        &[a, b, c] if [a, b, c].iter().all(|x| x.is_finite()) => Ok([a, b, c]),
        _ => Err(err(
            SceneErrorKind::Dimension,
            path.clone(),
            format!("three finite numbers, not {v:?}"),
        )),
    }
}

/// A 3 × 3 matrix of finite numbers, by rows.
fn matrix(m: &[Vec<f64>], path: &FieldPath) -> Result<[[f64; 3]; 3]> {
    if m.len() != 3 {
        return Err(err(
            SceneErrorKind::Dimension,
            path.clone(),
            format!("a 3 × 3 matrix (three rows), not {} rows", m.len()),
        ));
    }
    Ok([
        three(&m[0], &path.index(0))?,
        three(&m[1], &path.index(1))?,
        three(&m[2], &path.index(2))?,
    ])
}

impl InertiaSpec {
    /// The solid a drawing shows (`scene::sketch`), when the inertia is a shape (read after
    /// [`resolve`](Self::resolve) has checked it).
    pub(crate) fn drawn_shape(&self) -> Option<crate::scene::shape::Shape> {
        use crate::scene::shape::Shape;
        match (self.shape.as_deref()?, &self.size, self.radius, self.height) {
            ("box", Some(s), _, _) if s.len() == 3 => Some(Shape::Box {
                size: [s[0], s[1], s[2]],
            }),
            ("cylinder", _, Some(radius), Some(height)) => Some(Shape::Cylinder { radius, height }),
            ("sphere", _, Some(radius), _) => Some(Shape::Sphere { radius }),
            _ => None,
        }
    }

    /// The body's mass and inertia; `mass` is the body's own `mass` field, `body` where the
    /// body is declared, `dim` the scene's (`moment` is planar only; a planar body's normal is
    /// checked where the body is added, `compile::rigid::push_rigid`).
    pub(crate) fn resolve(
        &self,
        mass: Option<f64>,
        body: &FieldPath,
        dim: usize,
    ) -> Result<(f64, Inertia)> {
        let path = &body.key("inertia");
        let given = [
            self.moments.is_some(),
            self.tensor.is_some(),
            self.shape.is_some(),
            self.moment.is_some(),
        ];
        if given.iter().filter(|&&g| g).count() != 1 {
            return Err(err(
                SceneErrorKind::Value,
                path.clone(),
                if dim == 2 {
                    "give exactly one of `moment`, `moments` (with `axes`), `tensor`, or `shape`"
                } else {
                    "give exactly one of `moments` (with `axes`), `tensor`, or `shape`"
                },
            ));
        }
        let mass_path = body.key("mass");
        if self.axes.is_some() && self.moments.is_none() {
            return Err(err(
                SceneErrorKind::Value,
                path.key("axes"),
                "`axes` go with `moments` (a tensor, a shape or a planar moment has its own)",
            ));
        }
        if let Some(shape) = &self.shape {
            return self.shape(shape, mass, path, &mass_path);
        }
        for (field, set) in [
            ("size", self.size.is_some()),
            ("radius", self.radius.is_some()),
            ("height", self.height.is_some()),
            ("density", self.density.is_some()),
        ] {
            if set {
                return Err(err(
                    SceneErrorKind::Value,
                    path.key(field),
                    format!("`{field}` belongs to a `shape`"),
                ));
            }
        }
        let Some(mass) = mass else {
            return Err(err(
                SceneErrorKind::Value,
                mass_path,
                "a rigid body needs a `mass` (or a `shape` with a `density`)",
            ));
        };
        let mass = positive(mass, &mass_path, "mass")?;
        let inertia = if let Some(j) = self.moment {
            let mp = path.key("moment");
            if dim != 2 {
                return Err(err(
                    SceneErrorKind::Value,
                    mp,
                    "`moment` is a planar body's (dim = 2); in 3D give `moments`, a `tensor` or a `shape`",
                ));
            }
            // The planar body's directors carry E₁ = E₂ = J/2 (their sum the moment about z);
            // J₁ = J₂ = J₃ = J is the one tensor with those and a positive E₃.
            Inertia::principal([positive(j, &mp, "moment")?; 3]).map_err(|e| located(&mp, e))?
        } else if let Some(t) = &self.tensor {
            let tp = path.key("tensor");
            Inertia::tensor(matrix(t, &tp)?).map_err(|e| located(&tp, e))?
        } else {
            let mp = path.key("moments");
            let moments = three(self.moments.as_deref().unwrap_or_default(), &mp)?;
            match &self.axes {
                None => Inertia::principal(moments).map_err(|e| located(&mp, e))?,
                Some(axes) => {
                    let ap = path.key("axes");
                    // Given one axis per moment: the matrix whose columns they are.
                    let rows = matrix(axes, &ap)?;
                    let columns = core::array::from_fn(|r| core::array::from_fn(|c| rows[c][r]));
                    Inertia::with_axes(moments, columns).map_err(|e| located(&ap, e))?
                }
            }
        };
        Ok((mass, inertia))
    }

    /// A uniform solid shape's mass and inertia.
    fn shape(
        &self,
        shape: &str,
        mass: Option<f64>,
        path: &FieldPath,
        mass_path: &FieldPath,
    ) -> Result<(f64, Inertia)> {
        use std::f64::consts::PI;
        let need = |v: Option<f64>, field: &str| {
            let p = path.key(field);
            let v = v.ok_or_else(|| {
                err(
                    SceneErrorKind::Value,
                    p.clone(),
                    format!("a {shape} needs `{field}`"),
                )
            })?;
            positive(v, &p, field)
        };
        let solid = match shape {
            "box" => {
                let sp = path.key("size");
                let size = self
                    .size
                    .as_deref()
                    .ok_or_else(|| err(SceneErrorKind::Value, sp.clone(), "a box needs `size`"))?;
                let s = three(size, &sp)?;
                for (k, &x) in s.iter().enumerate() {
                    positive(x, &sp.index(k), "side")?;
                }
                Solid::Box(s)
            }
            "cylinder" => {
                Solid::Cylinder(need(self.radius, "radius")?, need(self.height, "height")?)
            }
            "sphere" => Solid::Sphere(need(self.radius, "radius")?),
            other => {
                return Err(err(
                    SceneErrorKind::Value,
                    path.key("shape"),
                    format!("'{other}' is not a shape: \"box\", \"cylinder\" or \"sphere\""),
                ));
            }
        };
        let volume = match solid {
            Solid::Box(s) => s[0] * s[1] * s[2],
            Solid::Cylinder(r, h) => PI * r * r * h,
            Solid::Sphere(r) => 4.0 / 3.0 * PI * r * r * r,
        };
        let mass = match (mass, self.density) {
            (Some(m), None) => positive(m, mass_path, "mass")?,
            (None, Some(rho)) => positive(rho, &path.key("density"), "density")? * volume,
            (Some(_), Some(_)) => {
                return Err(err(
                    SceneErrorKind::Value,
                    path.key("density"),
                    "give the body's `mass` or the shape's `density`, not both",
                ));
            }
            (None, None) => {
                return Err(err(
                    SceneErrorKind::Value,
                    mass_path.clone(),
                    "a rigid body needs a `mass` or its shape's `density`",
                ));
            }
        };
        let inertia = match solid {
            Solid::Box(s) => Inertia::solid_box(mass, s),
            Solid::Cylinder(r, h) => Inertia::solid_cylinder(mass, r, h),
            Solid::Sphere(r) => Inertia::solid_sphere(mass, r),
        }
        .map_err(|e| located(path, e))?;
        Ok((mass, inertia))
    }
}

impl OrientationSpec {
    /// The rotation it declares; in a planar scene (`dim = 2`) a turn about `z`, by
    /// `angle_deg` alone or any form whose third axis is `z`.
    pub(crate) fn resolve(&self, path: &FieldPath, dim: usize) -> Result<Rotation> {
        if dim == 2
            && self.axis.is_none()
            && self.quaternion.is_none()
            && self.matrix.is_none()
            && let Some(angle) = self.angle_deg
        {
            return Rotation::from_axis_angle([0.0, 0.0, 1.0], angle.to_radians())
                .map_err(|e| located(&path.key("angle_deg"), e));
        }
        let r = self.resolve_3d(path)?;
        if dim != 2 {
            return Ok(r);
        }
        crate::rigid::planar_rotation("orientation", &r).map_err(|e| located(path, e))
    }

    fn resolve_3d(&self, path: &FieldPath) -> Result<Rotation> {
        let given = [
            self.quaternion.is_some(),
            self.axis.is_some() || self.angle_deg.is_some(),
            self.matrix.is_some(),
        ];
        if given.iter().filter(|&&g| g).count() != 1 {
            return Err(err(
                SceneErrorKind::Value,
                path.clone(),
                "give exactly one of `quaternion`, `axis` with `angle_deg`, or `matrix`",
            ));
        }
        if let Some(q) = &self.quaternion {
            let qp = path.key("quaternion");
            let q: [f64; 4] = q.as_slice().try_into().map_err(|_| {
                err(
                    SceneErrorKind::Dimension,
                    qp.clone(),
                    format!("[w, x, y, z]: four numbers, not {}", q.len()),
                )
            })?;
            return Rotation::from_quaternion(q).map_err(|e| located(&qp, e));
        }
        if let Some(m) = &self.matrix {
            let mp = path.key("matrix");
            return Rotation::from_matrix(matrix(m, &mp)?).map_err(|e| located(&mp, e));
        }
        let (Some(axis), Some(angle)) = (&self.axis, self.angle_deg) else {
            let missing = if self.axis.is_none() {
                "axis"
            } else {
                "angle_deg"
            };
            return Err(err(
                SceneErrorKind::Value,
                path.key(missing),
                "an axis–angle orientation needs `axis` and `angle_deg`",
            ));
        };
        let ap = path.key("axis");
        Rotation::from_axis_angle(three(axis, &ap)?, angle.to_radians())
            .map_err(|e| located(&ap, e))
    }
}
