//! [`Multibody`]: point masses and rigid bodies (centre of mass and directors) joined by
//! joints, under uniform gravity — a [`System`] of mechanical form with a constant diagonal
//! mass matrix, run by the library's flows (RATTLE: the projection around kick ∘ drift ∘ kick).

use super::RigidBody;
use super::drift::MultibodyDrift;
use super::elements::{HingeAngle, JointDamper, JointSpring};
pub use super::energy::MultibodyEnergy;
use super::frames::{Entry, Frames};
use super::joints::{Hinge, JointKind};
use super::kick::MultibodyKick;
use super::pose::{Rotation, cross, dot};
use super::rows::{QuadraticRows, RowBuilder};
use crate::error::SetupError;
use crate::flow::{Coupling, ProjectionOptions};
use crate::nonlinear::NewtonOptions;
use crate::real::Real;
use crate::system::{Canonical, Case, System};
use crate::vector::Vector;

/// Point masses and rigid bodies joined by joints, under uniform gravity; see the module
/// documentation and `../shared/docs/METHOD.md` §8.
///
/// **State.** Slots of three positions each: a point mass is one slot; a rigid body is four,
/// its centre of mass `c` and its directors `d₁, d₂, d₃` (the columns of its rotation along its
/// principal axes), with the masses `m, E₁, E₂, E₃` ([`Inertia::director_masses`](super::Inertia::director_masses)). The state
/// is `(q, p)`, `p_s = m_s q̇_s`, so
///
/// ```text
/// H = Σ_s |p_s|²/(2 m_s) − Σ_bodies m g·c,
/// ```
///
/// constant diagonal mass, gravity on the centres alone. Each rigid body adds the six rows of
/// `QᵀQ = I` (`(|dᵢ|² − 1)/2`, `dᵢ·dⱼ`), each joint its rows ([`JointKind`]); all have degree
/// ≤ 2 ([`QuadraticRows`]). The free flight `q_s += h p_s/m_s` is exact, gravity a kick, and
/// the projected kick–drift–kick step is RATTLE on the rotation matrices — for a free body the
/// discrete Moser–Veselov map, which keeps energy and angular momentum without drift
/// (McLachlan & Scovel 1995; Leimkuhler & Reich 2004, ch. 8).
#[derive(Debug, Clone, PartialEq)]
pub struct Multibody {
    /// Positions per slot: 3, or 2 for a planar model.
    dim: usize,
    gravity: [f64; 3],
    masses: Vec<f64>,
    /// Whether a slot carries a body's translation (gravity acts on it).
    translational: Vec<bool>,
    entries: Vec<Entry>,
    /// Initial positions and momenta, slot by slot.
    q0: Vec<f64>,
    p0: Vec<f64>,
    rows: Vec<RowBuilder<f64>>,
    /// `(joint kind, first row)` of each joint.
    joints: Vec<(&'static str, usize)>,
    springs: Vec<JointSpring>,
    dampers: Vec<JointDamper>,
}

/// How far from its row an initial pose may be (the rows' scale is 1: unit directors, metres).
const INITIAL_ROW_TOL: f64 = 1e-9;

impl Multibody {
    /// The joints' view of the model.
    fn frames(&self) -> Frames<'_> {
        Frames {
            entries: &self.entries,
            q0: &self.q0,
            dim: self.dim,
        }
    }

    /// An empty model under the uniform field `gravity` (an acceleration, m/s²).
    pub fn new(gravity: [f64; 3]) -> Self {
        Self::with_dim(3, gravity)
    }

    /// An empty planar model (`dim = 2`: slots of two positions) under the field `gravity` in
    /// the plane. Its rigid bodies turn about the plane's normal `e_z`: two directors each (the
    /// masses `E₁, E₂`, `E₁ + E₂` the moment about the normal), three rows of `QᵀQ = I`; its
    /// joints are the 3D kinds with the normal a constant director ([`joint_rows`]) — a hinge
    /// about `e_z` is the planar pin, a slider along an axis in the plane the planar prism.
    ///
    /// [`joint_rows`]: super::joints::joint_rows
    pub fn planar(gravity: [f64; 2]) -> Self {
        Self::with_dim(2, [gravity[0], gravity[1], 0.0])
    }

    fn with_dim(dim: usize, gravity: [f64; 3]) -> Self {
        Self {
            dim,
            gravity,
            masses: Vec::new(),
            translational: Vec::new(),
            entries: Vec::new(),
            q0: Vec::new(),
            p0: Vec::new(),
            rows: Vec::new(),
            joints: Vec::new(),
            springs: Vec::new(),
            dampers: Vec::new(),
        }
    }

    fn push_slot(&mut self, mass: f64, translational: bool, q: [f64; 3], v: [f64; 3]) {
        self.masses.push(mass);
        self.translational.push(translational);
        self.q0.extend_from_slice(&q[..self.dim]);
        self.p0.extend(v[..self.dim].iter().map(|x| mass * x));
    }

