//! The effects a scene may declare, one file each: its table in the scene file (the serde
//! struct), its checks, the term it assembles and that term's value, gradient and Hessian
//! product (a potential) or its per-body coefficients (a term of `M`), and its switch.
//!
//! **Adding an effect** is one new file here and one line in the `effects!` list below (two
//! for a potential that brings a new kind of term: its line in `potentials!` too). The file
//! implements `Effect` for its spec; a potential term implements `PotentialOps`. Terms of
//! `M` (damping, the magnetic field) add per-body coefficients that the model merges, because
//! their flows do not commute: the kinetic flow under all of them is solved at once in closed
//! form (`model/flight.rs`).

// Per-coordinate loops `for k in 0..d` index several arrays at once (q, p, a 3-vector).
#![allow(clippy::needless_range_loop)]

mod coordinate;
mod damping;
mod dashpot;
mod gravity;
mod hinge_damper;
mod hinge_limit;
mod line_damper;
mod magnetic;
mod pair;
mod radial;
mod slider_damper;
mod slider_limit;
mod slider_spring;
mod spring;
mod torsion;
mod trap;

pub use damping::DampingSpec;
pub(crate) use damping::dissipated_power;
pub use dashpot::DashpotSpec;
pub use gravity::GravitySpec;
pub use hinge_damper::HingeDamperSpec;
pub use hinge_limit::HingeLimitSpec;
pub use line_damper::LineDamperSpec;
pub use magnetic::MagneticSpec;
pub use pair::{MAX_PAIRS, PairSpec};
pub use slider_damper::SliderDamperSpec;
pub use slider_limit::SliderLimitSpec;
pub use slider_spring::SliderSpringSpec;
pub use spring::SpringSpec;
pub use torsion::TorsionSpringSpec;
pub use trap::TrapSpec;

use crate::real::Real;
use crate::scene::bodies::Bodies;
use crate::scene::counter::Counter;
use crate::scene::error::FieldPath;
use crate::scene::names::Flag;
use crate::scene::validate::Result;
use serde::Deserialize;

/// What the effects of a scene assemble into, and what they read from it.
pub(crate) struct Assembler<'a> {
    /// The scene's bodies (selection by name, masses, charges, initial positions).
    pub(crate) bodies: &'a Bodies,
    /// Dimension of the space.
    pub(crate) dim: usize,
    /// Damping coefficient `c_b` per body, summed over the damping effects that are on.
    pub(crate) damping: Vec<f64>,
    /// Labels of the damping effects that are on.
    pub(crate) damping_labels: Vec<String>,
    /// `e_b B` per body, summed over the magnetic effects that are on.
    pub(crate) magnetic: Vec<[f64; 3]>,
    /// Labels of the magnetic effects that are on.
    pub(crate) magnetic_labels: Vec<String>,
    /// `(a, b, c)` per dashpot that is on with `c > 0`.
    pub(crate) dashpots: Vec<(usize, usize, f64)>,
    /// Labels of the dashpots that are on.
    pub(crate) dashpot_labels: Vec<String>,
    /// `(coordinate, c)` per hinge or slider damper that is on with `c > 0`.
    pub(crate) hinge_dampers: Vec<(crate::rigid::Coordinate, f64)>,
    /// Labels of the hinge and slider dampers that are on.
    pub(crate) hinge_damper_labels: Vec<String>,
}

/// What an effect file provides for its table in the scene file (whose struct also has the
/// label in summaries, `name: Option<String>`, read by the `effects!` list).
pub(crate) trait Effect {
    /// Its switch in `[flags]`.
    const FLAG: Flag;
    /// Checks the declaration (also when it is switched off: a flag must not hide an error in
    /// the file) and returns its potential term, or, when `on`, adds its per-body coefficients
    /// to `cx` (a term of `M`) and returns `None`.
    fn assemble(
        &self,
        cx: &mut Assembler<'_>,
        path: &FieldPath,
        label: &str,
        on: bool,
    ) -> Result<Option<Potential<f64>>>;
}

/// The computations of a potential term `V_term(q)` on positions `q` (length `d N`).
pub(crate) trait PotentialOps<T: Real> {
    /// `V_term(q)`.
    fn energy(&self, q: &[T], d: usize) -> T;
    /// `V_term(q') − V_term(q)`; a term may sum per-part differences (no cancellation of the
    /// two totals, fewer transcendental evaluations).
    fn energy_difference(&self, q: &[T], q2: &[T], d: usize) -> T {
        self.energy(q2, d) - self.energy(q, d)
    }
    /// `out += α ∇V_term(q)`.
    fn gradient_add(&self, q: &[T], d: usize, alpha: T, out: &mut [T]);
    /// `out += ∇²V_term(q) v`.
    fn hessian_apply_add(&self, q: &[T], d: usize, v: &[T], out: &mut [T]);
    /// `true` if `V_term` is at most quadratic in `q` (its Hessian is constant).
    fn is_quadratic(&self) -> bool;
    /// Appends the body pairs `(a, b)` whose `d × d` block of `∇²V_term` can be non-zero.
    fn hessian_bodies(&self, out: &mut Vec<(usize, usize)>);
}

