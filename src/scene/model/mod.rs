//! The assembled model of a scene: the declared terms of `H` and of `M`, the declared
//! constraints, and the exact sub-flows they bring.
//!
//! ```text
//! x = (q, p),  q, p ∈ R^{dN} (body b at q[b·d .. b·d + d]),
//! H = Σ_b |p_b|²/(2 m_b) + Σ_terms V_term(q),
//! M = [[0, I], [−I, K − R]],  K_b v = e_b v × B (magnetic),  R_b = c_b I (damping),
//!     plus c (e_a − e_b)(e_a − e_b)ᵀ ⊗ I in R per dashpot between bodies a and b,
//! g = (g_1, …, g_m)(q).
//! ```
//!
//! A scene's potential terms depend on `q` only, so their flows commute and merge into one kick
//! `p ← p − h ∇V(q)` (exact). The kinetic term's flow under `M` is the free flight of each
//! body, `q' = v = p/m`, `p' = e v × B − c v`, linear and solved exactly: a drift, rotated about
//! `B` and damped by `e^{−c t/m}` only for the bodies that have a field or damping (see
//! [`SceneModel::free_flight`]). Undeclared effects have no term: no evaluation, no cost.

// Per-coordinate loops `for k in 0..d` index several arrays at once (q, p, a 3-vector).
#![allow(clippy::needless_range_loop)]

mod books;
mod consistent;
mod constraints;
mod dashpot;
mod flight;
mod hamiltonian;
mod hinge_damper;
mod potential;
mod reports;
mod scalar;
mod splitting;
mod structure;
mod terms;

pub use crate::scene::effects::EffectKind;
use crate::scene::effects::PotentialTerm;
pub(crate) use consistent::{consistent_account, consistent_momentum};
pub use dashpot::DashpotFlow;
pub(crate) use dashpot::Dashpots;
use flight::Flight;
pub use flight::{FlightCache, FreeFlight};
pub use hinge_damper::HingeDamperFlow;
pub(crate) use hinge_damper::HingeDampers;
pub use potential::{Kick, KickCache};
pub use splitting::{SceneKick, SceneSplitting};
pub(crate) use terms::{ConstraintTerm, StructureTerm};

use crate::real::Real;
pub(crate) use crate::scene::counter::Counter;
use std::time::Instant;

/// A scene's assembled model. It implements [`Hamiltonian`](crate::Hamiltonian),
/// [`StructureMatrix`](crate::StructureMatrix) and
/// [`HolonomicConstraint`](crate::HolonomicConstraint) with only the declared terms, and provides the exact sub-flows
/// ([`kick`](Self::kick), [`free_flight`](Self::free_flight)).
#[derive(Debug)]
pub struct SceneModel<T = f64> {
    pub(crate) dim: usize,
    pub(crate) masses: Vec<T>,
    pub(crate) inv_masses: Vec<T>,
    pub(crate) potentials: Vec<PotentialTerm<T>>,
    pub(crate) constraints: Vec<ConstraintTerm<T>>,
    pub(crate) m: usize,
    pub(crate) damping: Option<StructureTerm<T>>,
    /// A damping effect is declared and switched on but zero on every body: no term, and a
    /// run reports the energy it dissipated as 0, not as absent.
    pub(crate) zero_damping: bool,
    /// Dashpots between bodies (a term of `R` on relative velocities), when declared.
    pub(crate) dashpots: Option<Dashpots<T>>,
    /// Dampers on hinges' angles (their exact flows join the kick), when declared.
    pub(crate) hinge_dampers: Option<HingeDampers<T>>,
    /// The state's component names (`q.<body>.<axis>`, `p.<body>.<axis>`), for CSV columns.
    pub(crate) state_names: Vec<String>,
    /// One name per constraint row, for the multipliers' CSV columns.
    pub(crate) multiplier_names: Vec<String>,
    pub(crate) magnetic: Option<StructureTerm<[T; 3]>>,
    pub(crate) kinetic: Counter,
    /// Free flights: each evaluates the kinetic term, the damping, the field and gravity joined
    /// to it at once, and counts once here ([`SceneModel::flight_evaluations`]).
    pub(crate) flight_counter: Counter,
    pub(crate) constraint_counter: Counter,
    /// Time each evaluation (the `profile` diagnostic).
    pub(crate) profile: bool,
    /// Provide `jacobian_entries` (sparse multiplier systems); off for `m ≤ 4`, where the
    /// projection's small dense path is faster.
    pub(crate) sparse: bool,
    flights: Vec<Flight<T>>,
    /// Uniform gravity is part of the free flight (no magnetic term), not of the kick.
    gravity_in_flight: bool,
    /// The declared inputs (`None`: no input, no input sub-flow).
    pub(crate) inputs: Option<crate::scene::ports::SceneInputs<T>>,
    /// Whether the flows book the damping's energy (on unless the run reads no books).
    pub(crate) books: books::Books,
}

