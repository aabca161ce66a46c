//! A rigid body's inertia: its principal moments `J₁, J₂, J₃` and principal axes in the body's
//! frame, and the director masses `Eᵢ = ∫ Xᵢ² dm = ½(J_j + J_k − J_i)` of the kinetic energy
//! `½ m |ċ|² + ½ Σ Eᵢ |ḋᵢ|²` (`../shared/docs/METHOD.md` §8).

use crate::error::SetupError;
use nalgebra::{Matrix3, SymmetricEigen};

/// Principal moments (about the centre of mass) and the principal axes as the columns of a
/// rotation from the principal frame to the body's frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Inertia {
    moments: [f64; 3],
    axes: [[f64; 3]; 3],
}

/// The moments' relative slack below which a triangle inequality counts as violated.
const TRIANGLE_SLACK: f64 = 1e-12;

impl Inertia {
    /// Principal moments along the body's own axes.
    ///
    /// # Errors
    /// [`SetupError::InvalidParameter`] for a moment that is not positive and finite, or that
    /// exceeds the sum of the other two (no mass distribution has it: `Eᵢ < 0`) or equals it
    /// (a rod or a lamina, with no extent along one axis: `Eᵢ = 0`).
    pub fn principal(moments: [f64; 3]) -> Result<Self, SetupError> {
        Self::with_axes(moments, [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    }

    /// Principal moments along `axes` (the rows of a rotation matrix's columns: `axes[r][c]` is
    /// row `r` of the matrix whose column `c` is principal axis `c` in the body's frame).
    ///
    /// # Errors
    /// As [`principal`](Self::principal), and [`SetupError::InvalidParameter`] when `axes` is
    /// not a rotation (orthonormal with determinant +1, to 1e-9).
    pub fn with_axes(moments: [f64; 3], axes: [[f64; 3]; 3]) -> Result<Self, SetupError> {
        for (i, &j) in moments.iter().enumerate() {
            if !(j > 0.0 && j.is_finite()) {
                return Err(SetupError::InvalidParameter {
                    name: format!("moment of inertia {}", i + 1),
                    value: j,
                    requirement: "positive and finite",
                });
            }
        }
        let scale = moments.iter().fold(0.0f64, |a, &b| a.max(b));
        for i in 0..3 {
            let (j, k) = ((i + 1) % 3, (i + 2) % 3);
            if moments[i] >= (moments[j] + moments[k]) * (1.0 - TRIANGLE_SLACK)
                && moments[i] - (moments[j] + moments[k]) > -TRIANGLE_SLACK * scale
            {
                return Err(SetupError::InvalidParameter {
                    name: format!("moment of inertia {}", i + 1),
                    value: moments[i],
                    requirement: "less than the sum of the other two moments (the triangle inequality of an inertia tensor: no mass distribution exceeds it, and equality is a rod or a lamina, with no extent along one axis)",
                });
            }
        }
        super::pose::Rotation::from_matrix(axes).map_err(|_| SetupError::InvalidParameter {
            name: "principal axes".to_owned(),
            value: f64::NAN,
            requirement: "a rotation matrix (orthonormal columns, determinant +1)",
        })?;
        Ok(Self { moments, axes })
    }

    /// The inertia tensor about the centre of mass, in the body's frame (symmetric).
    ///
    /// # Errors
    /// [`SetupError::InvalidParameter`] for a tensor that is not symmetric and finite, and as
    /// [`principal`](Self::principal) for its eigenvalues.
    pub fn tensor(t: [[f64; 3]; 3]) -> Result<Self, SetupError> {
        let scale = t.iter().flatten().fold(0.0f64, |a, &b| a.max(b.abs()));
        let symmetric = (0..3).all(|r| (0..3).all(|c| (t[r][c] - t[c][r]).abs() <= 1e-12 * scale));
        if !symmetric || !t.iter().flatten().all(|v| v.is_finite()) {
            return Err(SetupError::InvalidParameter {
                name: "inertia tensor".to_owned(),
                value: f64::NAN,
                requirement: "symmetric and finite",
            });
        }
        let m = Matrix3::from_fn(|r, c| 0.5 * (t[r][c] + t[c][r]));
        let eig = SymmetricEigen::new(m);
        let mut axes: [[f64; 3]; 3] =
            core::array::from_fn(|r| core::array::from_fn(|c| eig.eigenvectors[(r, c)]));
        // A proper rotation: flip the last axis of a reflection.
        let det = eig.eigenvectors.determinant();
        if det < 0.0 {
            for row in &mut axes {
                row[2] = -row[2];
            }
        }
        let moments = [eig.eigenvalues[0], eig.eigenvalues[1], eig.eigenvalues[2]];
        Self::with_axes(moments, axes)
    }

    /// A solid box of `mass` with side lengths `sides` along the body's axes.
    ///
    /// # Errors
    /// [`SetupError::InvalidParameter`] for a mass or side that is not positive and finite.
    pub fn solid_box(mass: f64, sides: [f64; 3]) -> Result<Self, SetupError> {
        positive("mass", mass)?;
        for (i, &s) in sides.iter().enumerate() {
            positive(&format!("side {}", i + 1), s)?;
        }
        let [a, b, c] = sides.map(|s| s * s);
        Self::principal([
            mass * (b + c) / 12.0,
            mass * (a + c) / 12.0,
            mass * (a + b) / 12.0,
        ])
    }

    /// A solid cylinder of `mass`, `radius` and `height`, its axis along the body's third axis.
    ///
    /// # Errors
    /// [`SetupError::InvalidParameter`] for a value that is not positive and finite.
    pub fn solid_cylinder(mass: f64, radius: f64, height: f64) -> Result<Self, SetupError> {
        positive("mass", mass)?;
        positive("radius", radius)?;
        positive("height", height)?;
        let side = mass * (3.0 * radius * radius + height * height) / 12.0;
        Self::principal([side, side, 0.5 * mass * radius * radius])
    }

    /// A solid sphere of `mass` and `radius`.
    ///
    /// # Errors
    /// [`SetupError::InvalidParameter`] for a value that is not positive and finite.
    pub fn solid_sphere(mass: f64, radius: f64) -> Result<Self, SetupError> {
        positive("mass", mass)?;
        positive("radius", radius)?;
        Self::principal([0.4 * mass * radius * radius; 3])
    }

    /// The principal moments `J₁, J₂, J₃`.
    pub fn moments(&self) -> [f64; 3] {
        self.moments
    }

    /// The principal axes: column `c` of the returned matrix is axis `c` in the body's frame.
    pub fn axes(&self) -> [[f64; 3]; 3] {
        self.axes
    }

    /// The same inertia with its third principal axis along the body's `z` axis, as a planar
    /// body needs (it turns about that axis: its moment there is `E₁ + E₂`): from the tensor
    /// `T = P diag(J) Pᵀ`, whose `xz` and `yz` entries must vanish, the in-plane axes at
    /// `φ = ½ atan2(2T_xy, T_xx − T_yy)`.
    ///
    /// # Errors
    /// [`SetupError::InvalidParameter`] when no principal axis lies along `z` (to 1e-12 of the
    /// largest moment).
    pub(crate) fn about_normal(&self) -> Result<Self, SetupError> {
        let (p, j) = (self.axes, self.moments);
        let t = |r: usize, c: usize| (0..3).map(|k| p[r][k] * j[k] * p[c][k]).sum::<f64>();
        let scale = j.iter().fold(0.0f64, |a, &b| a.max(b));
        let off = t(0, 2).abs().max(t(1, 2).abs());
        if off > 1e-12 * scale {
            return Err(SetupError::InvalidParameter {
                name: "inertia of a planar body".to_owned(),
                value: off,
                requirement: "a principal axis along the body's z axis (the plane's normal): no xz or yz product of inertia",
            });
        }
        let (xx, yy, xy) = (t(0, 0), t(1, 1), t(0, 1));
        let phi = 0.5 * (2.0 * xy).atan2(xx - yy);
        let (c, s) = (phi.cos(), phi.sin());
        let j1 = c * c * xx + 2.0 * c * s * xy + s * s * yy;
        let j2 = s * s * xx - 2.0 * c * s * xy + c * c * yy;
        Self::with_axes(
            [j1, j2, t(2, 2)],
            [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]],
        )
    }

    /// The director masses `Eᵢ = ½(J_j + J_k − J_i)`, all positive.
    pub fn director_masses(&self) -> [f64; 3] {
        let [a, b, c] = self.moments;
        [0.5 * (b + c - a), 0.5 * (a + c - b), 0.5 * (a + b - c)]
    }
}

fn positive(name: &str, value: f64) -> Result<(), SetupError> {
    if value > 0.0 && value.is_finite() {
        Ok(())
    } else {
        Err(SetupError::InvalidParameter {
            name: name.to_owned(),
            value,
            requirement: "positive and finite",
        })
    }
}