/// Declares the effects: the `type`s of `[[effects]]` tables ([`EffectSpec`]), the kinds of
/// terms in summaries ([`EffectKind`]), and the dispatch from a spec to its file.
macro_rules! effects {
    ($( $(#[doc = $doc:literal])* $Variant:ident($module:ident::$Spec:ident) = $name:literal, )+) => {
        /// A term of the Hamiltonian or of the structure matrix, by `type`.
        #[derive(Debug, Clone, PartialEq, Deserialize)]
        #[serde(tag = "type")]
        pub enum EffectSpec {
            $( $(#[doc = $doc])* #[serde(rename = $name)] $Variant($module::$Spec), )+
        }

        /// What kind of physics a term is.
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
        #[non_exhaustive]
        pub enum EffectKind {
            /// The kinetic energy `Σ |p|²/2m` and its flow (the drift).
            Kinetic,
            $( $(#[doc = $doc])* $Variant, )+
            /// The holonomic constraints.
            Constraints,
        }

        impl EffectKind {
            /// The name used in scene files and summaries.
            pub fn name(self) -> &'static str {
                match self {
                    EffectKind::Kinetic => "kinetic",
                    $( EffectKind::$Variant => $name, )+
                    EffectKind::Constraints => "constraints",
                }
            }
        }

        impl EffectSpec {
            /// The kind of term it declares.
            pub fn kind(&self) -> EffectKind {
                match self {
                    $( EffectSpec::$Variant(_) => EffectKind::$Variant, )+
                }
            }
            /// Its switch in `[flags]`.
            pub fn flag(&self) -> Flag {
                match self {
                    $( EffectSpec::$Variant(_) => <$module::$Spec as Effect>::FLAG, )+
                }
            }
            /// Its `name`, if the file gives one.
            pub fn label(&self) -> Option<&String> {
                match self {
                    $( EffectSpec::$Variant(s) => s.name.as_ref(), )+
                }
            }
            pub(crate) fn assemble(
                &self,
                cx: &mut Assembler<'_>,
                path: &FieldPath,
                label: &str,
                on: bool,
            ) -> Result<Option<Potential<f64>>> {
                match self {
                    $( EffectSpec::$Variant(s) => s.assemble(cx, path, label, on), )+
                }
            }
        }
    };
}

effects! {
    /// Uniform gravity `V = −Σ m_b g · q_b`.
    Gravity(gravity::GravitySpec) = "gravity",
    /// A spring between two bodies, `V = k/2 (|q_a − q_b| − L)²`.
    Spring(spring::SpringSpec) = "spring",
    /// A torsion spring about a hinge's axis between rigid bodies, `V = k/2 (θ − θ₀)²`.
    TorsionSpring(torsion::TorsionSpringSpec) = "torsion-spring",
    /// A hinge's stops as one-sided springs, `V = k/2 (θ − θ_max)²` past the upper one, `k/2 (θ_min − θ)²` past the lower.
    HingeLimit(hinge_limit::HingeLimitSpec) = "hinge-limit",
    /// A spring along a slider's axis between rigid bodies, `V = k/2 (d − d₀)²`.
    SliderSpring(slider_spring::SliderSpringSpec) = "slider-spring",
    /// A slider's stops as one-sided springs, `V = k/2 (d − d_max)²` past the upper one, `k/2 (d_min − d)²` past the lower.
    SliderLimit(slider_limit::SliderLimitSpec) = "slider-limit",
    /// A pair potential between every two bodies of a group.
    Pair(pair::PairSpec) = "pair",
    /// A harmonic trap `V = k/2 Σ |q_b − c|²`.
    Trap(trap::TrapSpec) = "trap",
    /// Viscous damping of the momenta, `p_b' = … − c v_b`: the `R` of `M = J − R`.
    Damping(damping::DampingSpec) = "damping",
    /// A dashpot between two bodies, `p_a' = … − c (v_a − v_b)`: a term of `R` on the relative velocity.
    Dashpot(dashpot::DashpotSpec) = "dashpot",
    /// A damper on a hinge's angle between rigid bodies, the torque `−c θ'`: a term of `R` along the constraint-consistent direction.
    HingeDamper(hinge_damper::HingeDamperSpec) = "hinge-damper",
    /// A damper on a slider's displacement between rigid bodies, the force `−c d'`: a term of `R` along the constraint-consistent direction.
    SliderDamper(slider_damper::SliderDamperSpec) = "slider-damper",
    /// A damper along the line between two bodies' points, the force `−c r'`: a spring-damper element's damper, along the constraint-consistent direction.
    LineDamper(line_damper::LineDamperSpec) = "line-damper",
    /// A uniform magnetic field on charged bodies, `p_b' = … + e_b v_b × B`: a non-canonical `J`.
    Magnetic(magnetic::MagneticSpec) = "magnetic",
}

/// Declares the kinds of potential terms ([`Potential`]) and dispatches their computations
/// and their change of scalar to the effect files.
macro_rules! potentials {
    ($( $(#[doc = $doc:literal])* $Variant:ident($module:ident::$Term:ident), )+) => {
        /// A position-dependent potential term.
        #[derive(Debug, Clone, PartialEq)]
        pub(crate) enum Potential<T = f64> {
            $( $(#[doc = $doc])* $Variant($module::$Term<T>), )+
        }

        impl<T: Real> Potential<T> {
            /// `V_term(q)`.
            #[inline]
            pub(crate) fn energy(&self, q: &[T], d: usize) -> T {
                match self {
                    $( Potential::$Variant(p) => p.energy(q, d), )+
                }
            }
            /// `V_term(q') − V_term(q)`.
            #[inline]
            pub(crate) fn energy_difference(&self, q: &[T], q2: &[T], d: usize) -> T {
                match self {
                    $( Potential::$Variant(p) => p.energy_difference(q, q2, d), )+
                }
            }
            /// `out += α ∇V_term(q)`.
            #[inline]
            pub(crate) fn gradient_add(&self, q: &[T], d: usize, alpha: T, out: &mut [T]) {
                match self {
                    $( Potential::$Variant(p) => p.gradient_add(q, d, alpha, out), )+
                }
            }
            /// `out += ∇²V_term(q) v`.
            #[inline]
            pub(crate) fn hessian_apply_add(&self, q: &[T], d: usize, v: &[T], out: &mut [T]) {
                match self {
                    $( Potential::$Variant(p) => p.hessian_apply_add(q, d, v, out), )+
                }
            }
        }

        impl<T: Real> Potential<T> {
            /// `true` if the term is at most quadratic in `q`.
            pub(crate) fn is_quadratic(&self) -> bool {
                match self {
                    $( Potential::$Variant(p) => PotentialOps::<T>::is_quadratic(p), )+
                }
            }
            /// The body pairs whose block of the term's Hessian can be non-zero.
            pub(crate) fn hessian_bodies(&self, out: &mut Vec<(usize, usize)>) {
                match self {
                    $( Potential::$Variant(p) => PotentialOps::<T>::hessian_bodies(p, out), )+
                }
            }
        }

        impl Potential<f64> {
            /// The same term in the scalar `U` (every parameter rounded to `U`).
            pub(crate) fn with_scalar<U: Real>(&self) -> Potential<U> {
                match self {
                    $( Potential::$Variant(p) => Potential::$Variant(p.with_scalar()), )+
                }
            }
        }
    };
}

potentials! {
    /// `V = −Σ_b m_b g · q_b`.
    Gravity(gravity::Gravity),
    /// `Σ φ(|q_a − q_b|)` over listed pairs (springs and pair potentials).
    Pairs(radial::Pairs),
    /// `k/2 Σ_b |q_b − c|²`.
    Trap(trap::Trap),
    /// `k/2 (θ − θ₀)²` on a hinge's angle.
    Torsion(torsion::Torsion),
    /// `k/2` times the squared overshoot of a hinge's angle past its stops.
    HingeLimit(hinge_limit::HingeLimit),
    /// `k/2 (d − d₀)²` on a slider's displacement.
    SliderSpring(slider_spring::SliderSpring),
}

/// A declared term of `V` with its label and counter.
#[derive(Debug)]
pub(crate) struct PotentialTerm<T = f64> {
    pub(crate) label: String,
    pub(crate) kind: EffectKind,
    pub(crate) potential: Potential<T>,
    pub(crate) counter: Counter,
}

impl<T> PotentialTerm<T> {
    /// `true` for uniform gravity (a constant force per body).
    pub(crate) fn is_gravity(&self) -> bool {
        matches!(self.potential, Potential::Gravity(_))
    }
}
