//! Bricard's mechanism (IFToMM multibody benchmark A04; Bricard 1897): five rods of length
//! 1 m, mass 1 kg and square section 0.1 m, joined in a closed loop with the ground by six
//! revolute joints, under gravity 9.81 m/s² along `−y`. Grübler's count gives
//! `6·5 − 5·6 = 0` degrees of freedom; the orientation of the joint axes gives the linkage one.
//! Its constraint equations are therefore redundant everywhere along the motion: the case
//! [`DropDependent`] exists for.
//!
//! Geometry (the benchmark's initial position, as in the public simEngine3D driver of A04):
//! the loop runs along the edges of the unit cube,
//!
//! ```text
//! O = (0,0,0) → P₁ = (1,0,0) → P₂ = (1,−1,0) → P₃ = (1,−1,1) → P₄ = (0,−1,1) → P₅ = (0,0,1) → O,
//! ```
//!
//! the ground being the segment `P₅O`, and each joint axis is perpendicular to both rods it
//! joins (`y` at `O`, `z` at `P₁`, `x` at `P₂`, `y` at `P₃`, `z` at `P₄`, `x` at `P₅`), so each
//! rod's two axes are perpendicular to it and to each other. The mechanism starts from rest.
//!
//! **Natural coordinates** (García de Jalón & Bayo, *Kinematic and Dynamic Simulation of
//! Multibody Systems*, Springer 1994, ch. 2–3): the moving joint points `P₁ … P₄` and the unit
//! vectors `u₁ … u₄` of their axes, `q ∈ R²⁴`; `O`, `P₅`, `u₀ = y`, `u₅ = x` are fixed. Rod `k`
//! from `A` to `B` with axes `a` (at `A`) and `b` (at `B`) is rigid when
//!
//! ```text
//! (|B − A|² − 1)/2 = 0,  (B − A)·a = 0,  (B − A)·b = 0,  a·b = 0,  (|b|² − 1)/2 = 0,
//! ```
//!
//! and the revolute joints hold by construction (neighbours share the point and the axis):
//! 24 equations (the last rod's `b = u₅` is fixed) for 24 coordinates, of rank 23. A point of
//! the rod is `A + ξ₁(B − A) + ξ₂ a + ξ₃ b` with `ξ₁ ∈ [0, 1]` and `ξ₂, ξ₃` uniform on the
//! section, so the kinetic energy is constant-coefficient quadratic:
//! `T = ½ Σ_rods (|A'|²/3 + A'·B'/3 + |B'|²/3 + (s²/12)(|a'|² + |b'|²))` — the points' mass
//! matrix is tridiagonal (`2/3` on the diagonal, `1/6` beside it), each axis vector weighs
//! `2 s²/12 = 1/600`. With `p = M q'`,
//!
//! ```text
//! H = ½ pᵀ M⁻¹ p + g Σᵢ Pᵢ,y
//! ```
//!
//! (each moving point carries half of each rod at it). The exact flows are the drift
//! `q += h M⁻¹ p` and the constant kick `p_{Pᵢ,y} −= h g`: RATTLE with a constant,
//! non-diagonal mass matrix, as for the N-four-bar ([`four_bar`](super::four_bar)).

use crate::error::{SetupError, StepError};
use crate::flow::{Coupling, Flow, FlowExt, FnFlow, ProjectionOptions, from_fn};
use crate::nonlinear::NewtonOptions;
use crate::system::{Canonical, Case, DropDependent, Hamiltonian, HolonomicConstraint, System};
use crate::vector::Vector;

/// Gravity of the benchmark, m/s².
pub const GRAVITY: f64 = 9.81;
/// Side of the rods' square section, m.
pub const SECTION: f64 = 0.1;
/// The coordinates: 4 points and 4 axis vectors of 3 components.
pub const NQ: usize = 24;
/// The state length (positions and momenta).
pub const STATE_LEN: usize = 2 * NQ;
/// Rows of [`Joints`]: five per rod, four for the last (its far axis is fixed).
pub const ROWS: usize = 24;

/// Mass of an axis vector: `s²/12` from each of its two rods.
const AXIS_MASS: f64 = 2.0 * SECTION * SECTION / 12.0;

/// The fixed points `O` (slot 0) and `P₅` (slot 5), and the fixed axes `u₀` and `u₅`.
const FIXED_POINTS: [[f64; 3]; 2] = [[0.0, 0.0, 0.0], [0.0, 0.0, 1.0]];
const FIXED_AXES: [[f64; 3]; 2] = [[0.0, 1.0, 0.0], [1.0, 0.0, 0.0]];

/// The mechanism's Hamiltonian (its constraints are [`Joints`]).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Bricard;