    /// The positions per slot: 3, or 2 for a planar model.
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// Adds a point mass; returns its index.
    ///
    /// # Errors
    /// [`SetupError::InvalidParameter`] for a mass that is not positive and finite or a
    /// non-finite position or velocity.
    pub fn add_point(
        &mut self,
        mass: f64,
        position: [f64; 3],
        velocity: [f64; 3],
    ) -> Result<usize, SetupError> {
        check_mass(mass)?;
        check_finite("position", &position)?;
        check_finite("velocity", &velocity)?;
        self.check_in_plane("position", position)?;
        self.check_in_plane("velocity", velocity)?;
        let slot = self.masses.len();
        self.push_slot(mass, true, position, velocity);
        self.entries.push(Entry::Point { slot });
        Ok(self.entries.len() - 1)
    }

    /// Adds a rigid body (four slots and the six rows of `QᵀQ = I`); returns its index.
    ///
    /// # Errors
    /// [`SetupError::InvalidParameter`] for a mass that is not positive and finite or a
    /// non-finite pose or velocity.
    pub fn add_rigid(&mut self, body: RigidBody) -> Result<usize, SetupError> {
        check_mass(body.mass)?;
        check_finite("position", &body.position)?;
        check_finite("velocity", &body.velocity)?;
        check_finite("angular velocity", &body.angular_velocity)?;
        let slot = self.masses.len();
        let mut inertia = body.inertia;
        let mut orientation = body.orientation;
        if self.dim == 2 {
            self.check_in_plane("position", body.position)?;
            self.check_in_plane("velocity", body.velocity)?;
            inertia = inertia.about_normal()?;
            orientation = super::pose::planar_rotation("orientation", &orientation)?;
            let w = body.angular_velocity;
            if w[0] != 0.0 || w[1] != 0.0 {
                return Err(SetupError::InvalidParameter {
                    name: "angular velocity".to_owned(),
                    value: w[0].abs().max(w[1].abs()),
                    requirement: "along the plane's normal in a planar model",
                });
            }
        }
        let axes = Rotation(inertia.axes());
        // The principal axes in the world: Q = R P.
        let q = orientation.then(&axes);
        self.push_slot(body.mass, true, body.position, body.velocity);
        let e = inertia.director_masses();
        for (i, &ei) in e.iter().enumerate().take(self.dim) {
            let d = q.column(i);
            self.push_slot(ei, false, d, cross(body.angular_velocity, d));
        }
        // QᵀQ = I: (|dᵢ|² − 1)/2 and dᵢ·dⱼ.
        self.rows
            .extend(super::body::orthonormality(slot, self.dim));
        self.entries.push(Entry::Rigid { slot, axes });
        Ok(self.entries.len() - 1)
    }

    /// Adds a joint; returns its index.
    ///
    /// # Errors
    /// The joint's own ([`JointKind::rows`]), and [`SetupError::InvalidParameter`] when the
    /// initial poses do not satisfy its rows (anchors apart, axes not aligned), naming the joint
    /// and the row.
    pub fn add_joint(&mut self, joint: &dyn JointKind) -> Result<usize, SetupError> {
        let rows = super::joints::joint_rows(joint, &self.frames())?;
        let mut joint_rows = QuadraticRows::<f64>::new(self.q0.len());
        for row in &rows {
            joint_rows.push(row);
        }
        for r in 0..rows.len() {
            let g = joint_rows.row_residual(&self.q0, r);
            if g.is_nan() || g.abs() > INITIAL_ROW_TOL {
                return Err(SetupError::InvalidParameter {
                    name: format!("{} joint {} (row {r})", joint.name(), self.joints.len()),
                    value: g,
                    requirement: "satisfied by the initial poses (anchors coincident, axes aligned as the joint holds them)",
                });
            }
        }
        self.joints.push((joint.name(), self.rows.len()));
        self.rows.extend(rows);
        Ok(self.joints.len() - 1)
    }

    /// Adds a spring `½ k (θ − θ₀)²` on `hinge`'s angle (`θ = 0` at the initial poses; the
    /// hinge itself is added with [`add_joint`](Self::add_joint)); returns its index.
    ///
    /// # Errors
    /// [`SetupError::InvalidParameter`] for a stiffness that is negative or not finite or a
    /// rest angle that is not finite; the hinge's own errors.
    pub fn add_hinge_spring(
        &mut self,
        hinge: &Hinge,
        stiffness: f64,
        rest: f64,
    ) -> Result<usize, SetupError> {
        if !(stiffness >= 0.0 && stiffness.is_finite() && rest.is_finite()) {
            return Err(SetupError::InvalidParameter {
                name: "hinge spring".to_owned(),
                value: stiffness,
                requirement: "a stiffness non-negative and finite, a finite rest angle",
            });
        }
        let angle = HingeAngle::of(hinge, &self.frames())?;
        self.springs.push(JointSpring {
            angle,
            stiffness,
            rest,
        });
        Ok(self.springs.len() - 1)
    }

