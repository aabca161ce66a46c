//! Andrews' squeezing mechanism (feature `autodiff`): seven rigid bodies in the plane, six
//! holonomic constraints, a position-dependent mass matrix, driven by a constant torque — the
//! index-3 problem of the IVP test set (Mazzia & Iavernaro, Bari; problem `andrews`, after
//! Schiehlen, *Multibody Systems Handbook*, 1990; Hairer & Wanner, *Solving ODEs II*, §VII.7).
//!
//! In Hamiltonian form, `q = (β, Θ, γ, Φ, δ, Ω, ε)` and `p = M(q) q'`:
//!
//! ```text
//! H(q, p) = ½ pᵀ M(q)⁻¹ p + U(q),   U = −mom · β + c₀ (ℓ(γ) − l₀)² / 2,   g(q) = 0 (6 rows),
//! ```
//!
//! with the test set's `M(q)` (block diagonal: `{β, Θ}`, `{γ}`, `{Φ, δ}`, `{Ω, ε}`), spring
//! length `ℓ(γ)` and loop-closure constraints `g`; its force vector `f(q, q')` (torque, spring
//! and the velocity-quadratic terms) is `−∂H/∂q` written in `q'`. `H` has no closed-form drift,
//! so the scheme is the projection around the implicit midpoint rule, and every derivative
//! comes from [`autodiff`](crate::autodiff) elements: one per block of `M` (reading its angle
//! and momenta), one each for the torque and the spring, one per constraint row.

use crate::autodiff::{AdConstraint, AdHamiltonian, DualNum, Element};
use crate::system::{Canonical, System};
use crate::vector::Vector;

/// The test set's parameters (`andrews.f`, common block `andcom`; SI units).
#[allow(missing_docs)]
pub mod p {
    pub const M1: f64 = 0.04325;
    pub const M2: f64 = 0.00365;
    pub const M3: f64 = 0.02373;
    pub const M4: f64 = 0.00706;
    pub const M5: f64 = 0.07050;
    pub const M6: f64 = 0.00706;
    pub const M7: f64 = 0.05498;
    pub const XA: f64 = -0.06934;
    pub const YA: f64 = -0.00227;
    pub const XB: f64 = -0.03635;
    pub const YB: f64 = 0.03273;
    pub const XC: f64 = 0.014;
    pub const YC: f64 = 0.072;
    pub const C0: f64 = 4530.0;
    pub const I1: f64 = 2.194e-6;
    pub const I2: f64 = 4.410e-7;
    pub const I3: f64 = 5.255e-6;
    pub const I4: f64 = 5.667e-7;
    pub const I5: f64 = 1.169e-5;
    pub const I6: f64 = 5.667e-7;
    pub const I7: f64 = 1.912e-5;
    pub const D: f64 = 28e-3;
    pub const DA: f64 = 115e-4;
    pub const E: f64 = 2e-2;
    pub const EA: f64 = 1421e-5;
    pub const RR: f64 = 7e-3;
    pub const RA: f64 = 92e-5;
    pub const L0: f64 = 7785e-5;
    pub const SS: f64 = 35e-3;
    pub const SA: f64 = 1874e-5;
    pub const SB: f64 = 1043e-5;
    pub const SC: f64 = 18e-3;
    pub const SD: f64 = 2e-2;
    pub const TA: f64 = 2308e-5;
    pub const TB: f64 = 916e-5;
    pub const U: f64 = 4e-2;
    pub const UA: f64 = 1228e-5;
    pub const UB: f64 = 449e-5;
    pub const ZF: f64 = 2e-2;
    pub const ZT: f64 = 4e-2;
    pub const FA: f64 = 1421e-5;
    pub const MOM: f64 = 33e-3;
}

/// A 2×2 block `[[a, b], [b, c]]` of `M` and `½ pᵀ B⁻¹ p`.
fn half_inverse_form<T: DualNum<Primitive = f64> + Copy>(a: T, b: T, c: T, p0: T, p1: T) -> T {
    let det = a * c - b * b;
    (c * p0 * p0 - b * p0 * p1 * 2.0 + a * p1 * p1) / (det * 2.0)
}

/// The blocks of `M(q)` that depend on an angle: `(m₁₁, m₂₁, m₂₂)` of `{β, Θ}` at `Θ`.
fn block_beta<T: DualNum<Primitive = f64> + Copy>(theta: T) -> (T, T, T) {
    use p::*;
    let c = theta.cos();
    (
        c * (-2.0 * M2 * DA * RR) + (M1 * RA * RA + M2 * (RR * RR + DA * DA) + I1 + I2),
        c * (-M2 * DA * RR) + (M2 * DA * DA + I2),
        T::from(M2 * DA * DA + I2),
    )
}