impl<T: Real> SceneModel<T> {
    /// Builds the model from its parts (the compiler has validated them).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn new(
        dim: usize,
        masses: Vec<T>,
        potentials: Vec<PotentialTerm<T>>,
        constraints: Vec<ConstraintTerm<T>>,
        damping: Option<StructureTerm<T>>,
        magnetic: Option<StructureTerm<[T; 3]>>,
        profile: bool,
    ) -> Self {
        let inv_masses: Vec<T> = masses.iter().map(|&m| T::one() / m).collect();
        let m = constraints.iter().map(|c| c.rows(dim)).sum();
        // Uniform gravity joins the free flight when no body turns in a field: the flow of
        // `T + V_gravity` under `M` is then still linear per body and solved exactly, so the
        // splitting loses a sub-flow and the free fall its splitting error.
        let gravity_in_flight = magnetic.is_none() && potentials.iter().any(|t| t.is_gravity());
        let mut forces = vec![[T::lit(0.0); 3]; masses.len()];
        if gravity_in_flight {
            for t in &potentials {
                if let crate::scene::effects::Potential::Gravity(g) = &t.potential {
                    g.add_forces(&mut forces);
                }
            }
        }
        let flights = (0..masses.len())
            .map(|b| {
                let c = damping.as_ref().map_or(T::lit(0.0), |t| t.per_body[b]);
                let eb = magnetic
                    .as_ref()
                    .map_or([T::lit(0.0); 3], |t| t.per_body[b]);
                let w = inv_masses[b];
                let force = forces[b];
                let forced = force != [T::lit(0.0); 3];
                match (c == T::lit(0.0), eb == [T::lit(0.0); 3], forced) {
                    (true, true, false) => Flight::Drift,
                    (true, true, true) => Flight::Fall { force },
                    (false, true, true) => Flight::DampedFall {
                        gamma: c * w,
                        force,
                    },
                    _ => Flight::Exact {
                        gamma: c * w,
                        omega: [eb[0] * w, eb[1] * w, eb[2] * w],
                    },
                }
            })
            .collect();
        Self {
            dim,
            masses,
            inv_masses,
            potentials,
            constraints,
            m,
            damping,
            magnetic,
            kinetic: Counter::default(),
            flight_counter: Counter::default(),
            constraint_counter: Counter::default(),
            profile,
            sparse: m > 4,
            flights,
            gravity_in_flight,
            inputs: None,
            zero_damping: false,
            dashpots: None,
            hinge_dampers: None,
            state_names: Vec::new(),
            multiplier_names: Vec::new(),
            books: books::Books::default(),
        }
    }

    /// Keeps the constraint terms whose index passes `keep`, renumbering their rows.
    pub(crate) fn retain_constraints(&mut self, keep: impl Fn(usize) -> bool) {
        let dim = self.dim;
        let mut row = 0;
        let old = std::mem::take(&mut self.constraints);
        self.constraints = old
            .into_iter()
            .enumerate()
            .filter(|(i, _)| keep(*i))
            .map(|(_, mut t)| {
                t.row = row;
                row += t.rows(dim);
                t
            })
            .collect();
        self.m = row;
        self.sparse = row > 4;
    }

    /// Number of bodies.
    pub fn bodies(&self) -> usize {
        self.masses.len()
    }
    /// Dimension of the space (2 or 3).
    pub fn space_dim(&self) -> usize {
        self.dim
    }
    /// Length of the state `x = (q, p)`: `2 d N`.
    pub fn state_len(&self) -> usize {
        2 * self.dim * self.masses.len()
    }
    /// Number of constraint rows `m` (the length of `g`).
    pub fn constraint_rows(&self) -> usize {
        self.m
    }
    /// The inverse masses `1/m_b`, one per body (`W⁻¹` is `1/m_b` on each of body `b`'s `d`
    /// coordinates).
    pub fn inv_masses(&self) -> &[T] {
        &self.inv_masses
    }

    /// Zeroes every term's evaluation counter and clock.
    pub fn reset_counters(&self) {
        self.kinetic.reset();
        self.flight_counter.reset();
        self.constraint_counter.reset();
        for t in &self.potentials {
            t.counter.reset();
        }
        if let Some(t) = &self.damping {
            t.counter.reset();
        }
        if let Some(t) = &self.magnetic {
            t.counter.reset();
        }
    }

    /// The declared inputs.
    pub fn inputs(&self) -> Option<&crate::scene::ports::SceneInputs<T>> {
        self.inputs.as_ref()
    }

    /// `true` if uniform gravity is part of the free flight (no magnetic term is assembled).
    pub fn gravity_in_flight(&self) -> bool {
        self.gravity_in_flight
    }

    /// The shortest relaxation time `m_b / c_b` of a body under damping, when something the
    /// free flight does not integrate acts on the damped momenta — a constraint's projection,
    /// a kick, an input, a dashpot or a hinge damper: the flight damps the impulses they give,
    /// and over sub-steps longer than this the splitting's error is first order in the step
    /// (docs/method.md §12d). `None` without damping, or when the flight is the whole motion
    /// (exact).
    pub fn stiff_relaxation(&self) -> Option<T> {
        let impulses = self.m > 0
            || self.has_kick()
            || self.inputs.is_some()
            || self.dashpots.is_some()
            || self.hinge_dampers.is_some();
        if !impulses {
            return None;
        }
        self.ground_relaxations().reduce(|a, b| a.min(b))
    }

    /// `m_b / c_b` of every body damped against the ground.
    fn ground_relaxations(&self) -> impl Iterator<Item = T> + '_ {
        self.damping.iter().flat_map(|d| {
            d.per_body
                .iter()
                .zip(&self.inv_masses)
                .filter(|(c, w)| **c > T::zero() && **w > T::zero())
                .map(|(&c, &w)| T::one() / (c * w))
        })
    }

    /// The damping's shortest relaxation time, whatever else acts: `m_b / c_b` of a body damped
    /// against the ground, `μ / c` (`1/μ = 1/m_a + 1/m_b`) of two bodies joined by a dashpot.
    /// `None` without either. The first step of a fixed-order scheme under step doubling
    /// resolves it ([`AdaptiveOptions::resolve`](crate::flow::AdaptiveOptions::resolve)).
    pub fn relaxation(&self) -> Option<T> {
        let w = &self.inv_masses;
        let pairs = self.dashpots.iter().flat_map(|d| {
            d.pairs
                .iter()
                .filter(|&&(a, b, c)| c > T::zero() && w[a] + w[b] > T::zero())
                .map(|&(a, b, c)| T::one() / (c * (w[a] + w[b])))
        });
        self.ground_relaxations()
            .chain(pairs)
            .reduce(|a, b| a.min(b))
    }

    /// The times where an input's signal jumps or kinks ([`Signal::breakpoints`](crate::port::Signal::breakpoints)),
    /// sorted, without repeats: an adaptive run's steps land on them.
    pub fn breakpoints(&self) -> Vec<T> {
        let mut out = Vec::new();
        for s in self.inputs.iter().flat_map(|i| i.signals()) {
            s.breakpoints(&mut out);
        }
        out.sort_by(|a, b| a.partial_cmp(b).unwrap_or(core::cmp::Ordering::Equal));
        out.dedup();
        out
    }

    /// `true` if the kick has terms: a potential that is not joined to the free flight.
    pub fn has_kick(&self) -> bool {
        self.potentials
            .iter()
            .any(|t| !(self.gravity_in_flight && t.is_gravity()))
    }

    /// `true` if a damping term, a dashpot or a hinge damper is assembled (`M` has a
    /// dissipative part).
    pub fn is_dissipative(&self) -> bool {
        self.damping.is_some() || self.dashpots.is_some() || self.hinge_dampers.is_some()
    }

    /// `true` if hinge dampers are assembled (their exact flows join the kick; the implicit
    /// schemes, whose `M` does not hold them, refuse them).
    pub fn has_hinge_dampers(&self) -> bool {
        self.hinge_dampers.is_some()
    }

    /// `true` if dashpots join bodies (their exact flow joins the kick).
    pub fn has_dashpots(&self) -> bool {
        self.dashpots.is_some()
    }
    /// `true` if the skew part `J` of `M` is canonical (no magnetic term is assembled).
    pub fn is_canonical(&self) -> bool {
        self.magnetic.is_none()
    }

    /// Counts one evaluation of a term and, when profiling, times it.
    #[inline(always)]
    fn timed<R>(&self, counter: &Counter, f: impl FnOnce() -> R) -> R {
        let _timer = self.timer(counter);
        f()
    }

    /// Counts one evaluation of a term and, when profiling, times it until the returned guard
    /// drops: for kernels written inline (a closure around a kernel's body was outlined by
    /// the compiler, and the kernel then passed its captures through memory).
    #[inline(always)]
    fn timer<'a>(&self, counter: &'a Counter) -> Timer<'a> {
        counter.hit();
        Timer {
            counter,
            start: self.profile.then(Instant::now),
        }
    }
}

/// The clock of one evaluation (see [`SceneModel::timer`]).
struct Timer<'a> {
    counter: &'a Counter,
    start: Option<Instant>,
}

impl Drop for Timer<'_> {
    #[inline(always)]
    fn drop(&mut self) {
        if let Some(t) = self.start {
            self.counter.add_time(t);
        }
    }
}