    /// Adds a damper `c θ̇` on `hinge`'s rate, acting along the constraint-consistent
    /// direction ([`JointDamper`]); returns its index.
    ///
    /// # Errors
    /// [`SetupError::InvalidParameter`] for a coefficient that is negative or not finite; the
    /// hinge's own errors.
    pub fn add_hinge_damper(
        &mut self,
        hinge: &Hinge,
        coefficient: f64,
    ) -> Result<usize, SetupError> {
        if !(coefficient >= 0.0 && coefficient.is_finite()) {
            return Err(SetupError::InvalidParameter {
                name: "hinge damper".to_owned(),
                value: coefficient,
                requirement: "non-negative and finite",
            });
        }
        let angle = HingeAngle::of(hinge, &self.frames())?;
        self.dampers.push(JointDamper { angle, coefficient });
        Ok(self.dampers.len() - 1)
    }

    /// The angle of spring `spring`'s hinge at state `x` (radians, `0` at the initial poses).
    pub fn spring_angle(&self, x: &[f64], spring: usize) -> f64 {
        self.springs[spring].angle.value(&x[..self.q0.len()])
    }

    /// The number of slots (three positions each; two in a planar model).
    pub fn slots(&self) -> usize {
        self.masses.len()
    }

    /// The number of constraint rows.
    pub fn constraints(&self) -> usize {
        self.rows.len()
    }

    /// The model as a [`System`] in the scalar `T`.
    pub fn system<T: Real>(&self) -> System<Canonical, MultibodyEnergy<T>, QuadraticRows<T>> {
        System::new(Canonical, self.energy(), self.quadratic_rows())
    }

    /// The constraint rows in the scalar `T`.
    pub fn quadratic_rows<T: Real>(&self) -> QuadraticRows<T> {
        let mut rows = QuadraticRows::new(self.q0.len());
        for row in &self.rows {
            rows.push(&row.cast());
        }
        rows
    }

    /// The Hamiltonian in the scalar `T`.
    pub fn energy<T: Real>(&self) -> MultibodyEnergy<T> {
        MultibodyEnergy {
            dim: self.dim,
            springs: self.springs.clone(),
            inv_masses: self.masses.iter().map(|&m| T::lit(1.0 / m)).collect(),
            weights: self
                .masses
                .iter()
                .zip(&self.translational)
                .map(|(&m, &t)| {
                    let w = if t { m } else { 0.0 };
                    self.gravity.map(|g| T::lit(-w * g))
                })
                .collect(),
        }
    }

    /// The initial state `(q, p)`.
    pub fn initial_state<V: Vector>(&self) -> V {
        let n = self.q0.len();
        let mut x = V::zeros(2 * n);
        let s = x.as_mut_slice();
        for (o, &v) in s.iter_mut().zip(self.q0.iter().chain(&self.p0)) {
            *o = <V::Real as Real>::lit(v);
        }
        x
    }

    /// The kick: the exact flow of the potential (gravity on every centre of mass and point
    /// mass, the springs on joint angles), with the joint dampers' consistent flows around it
    /// ([`MultibodyKick`]).
    pub fn kick<V: Vector>(&self) -> MultibodyKick<V::Real> {
        let force: Vec<V::Real> = self
            .energy::<V::Real>()
            .weights
            .iter()
            .flat_map(|w| w.map(|v| -v).into_iter().take(self.dim))
            .collect();
        let inv = self.inverse_masses();
        MultibodyKick::new(
            force,
            self.springs.clone(),
            self.dampers.clone(),
            self.quadratic_rows(),
            inv,
        )
    }

    /// The exact flow of the kinetic energy, `q_s += h p_s/m_s` ([`MultibodyDrift`]).
    pub fn drift<V: Vector>(&self) -> MultibodyDrift<V::Real> {
        MultibodyDrift::new(self.inverse_masses())
    }

    /// The inverse mass of each position (`dim` per slot).
    fn inverse_masses<T: Real>(&self) -> Vec<T> {
        self.masses
            .iter()
            .flat_map(|&m| core::iter::repeat_n(T::lit(1.0 / m), self.dim))
            .collect()
    }

    /// The projection options for RATTLE on this model: the degenerate case and decoupled
    /// multiplier systems (position rows, forces on the momenta), named so that the dense
    /// bracket analysis is skipped, and the rows' residual tolerance `16 ε` (unit directors;
    /// positions of order one).
    pub fn projection_options<T: Real>(&self) -> ProjectionOptions<T> {
        let scale = self.q0.iter().fold(1.0f64, |a, &b| a.max(b.abs()));
        ProjectionOptions::default()
            .with_case(Case::Degenerate)
            .with_coupling(Coupling::Decoupled)
            .with_newton(NewtonOptions::default().with_ftol(T::lit(16.0 * f64::EPSILON * scale)))
    }