/// `(m₄₄, m₅₄, m₅₅)` of `{Φ, δ}` at `Φ`.
fn block_phi<T: DualNum<Primitive = f64> + Copy>(phi: T) -> (T, T, T) {
    use p::*;
    let s = phi.sin();
    let ee = E - EA;
    (
        T::from(M4 * ee * ee + I4),
        s * (M4 * ZT * ee) + (M4 * ee * ee + I4),
        s * (2.0 * M4 * ZT * ee) + (M4 * (ZT * ZT + ee * ee) + M5 * (TA * TA + TB * TB) + I4 + I5),
    )
}

/// `(m₆₆, m₇₆, m₇₇)` of `{Ω, ε}` at `Ω`.
fn block_omega<T: DualNum<Primitive = f64> + Copy>(omega: T) -> (T, T, T) {
    use p::*;
    let s = omega.sin();
    let zz = ZF - FA;
    (
        T::from(M6 * zz * zz + I6),
        s * (-M6 * U * zz) + (M6 * zz * zz + I6),
        s * (-2.0 * M6 * U * zz) + (M6 * (zz * zz + U * U) + M7 * (UA * UA + UB * UB) + I6 + I7),
    )
}

/// One term of `H`, reading three coordinates (unused ones repeat an index).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Term {
    /// `½ (p_β, p_Θ) B(Θ)⁻¹ (p_β, p_Θ)ᵀ`, reading `(Θ, p_β, p_Θ)`.
    BetaTheta,
    /// `p_γ² / (2 m₃₃)`, reading `(p_γ, ·, ·)`.
    Gamma,
    /// `{Φ, δ}`, reading `(Φ, p_Φ, p_δ)`.
    PhiDelta,
    /// `{Ω, ε}`, reading `(Ω, p_Ω, p_ε)`.
    OmegaEpsilon,
    /// The driving torque's potential `−mom · β`, reading `(β, ·, ·)`.
    Torque,
    /// The spring's potential `c₀ (ℓ(γ) − l₀)²/2`, reading `(γ, ·, ·)`.
    Spring,
}

impl Element<3> for Term {
    fn eval<T: DualNum<Primitive = f64> + Copy>(&self, x: [T; 3]) -> T {
        use p::*;
        match self {
            Term::BetaTheta => {
                let (a, b, c) = block_beta(x[0]);
                half_inverse_form(a, b, c, x[1], x[2])
            }
            Term::Gamma => x[0] * x[0] / (2.0 * (M3 * (SA * SA + SB * SB) + I3)),
            Term::PhiDelta => {
                let (a, b, c) = block_phi(x[0]);
                half_inverse_form(a, b, c, x[1], x[2])
            }
            Term::OmegaEpsilon => {
                let (a, b, c) = block_omega(x[0]);
                half_inverse_form(a, b, c, x[1], x[2])
            }
            Term::Torque => x[0] * (-MOM),
            Term::Spring => {
                let (s, c) = (x[0].sin(), x[0].cos());
                let xd = c * SD + s * SC + XB;
                let yd = s * SD - c * SC + YB;
                let (dx, dy) = (xd - XC, yd - YC);
                let stretch = (dx * dx + dy * dy).sqrt() - L0;
                stretch * stretch * (C0 / 2.0)
            }
        }
    }
}

/// One loop-closure row, reading `(β, Θ, a, b)` (rows 1–2: `a = b = γ`; rows 3–4: `Φ, δ`;
/// rows 5–6: `Ω, ε`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Closure(pub usize);

impl Element<4> for Closure {
    fn eval<T: DualNum<Primitive = f64> + Copy>(&self, x: [T; 4]) -> T {
        use p::*;
        let (beta, bt) = (x[0], x[0] + x[1]);
        let (a, b) = (x[2], x[3]);
        let cx = beta.cos() * RR - bt.cos() * D;
        let cy = beta.sin() * RR - bt.sin() * D;
        match self.0 {
            0 => cx - a.sin() * SS - XB,
            1 => cy + a.cos() * SS - YB,
            2 => cx - (a + b).sin() * E - b.cos() * ZT - XA,
            3 => cy + (a + b).cos() * E - b.sin() * ZT - YA,
            4 => cx - (a + b).cos() * ZF - b.sin() * U - XA,
            _ => cy - (a + b).sin() * ZF + b.cos() * U - YA,
        }
    }
}

/// The Hamiltonian.
pub type Energy = AdHamiltonian<Term, 3>;
/// The constraints.
pub type Closures = AdConstraint<Closure, 4>;

/// The model: canonical `J` on `x = (q, p) ∈ R¹⁴`, [`Energy`], [`Closures`].
pub fn system() -> System<Canonical, Energy, Closures> {
    let h = AdHamiltonian::new(vec![
        (Term::BetaTheta, [1, 7, 8]),
        (Term::Gamma, [9, 9, 9]),
        (Term::PhiDelta, [3, 10, 11]),
        (Term::OmegaEpsilon, [5, 12, 13]),
        (Term::Torque, [0, 0, 0]),
        (Term::Spring, [2, 2, 2]),
    ]);
    let g = AdConstraint::new(vec![
        (Closure(0), [0, 1, 2, 2]),
        (Closure(1), [0, 1, 2, 2]),
        (Closure(2), [0, 1, 3, 4]),
        (Closure(3), [0, 1, 3, 4]),
        (Closure(4), [0, 1, 5, 6]),
        (Closure(5), [0, 1, 5, 6]),
    ]);
    System::new(Canonical, h, g)
}