/// The 24 rigid-rod equations of [`Bricard`] in natural coordinates (rank 23: wrap them in
/// [`DropDependent`] to run).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Joints;

/// A 3-vector of the model: `P_b − P_a` (points, slots 0…5) or the axis `u_k` (slots 0…5).
#[derive(Debug, Clone, Copy)]
enum Vec3 {
    Rod(usize, usize),
    Axis(usize),
}

/// One constraint row.
#[derive(Debug, Clone, Copy)]
enum Row {
    /// `(|v|² − 1)/2`.
    Unit(Vec3),
    /// `v·w`.
    Dot(Vec3, Vec3),
}

/// The rows, rod by rod.
const fn rows() -> [Row; ROWS] {
    let mut out = [Row::Unit(Vec3::Axis(0)); ROWS];
    let mut r = 0;
    let mut k = 0;
    while k < 5 {
        let rod = Vec3::Rod(k, k + 1);
        let (a, b) = (Vec3::Axis(k), Vec3::Axis(k + 1));
        out[r] = Row::Unit(rod);
        out[r + 1] = Row::Dot(rod, a);
        out[r + 2] = Row::Dot(rod, b);
        out[r + 3] = Row::Dot(a, b);
        r += 4;
        if k < 4 {
            out[r] = Row::Unit(b);
            r += 1;
        }
        k += 1;
    }
    out
}
const ROW_LIST: [Row; ROWS] = rows();

/// Index of point slot `i` (1…4) or axis slot `k` (1…4) in `q`; `None` for the fixed ones.
fn point_index(i: usize) -> Option<usize> {
    (1..=4).contains(&i).then(|| 3 * (i - 1))
}
fn axis_index(k: usize) -> Option<usize> {
    (1..=4).contains(&k).then(|| 12 + 3 * (k - 1))
}

fn point(q: &[f64], i: usize) -> [f64; 3] {
    match point_index(i) {
        Some(j) => [q[j], q[j + 1], q[j + 2]],
        None => FIXED_POINTS[(i == 5) as usize],
    }
}
fn axis(q: &[f64], k: usize) -> [f64; 3] {
    match axis_index(k) {
        Some(j) => [q[j], q[j + 1], q[j + 2]],
        None => FIXED_AXES[(k == 5) as usize],
    }
}

/// The value of `v` at `q`.
fn value(q: &[f64], v: Vec3) -> [f64; 3] {
    match v {
        Vec3::Rod(a, b) => {
            let (pa, pb) = (point(q, a), point(q, b));
            [pb[0] - pa[0], pb[1] - pa[1], pb[2] - pa[2]]
        }
        Vec3::Axis(k) => axis(q, k),
    }
}

/// The derivative of `v` along the coordinate direction `dq` (fixed slots do not move).
fn tangent(dq: &[f64], v: Vec3) -> [f64; 3] {
    let at = |j: Option<usize>| j.map_or([0.0; 3], |j| [dq[j], dq[j + 1], dq[j + 2]]);
    match v {
        Vec3::Rod(a, b) => {
            let (da, db) = (at(point_index(a)), at(point_index(b)));
            [db[0] - da[0], db[1] - da[1], db[2] - da[2]]
        }
        Vec3::Axis(k) => at(axis_index(k)),
    }
}