    /// Body `body`'s rotation (its frame's axes in the world) at state `x`.
    ///
    /// # Panics
    /// For an index that is not a rigid body of the model.
    pub fn orientation(&self, x: &[f64], body: usize) -> Rotation {
        let Entry::Rigid { slot, axes } = self.entries[body] else {
            panic!("body {body} is not a rigid body");
        };
        super::pose::body_frame(x, slot, &axes, self.dim)
    }

    /// Body `body`'s orientation as the unit quaternion `[w, x, y, z]` (`w ≥ 0`) at state `x`.
    ///
    /// # Panics
    /// For an index that is not a rigid body of the model.
    pub fn quaternion(&self, x: &[f64], body: usize) -> [f64; 4] {
        self.orientation(x, body).quaternion()
    }

    /// Body `body`'s angular velocity in its own frame, `Rᵀω`, at state `x`.
    ///
    /// # Panics
    /// For an index that is not a rigid body of the model.
    pub fn body_angular_velocity(&self, x: &[f64], body: usize) -> [f64; 3] {
        let r = self.orientation(x, body);
        r.transpose().apply(self.angular_velocity(x, body))
    }

    /// Body `body`'s angular velocity in the world, `ω = ½ Σ dᵢ × ḋᵢ`, at state `x`.
    ///
    /// # Panics
    /// For an index that is not a rigid body of the model.
    pub fn angular_velocity(&self, x: &[f64], body: usize) -> [f64; 3] {
        let Entry::Rigid { slot, .. } = self.entries[body] else {
            panic!("body {body} is not a rigid body");
        };
        let (q, p) = x.split_at(self.q0.len());
        super::pose::director_spin(q, p, slot, |s| self.masses[s], self.dim)
    }

    /// The total angular momentum about the world's origin at state `x`: `Σ c × p_c` over
    /// the centres and point masses plus `Σ dᵢ × p_dᵢ` (`E_i dᵢ × ḋᵢ`) over the directors.
    pub fn angular_momentum(&self, x: &[f64]) -> [f64; 3] {
        let (n, d) = (self.q0.len(), self.dim);
        let mut l = [0.0; 3];
        for s in 0..self.slots() {
            let q: [f64; 3] = core::array::from_fn(|k| if k < d { x[d * s + k] } else { 0.0 });
            let p: [f64; 3] = core::array::from_fn(|k| if k < d { x[n + d * s + k] } else { 0.0 });
            let c = cross(q, p);
            for k in 0..3 {
                l[k] += c[k];
            }
        }
        l
    }

    /// `max |QᵀQ − I|` over the rigid bodies at state `x`.
    pub fn orthonormality_error(&self, x: &[f64]) -> f64 {
        let mut worst = 0.0f64;
        let d = self.dim;
        for e in &self.entries {
            if let Entry::Rigid { slot, .. } = *e {
                for i in 0..d {
                    for j in 0..d {
                        let di: [f64; 3] = core::array::from_fn(|k| {
                            if k < d {
                                x[d * (slot + 1 + i) + k]
                            } else {
                                0.0
                            }
                        });
                        let dj: [f64; 3] = core::array::from_fn(|k| {
                            if k < d {
                                x[d * (slot + 1 + j) + k]
                            } else {
                                0.0
                            }
                        });
                        let want = if i == j { 1.0 } else { 0.0 };
                        worst = worst.max((dot(di, dj) - want).abs());
                    }
                }
            }
        }
        worst
    }
}

fn check_mass(mass: f64) -> Result<(), SetupError> {
    if mass > 0.0 && mass.is_finite() {
        Ok(())
    } else {
        Err(SetupError::InvalidParameter {
            name: "mass".to_owned(),
            value: mass,
            requirement: "positive and finite",
        })
    }
}

impl Multibody {
    /// In a planar model, `v`'s normal component must be zero.
    fn check_in_plane(&self, name: &str, v: [f64; 3]) -> Result<(), SetupError> {
        if self.dim == 2 && v[2] != 0.0 {
            return Err(SetupError::InvalidParameter {
                name: name.to_owned(),
                value: v[2],
                requirement: "in the plane (z = 0) in a planar model",
            });
        }
        Ok(())
    }
}

fn check_finite(name: &str, v: &[f64; 3]) -> Result<(), SetupError> {
    match v.iter().find(|x| !x.is_finite()) {
        Some(&bad) => Err(SetupError::InvalidParameter {
            name: name.to_owned(),
            value: bad,
            requirement: "finite",
        }),
        None => Ok(()),
    }
}
