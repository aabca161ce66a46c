//! Orientations: a rotation matrix from a quaternion, an axis and angle, or a matrix; back to a
//! quaternion; and the angular velocity of directors, `ω = ½ Σ dᵢ × ḋᵢ`.

use crate::error::SetupError;

/// A rotation matrix `R` (row-major), its columns the body's axes in the world's frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rotation(pub [[f64; 3]; 3]);

/// How far a matrix may be from a rotation (orthonormality and determinant).
const ROTATION_TOL: f64 = 1e-9;

impl Rotation {
    /// The identity.
    pub fn identity() -> Self {
        Self([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    }

    /// The rotation of the quaternion `[w, x, y, z]` (normalized here).
    ///
    /// # Errors
    /// [`SetupError::InvalidParameter`] for a zero or non-finite quaternion.
    pub fn from_quaternion(q: [f64; 4]) -> Result<Self, SetupError> {
        let n = q.iter().map(|v| v * v).sum::<f64>().sqrt();
        if !(n > 0.0 && n.is_finite()) {
            return Err(SetupError::InvalidParameter {
                name: "quaternion".to_owned(),
                value: n,
                requirement: "non-zero and finite",
            });
        }
        let [w, x, y, z] = q.map(|v| v / n);
        Ok(Self([
            [
                1.0 - 2.0 * (y * y + z * z),
                2.0 * (x * y - w * z),
                2.0 * (x * z + w * y),
            ],
            [
                2.0 * (x * y + w * z),
                1.0 - 2.0 * (x * x + z * z),
                2.0 * (y * z - w * x),
            ],
            [
                2.0 * (x * z - w * y),
                2.0 * (y * z + w * x),
                1.0 - 2.0 * (x * x + y * y),
            ],
        ]))
    }

    /// The rotation by `angle` (radians) about `axis` (normalized here).
    ///
    /// # Errors
    /// [`SetupError::InvalidParameter`] for a zero or non-finite axis or a non-finite angle.
    pub fn from_axis_angle(axis: [f64; 3], angle: f64) -> Result<Self, SetupError> {
        let n = axis.iter().map(|v| v * v).sum::<f64>().sqrt();
        if !(n > 0.0 && n.is_finite() && angle.is_finite()) {
            return Err(SetupError::InvalidParameter {
                name: "rotation axis".to_owned(),
                value: n,
                requirement: "non-zero and finite, with a finite angle",
            });
        }
        let (s, c) = (0.5 * angle).sin_cos();
        Self::from_quaternion([c, s * axis[0] / n, s * axis[1] / n, s * axis[2] / n])
    }

    /// `m` itself, checked to be a rotation (orthonormal, determinant +1, to 1e-9).
    ///
    /// # Errors
    /// [`SetupError::InvalidParameter`] otherwise.
    pub fn from_matrix(m: [[f64; 3]; 3]) -> Result<Self, SetupError> {
        let r = Self(m);
        let mut worst = 0.0f64;
        for i in 0..3 {
            for j in 0..3 {
                let dot: f64 = (0..3).map(|k| m[k][i] * m[k][j]).sum();
                let want = if i == j { 1.0 } else { 0.0 };
                worst = worst.max((dot - want).abs());
            }
        }
        let det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
        if !(worst <= ROTATION_TOL && (det - 1.0).abs() <= ROTATION_TOL) {
            return Err(SetupError::InvalidParameter {
                name: "rotation matrix".to_owned(),
                value: worst.max((det - 1.0).abs()),
                requirement: "orthonormal columns and determinant +1 (to 1e-9)",
            });
        }
        Ok(r)
    }

    /// Column `c`: the body's axis `c` in the world's frame.
    pub fn column(&self, c: usize) -> [f64; 3] {
        [self.0[0][c], self.0[1][c], self.0[2][c]]
    }

    /// `R v`.
    pub fn apply(&self, v: [f64; 3]) -> [f64; 3] {
        core::array::from_fn(|r| (0..3).map(|c| self.0[r][c] * v[c]).sum())
    }

    /// `R S` for another rotation `S`.
    pub fn then(&self, s: &Rotation) -> Rotation {
        Rotation(core::array::from_fn(|r| {
            core::array::from_fn(|c| (0..3).map(|k| self.0[r][k] * s.0[k][c]).sum())
        }))
    }

    /// `Rᵀ`.
    pub fn transpose(&self) -> Rotation {
        Rotation(core::array::from_fn(|r| {
            core::array::from_fn(|c| self.0[c][r])
        }))
    }

    /// The unit quaternion `[w, x, y, z]` with `w ≥ 0` (Shepperd's method: from the largest of
    /// `w², x², y², z²`, so no branch divides by a small number).
    pub fn quaternion(&self) -> [f64; 4] {
        let m = &self.0;
        let trace = m[0][0] + m[1][1] + m[2][2];
        let q = if trace >= m[0][0].max(m[1][1]).max(m[2][2]) {
            let w = 0.5 * (1.0 + trace).max(0.0).sqrt();
            let f = 0.25 / w;
            [
                w,
                (m[2][1] - m[1][2]) * f,
                (m[0][2] - m[2][0]) * f,
                (m[1][0] - m[0][1]) * f,
            ]
        } else if m[0][0] >= m[1][1] && m[0][0] >= m[2][2] {
            let x = 0.5 * (1.0 + 2.0 * m[0][0] - trace).max(0.0).sqrt();
            let f = 0.25 / x;
            [
                (m[2][1] - m[1][2]) * f,
                x,
                (m[0][1] + m[1][0]) * f,
                (m[0][2] + m[2][0]) * f,
            ]
        } else if m[1][1] >= m[2][2] {
            let y = 0.5 * (1.0 + 2.0 * m[1][1] - trace).max(0.0).sqrt();
            let f = 0.25 / y;
            [
                (m[0][2] - m[2][0]) * f,
                (m[0][1] + m[1][0]) * f,
                y,
                (m[1][2] + m[2][1]) * f,
            ]
        } else {
            let z = 0.5 * (1.0 + 2.0 * m[2][2] - trace).max(0.0).sqrt();
            let f = 0.25 / z;
            [
                (m[1][0] - m[0][1]) * f,
                (m[0][2] + m[2][0]) * f,
                (m[1][2] + m[2][1]) * f,
                z,
            ]
        };
        if q[0] < 0.0 { q.map(|v| -v) } else { q }
    }
}

/// `r` as a turn about `e_z` (a planar model's rotations): its third column must be `e_z` to
/// `1e-12`; returned with that column exact and the first two rebuilt from the first's
/// direction in the plane, so a planar body's normal director is exactly constant.
pub(crate) fn planar_rotation(what: &str, r: &Rotation) -> Result<Rotation, SetupError> {
    let off = r.0[0][2]
        .abs()
        .max(r.0[1][2].abs())
        .max((r.0[2][2] - 1.0).abs());
    let first = [r.0[0][0], r.0[1][0]];
    let n = first[0].hypot(first[1]);
    if !(off <= 1e-12 && n > 0.5) {
        return Err(SetupError::InvalidParameter {
            name: format!("{what} (a planar body)"),
            value: off,
            requirement: "a turn about the plane's normal: the third axis along z",
        });
    }
    let (c, s) = (first[0] / n, first[1] / n);
    Ok(Rotation([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]))
}

/// `a × b`.
pub fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// `a · b`.
pub fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// The body frame `R = Q Pᵀ` of a body whose directors (the columns of `Q = R P`) are the slots
/// `slot + 1 …` of the positions `q` (`dim` each; in the plane the third is `e_z`), `P` its
/// principal axes.
pub(crate) fn body_frame(q: &[f64], slot: usize, axes: &Rotation, dim: usize) -> Rotation {
    let directors = Rotation(core::array::from_fn(|r| {
        core::array::from_fn(|c| director(q, slot, c, dim)[r])
    }));
    directors.then(&axes.transpose())
}

/// Director `i` of the body at `slot`: its positions, or in the plane (`dim = 2`) the normal
/// `e_z` for `i = 2`.
fn director(x: &[f64], slot: usize, i: usize, dim: usize) -> [f64; 3] {
    if i >= dim {
        return [0.0, 0.0, 1.0];
    }
    let s = dim * (slot + 1 + i);
    core::array::from_fn(|k| if k < dim { x[s + k] } else { 0.0 })
}

/// The angular velocity in the world of the body whose directors are the slots `slot + 1 …`,
/// `ω = ½ Σ dᵢ × ḋᵢ` (`Q̇ Qᵀ = ω̂` for orthonormal `Q`), with `ḋᵢ = p_dᵢ / mass(s)` of slot `s`
/// (`dim` positions each; in the plane the sum is over the two moving directors, whose halves
/// give the whole spin about `e_z`, the normal's own rate being zero).
pub(crate) fn director_spin(
    q: &[f64],
    p: &[f64],
    slot: usize,
    mass: impl Fn(usize) -> f64,
    dim: usize,
) -> [f64; 3] {
    let mut w = [0.0; 3];
    for i in 0..3 {
        let s = slot + 1 + i;
        let d = director(q, slot, i, dim);
        let v = director(p, slot, i, dim).map(|x| if i < dim { x / mass(s) } else { 0.0 });
        let c = cross(d, v);
        for k in 0..3 {
            w[k] += 0.5 * c[k];
        }
    }
    w
}