/// `out += c · ∂v/∂q` (the transpose of [`tangent`]).
fn scatter(out: &mut [f64], v: Vec3, c: [f64; 3]) {
    let mut add = |j: Option<usize>, s: f64| {
        if let Some(j) = j {
            for d in 0..3 {
                out[j + d] += s * c[d];
            }
        }
    };
    match v {
        Vec3::Rod(a, b) => {
            add(point_index(b), 1.0);
            add(point_index(a), -1.0);
        }
        Vec3::Axis(k) => add(axis_index(k), 1.0),
    }
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

impl<V: Vector<Real = f64>> HolonomicConstraint<V> for Joints {
    fn dim(&self) -> usize {
        ROWS
    }
    fn residual(&self, x: &V, out: &mut [f64]) {
        let q = &x.as_slice()[..NQ];
        for (o, row) in out.iter_mut().zip(&ROW_LIST) {
            *o = match *row {
                Row::Unit(v) => {
                    let v = value(q, v);
                    (dot(v, v) - 1.0) * 0.5
                }
                Row::Dot(v, w) => dot(value(q, v), value(q, w)),
            };
        }
    }
    fn jacobian_apply(&self, x: &V, v: &V, out: &mut [f64]) {
        let (q, dq) = (&x.as_slice()[..NQ], &v.as_slice()[..NQ]);
        for (o, row) in out.iter_mut().zip(&ROW_LIST) {
            *o = match *row {
                Row::Unit(a) => dot(value(q, a), tangent(dq, a)),
                Row::Dot(a, b) => {
                    dot(tangent(dq, a), value(q, b)) + dot(value(q, a), tangent(dq, b))
                }
            };
        }
    }
    fn jacobian_transpose_apply_add(&self, x: &V, mu: &[f64], alpha: f64, out: &mut V) {
        let q = &x.as_slice()[..NQ];
        let o = &mut out.as_mut_slice()[..NQ];
        let scaled = |v: [f64; 3], s: f64| [s * v[0], s * v[1], s * v[2]];
        for (&m, row) in mu.iter().zip(&ROW_LIST) {
            let s = alpha * m;
            match *row {
                Row::Unit(a) => scatter(o, a, scaled(value(q, a), s)),
                Row::Dot(a, b) => {
                    scatter(o, a, scaled(value(q, b), s));
                    scatter(o, b, scaled(value(q, a), s));
                }
            }
        }
    }
}

impl Bricard {
    /// The constraints with the dependent row dropped (in this row order the last one, the
    /// last rod's `u₄·u₅ = u₄·x = 0`), chosen at the benchmark's initial position.
    pub fn constraint() -> Result<DropDependent<Joints, f64>, SetupError> {
        let x0: faer::Col<f64> = Self::initial_state();
        DropDependent::new(Joints, &x0, 1e-8)
    }

    /// The model as a [`System`] (canonical structure).
    pub fn system() -> Result<System<Canonical, Bricard, DropDependent<Joints, f64>>, SetupError> {
        Ok(System::new(Canonical, Bricard, Self::constraint()?))
    }

    /// The benchmark's initial position, at rest.
    pub fn initial_state<V: Vector<Real = f64>>() -> V {
        let mut x = V::zeros(STATE_LEN);
        let q = x.as_mut_slice();
        let values: [f64; NQ] = [
            1.0, 0.0, 0.0, // P1
            1.0, -1.0, 0.0, // P2
            1.0, -1.0, 1.0, // P3
            0.0, -1.0, 1.0, // P4
            0.0, 0.0, 1.0, // u1 = z
            1.0, 0.0, 0.0, // u2 = x
            0.0, 1.0, 0.0, // u3 = y
            0.0, 0.0, 1.0, // u4 = z
        ];
        q[..NQ].copy_from_slice(&values);
        x
    }

    /// `out = M⁻¹ p`: the points' tridiagonal `T = tridiag(1/6, 2/3, 1/6)` per axis (Thomas),
    /// the axis vectors' `1/AXIS_MASS`.
    fn solve(p: &[f64], out: &mut [f64]) {
        const DIAG: f64 = 2.0 / 3.0;
        const OFF: f64 = 1.0 / 6.0;
        for d in 0..3 {
            // Forward elimination over the 4 points, then back substitution.
            let (mut c, mut y) = ([0.0; 4], [0.0; 4]);
            let mut denom = DIAG;
            c[0] = OFF / denom;
            y[0] = p[d] / denom;
            for i in 1..4 {
                denom = DIAG - OFF * c[i - 1];
                c[i] = OFF / denom;
                y[i] = (p[3 * i + d] - OFF * y[i - 1]) / denom;
            }
            out[9 + d] = y[3];
            for i in (0..3).rev() {
                out[3 * i + d] = y[i] - c[i] * out[3 * (i + 1) + d];
            }
        }
        for (o, &v) in out[12..NQ].iter_mut().zip(&p[12..NQ]) {
            *o = v / AXIS_MASS;
        }
    }

    /// The exact drift `q += h M⁻¹ p`.
    pub fn drift<V: Vector<Real = f64>>() -> FnFlow<impl FnMut(f64, &mut V) + Copy> {
        from_fn(|h: f64, x: &mut V| {
            let (q, p) = x.as_mut_slice().split_at_mut(NQ);
            let mut v = [0.0; NQ];
            Self::solve(p, &mut v);
            for (qi, vi) in q.iter_mut().zip(&v) {
                *qi += h * vi;
            }
        })
    }

    /// The exact kick of gravity `p_{Pᵢ,y} −= h g`.
    pub fn kick<V: Vector<Real = f64>>() -> FnFlow<impl FnMut(f64, &mut V) + Copy> {
        from_fn(|h: f64, x: &mut V| {
            let p = &mut x.as_mut_slice()[NQ..];
            for i in 0..4 {
                p[3 * i + 1] -= h * GRAVITY;
            }
        })
        .kick()
    }

    /// RATTLE's options: the degenerate, decoupled case (position constraints, canonical `M`),
    /// residuals to a few ulps of the unit lengths.
    pub fn projection_options() -> ProjectionOptions<f64> {
        ProjectionOptions::default()
            .with_case(Case::Degenerate)
            .with_coupling(Coupling::Decoupled)
            .with_newton(NewtonOptions::default().with_ftol(16.0 * f64::EPSILON))
    }

    /// `P₃`, the point the benchmark reports, from a state.
    pub fn p3(x: &[f64]) -> [f64; 3] {
        [x[6], x[7], x[8]]
    }

    /// RATTLE (projected kick–drift–kick) from the initial position for `steps` steps of `h`,
    /// measuring the residuals (enforced and dropped rows), the energy error over the first and
    /// last tenth, and where `P₃` ends.
    pub fn run(h: f64, steps: usize) -> Result<BricardRun, SetupError> {
        type V = faer::Col<f64>;
        let x0: V = Self::initial_state();
        let constraint = Self::constraint()?;
        let mut flow = Self::rattle(&x0)?;
        let e0 = Hamiltonian::<V>::energy(&Bricard, &x0);
        let mut x = x0;
        let start = Self::p3(x.as_slice());
        let (mut max_dropped, mut p3_travel) = (0.0f64, 0.0f64);
        let t = super::tracked_run(
            &mut flow,
            &mut x,
            (h, steps),
            &constraint,
            &Bricard,
            |x: &V| {
                max_dropped = max_dropped.max(constraint.dropped_residual(x));
                let p3 = Self::p3(x.as_slice());
                let travel = (0..3)
                    .map(|d| (p3[d] - start[d]).powi(2))
                    .sum::<f64>()
                    .sqrt();
                p3_travel = p3_travel.max(travel);
            },
        );
        Ok(BricardRun {
            steps: t.steps,
            dropped: constraint.dropped().to_vec(),
            max_g: t.max_g,
            max_dropped,
            energy: e0,
            first_tenth: t.first_tenth,
            last_tenth: t.last_tenth,
            newton_max: t.newton_max,
            p3: Self::p3(x.as_slice()),
            p3_travel,
            error: t.error,
            finite: t.finite,
        })
    }

    /// RATTLE for the mechanism: the projected kick–drift–kick with the dependent row dropped,
    /// from `x0`.
    pub fn rattle<V: Vector<Real = f64>>(x0: &V) -> Result<impl Flow<V> + use<V>, SetupError> {
        Self::kick().strang(Self::drift()).projected(
            Self::system()?,
            x0,
            Self::projection_options(),
        )
    }
}

/// What [`Bricard::run`] measured.
#[derive(Debug, Clone, PartialEq)]
pub struct BricardRun {
    /// Steps taken (all of them, or up to the failing one).
    pub steps: usize,
    /// The rows of [`Joints`] that were dropped as dependent.
    pub dropped: Vec<usize>,
    /// `max |g|` over the enforced rows and the run.
    pub max_g: f64,
    /// `max |g|` over the dropped rows and the run.
    pub max_dropped: f64,
    /// `H(x₀)`.
    pub energy: f64,
    /// `max |H − H₀|` over the first and over the last tenth of the run.
    pub first_tenth: f64,
    /// See `first_tenth`.
    pub last_tenth: f64,
    /// The most Newton iterations one step took.
    pub newton_max: u64,
    /// `P₃` at the end.
    pub p3: [f64; 3],
    /// The farthest `P₃` got from where it started: the mechanism moved.
    pub p3_travel: f64,
    /// The step error that stopped the run, if one did (the state is then the last good one).
    pub error: Option<StepError>,
    /// The final state is finite.
    pub finite: bool,
}

impl<V: Vector<Real = f64>> Hamiltonian<V> for Bricard {
    fn energy(&self, x: &V) -> f64 {
        let (q, p) = x.as_slice().split_at(NQ);
        let mut v = [0.0; NQ];
        Self::solve(p, &mut v);
        let kinetic = 0.5 * p.iter().zip(&v).map(|(a, b)| a * b).sum::<f64>();
        kinetic + GRAVITY * (0..4).map(|i| q[3 * i + 1]).sum::<f64>()
    }
    fn gradient(&self, x: &V, out: &mut V) {
        let p = &x.as_slice()[NQ..];
        let (oq, op) = out.as_mut_slice().split_at_mut(NQ);
        oq.fill(0.0);
        for i in 0..4 {
            oq[3 * i + 1] = GRAVITY;
        }
        Self::solve(p, op);
    }
    /// `∇²H = diag(0, M⁻¹)`.
    fn hessian_apply(&self, _x: &V, v: &V, out: &mut V) -> bool {
        let vp = &v.as_slice()[NQ..];
        let (oq, op) = out.as_mut_slice().split_at_mut(NQ);
        oq.fill(0.0);
        Self::solve(vp, op);
        true
    }
    fn is_quadratic(&self) -> bool {
        true
    }
}