/// The test set's consistent initial state: the angles (given to 30 digits there) at rest.
pub fn initial_state<V: Vector<Real = f64>>() -> V {
    let q = [
        -0.061_713_890_014_276_45,
        0.0,
        0.455_279_819_163_070_4,
        0.222_668_390_165_885_9,
        0.487_364_979_543_842_55,
        -0.222_668_390_165_885_9,
        1.230_547_444_549_821_2,
    ];
    let mut x = V::zeros(14);
    x.as_mut_slice()[..7].copy_from_slice(&q);
    x
}

/// The test set's reference at `t = 0.03` (`andsoln`, PSIDE at tolerance 1e-14): the angles
/// `q` and the angular velocities `q'`.
#[allow(clippy::excessive_precision)]
pub const REFERENCE: [f64; 14] = [
    0.1581077119629904e2,
    -0.1575637105984298e2,
    0.4082224013073101e-1,
    -0.5347301163226948,
    0.5244099658805304,
    0.5347301163226948,
    0.1048080741042263e1,
    0.1139920302151208e4,
    -0.1424379294994111e4,
    0.1103291221937134e2,
    0.1929337464421385e2,
    0.5735699284790808,
    -0.1929337464421385e2,
    0.3231791658026955,
];

/// The angular velocities `q' = M(q)⁻¹ p` of a state `x = (q, p)`.
pub fn velocities(x: &[f64]) -> [f64; 7] {
    let (q, p) = x.split_at(7);
    let solve = |(a, b, c): (f64, f64, f64), p0: f64, p1: f64| {
        let det = a * c - b * b;
        ((c * p0 - b * p1) / det, (a * p1 - b * p0) / det)
    };
    let (v0, v1) = solve(block_beta(q[1]), p[0], p[1]);
    let v2 = p[2] / (p::M3 * (p::SA * p::SA + p::SB * p::SB) + p::I3);
    let (v3, v4) = solve(block_phi(q[3]), p[3], p[4]);
    let (v5, v6) = solve(block_omega(q[5]), p[5], p[6]);
    [v0, v1, v2, v3, v4, v5, v6]
}

/// What [`run`] measured.
#[derive(Debug, Clone, PartialEq)]
pub struct Run {
    /// `(q, q')` at `t = 0.03`, comparable with [`REFERENCE`].
    pub end: [f64; 14],
    /// `max |g|` over the run.
    pub max_g: f64,
    /// `H` at the start and at the end (with the torque's potential).
    pub energy: (f64, f64),
    /// The most Newton iterations one step took.
    pub newton_max: u64,
}

/// The projection around the implicit midpoint rule from [`initial_state`] to `t = 0.03` in
/// `steps` steps.
pub fn run(steps: usize) -> Result<Run, String> {
    use crate::flow::{Flow, FlowExt, ImplicitMidpoint, ProjectionOptions};
    use crate::nonlinear::NewtonOptions;
    use crate::system::{Hamiltonian, HolonomicConstraint};
    type V = nalgebra::SVector<f64, 14>;
    let setup = |e: crate::error::SetupError| format!("refused: {e}");
    let x0: V = initial_state();
    let s = system();
    let mid = ImplicitMidpoint::<V, _, _>::try_new(
        Canonical,
        s.hamiltonian.clone(),
        &x0,
        NewtonOptions::default(),
    )
    .map_err(setup)?;
    let mut flow = mid
        .projected(system(), &x0, ProjectionOptions::default())
        .map_err(setup)?;
    let h = 0.03 / steps as f64;
    let (mut g, mut max_g) = ([0.0; 6], 0.0f64);
    let (mut newton_prev, mut newton_max) = (0, 0);
    let mut stepper =
        crate::Stepper::new(&mut flow, x0, 0.0, h).map_err(|e| format!("refused: {e}"))?;
    for k in 0..steps {
        stepper
            .step()
            .map_err(|e| format!("typed error at step {k}: {e}"))?;
        let n = stepper.flow().stats().newton_iterations;
        newton_max = newton_max.max(n - newton_prev);
        newton_prev = n;
        s.constraint.residual(stepper.state(), &mut g);
        max_g = g.iter().fold(max_g, |a, v| a.max(v.abs()));
    }
    let x = *stepper.state();
    let mut end = [0.0; 14];
    end[..7].copy_from_slice(&x.as_slice()[..7]);
    end[7..].copy_from_slice(&velocities(x.as_slice()));
    Ok(Run {
        end,
        max_g,
        energy: (s.hamiltonian.energy(&x0), s.hamiltonian.energy(&x)),
        newton_max,
    })
}
