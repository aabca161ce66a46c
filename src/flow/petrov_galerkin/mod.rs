//! The energy-consistent Petrov–Galerkin step in time (order `2k`, an exact discrete energy
//! balance) for `x' = (J − R)(∇H + Gᵀλ) + B(x) u(t)`, `g(x) = 0` (the inputs optional).

mod basis;
mod blocks;
mod dissipation;
mod problem;
mod quadrature;
#[cfg(all(test, feature = "scene"))]
#[path = "quadrature_tests.rs"]
mod quadrature_tests;
mod reduced;
mod rounding;
mod supplied;
mod tables;
#[cfg(all(test, feature = "scene"))]
mod test_scenes;

use super::projection::HiddenSolver;
use super::reduced::Reduced;
use super::{Flow, FlowStats, Ledger, ProjectionOptions, step_end};
use crate::error::{SetupError, StepError};
use crate::flow::forcing::Forcing;
use crate::nonlinear::{Newton, NonlinearSolver};
use crate::real::Real;
use crate::system::{
    Case, Hamiltonian, HolonomicConstraint, MechanicalForm, Model, StructureMatrix,
    check_initial_state, half_step_keeps_jacobian,
};
use crate::vector::{Vector, ops};
use blocks::ConstraintBlocks;
pub use dissipation::DiscreteDissipation;
use num_traits::Zero;
use problem::{Problem, Scratch};
use quadrature::constraint_is_quadratic;
pub use quadrature::exact_quadrature;
use reduced::Stages;
use tables::Tables;

/// The energy-consistent Petrov–Galerkin method in time (Egger, Habrich & Shashkov, CMAM 21,
/// 2021; Giesselmann, Karsai & Tscherpel, arXiv 2404.12480; with algebraic constraints
/// Altmann, Karsai & Schulze, arXiv 2507.21552). On `[t_n, t_n + h]` find `x ∈ P_k`
/// (`x(t_n) = x_n`) and `z, λ ∈ P_{k−1}` with, for all test functions `v, w ∈ P_{k−1}ⁿ`,
/// `μ ∈ P_{k−1}ᵐ`,
///
/// ```text
/// (a)  ∫ ⟨x' − M (z + G(x)ᵀλ), v⟩ = 0      (b)  ∫ ⟨z − ∇H(x), w⟩ = 0      (c)  ∫ ⟨G(x) x', μ⟩ = 0
/// ```
///
/// **Energy.** `H(x_{n+1}) − H(x_n) = ∫⟨∇H(x), x'⟩ = ∫⟨z, x'⟩` (by (b), `x' ∈ P_{k−1}`)
/// `= −∫ zᵀRz + ∫ zᵀ M Gᵀλ` (by (a) with `v = z`). For mechanical structure — constraints on
/// positions, `M` constant with `J` canonical in the `qp` blocks, `R` and magnetic terms in the
/// `pp` block — `M Gᵀλ` acts on momenta only, the `q`-rows of (a) give `q' = z_p` pointwise,
/// and the work `∫ zᵀ M Gᵀλ = −∫ λᵀ G q'` vanishes by (c) with `μ = λ`. So the step dissipates
/// exactly `D = h ∫ zᵀRz ≥ 0`. (c) with `μ` constant gives `g(x_{n+1}) = g(x_n)`; the scheme
/// solves it with `g(x_n)` moved to the right-hand side, `g(x_{n+1}) = 0`, so that rounding
/// does not accumulate (the work this adds is `h g(x_n)·Σβ_jλ_j`, at rounding level).
///
/// **Order.** `2k` at the step points (superconvergence, as for Gauss collocation), once the
/// hidden constraint `φ = G M ∇H = 0` is restored after each step: without it the index-3
/// order reduction leaves order 2. The projection `x ← x + M Gᵀν` with `φ = 0` is, for
/// mechanical models, orthogonal in the kinetic metric: it removes kinetic energy `≥ 0`, which
/// is counted in `D_n` ([`DiscreteDissipation::projection`]). `k = 1` is the average-vector-field
/// discrete gradient with `g(q_{n+1}) = g(q_n)`.
///
/// **Discretization.** `x'`, `z`, `λ` in the Lagrange basis at the `k` Gauss points; the
/// integrals by an `s`-point Gauss rule, exact for polynomials of degree `2s − 1`. By default
/// `s` is the fewest points that integrate every integral above exactly when they are
/// polynomials ([`exact_quadrature`]): with `H` and `g` quadratic (`∇H` and `G` affine)
/// the integrands have degree at most `3k − 2` (`G(x)ᵀλ` against `v`, `G(x) x'` against `μ`),
/// so `s = ⌈(3k − 1)/2⌉` (without constraints degree `2k − 1` and `s = k`), and the step is the same
/// as with any more points, to rounding. Otherwise `s = k + 2`: exact for the constraint rows
/// when `g` is quadratic and for the energy when `H` is a polynomial of degree `≤ 2s/k`; else
/// the balance holds to the quadrature error of `∫⟨∇H, x'⟩`, `O(h^{2s+1})`. Newton on
/// the `k (n + m)` unknowns `(h x'(c_j), h λ(c_j))` with a dense, difference Jacobian kept
/// between steps: for small and mid-sized states.
pub struct PetrovGalerkin<
    V: Vector,
    Sys,
    W: Vector<Real = V::Real> = faer::Col<<V as Vector>::Real>,
> {
    system: Sys,
    tables: Tables<V::Real>,
    /// Dense Newton on all `k (n + m)` unknowns, for a model without a mechanical form.
    newton: Option<Newton<W>>,
    /// The reduced solve of a model of mechanical form.
    mechanical: Option<Reduced<V::Real, W::Solver>>,
    /// The reduced solve's constraint blocks, when the constraint lists its Jacobian entries.
    blocks: Option<ConstraintBlocks<V::Real>>,
    hidden: Option<HiddenSolver<V>>,
    /// The inputs `B(x) u(t)`, when the system is open ([`with_inputs`](Self::with_inputs)).
    forcing: Option<Forcing<V>>,
    u: W,
    /// Where the last step ended (for the reduced solve's predictor), when `ended`; `x0`
    /// before the first step.
    end: V,
    ended: bool,
    w: Scratch<V>,
    start: V,
    xe: V,
    tmp: V,
    t2: V,
    nu: Vec<V::Real>,
    g0: Vec<V::Real>,
    /// The rounding floor's perturbation signs, `±ε/2` per component (`rounding.rs`).
    signs: Vec<V::Real>,
    /// The last step's damping and projection terms of `D_n` and its supplied work `S_n` (its
    /// energies are evaluated when asked for).
    last: Option<(V::Real, V::Real, V::Real)>,
    stats: FlowStats,
}

impl<V: Vector, Sys, W: Vector<Real = V::Real>> core::fmt::Debug for PetrovGalerkin<V, Sys, W> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("PetrovGalerkin")
            .field("k", &self.tables.k)
            .field("s", &self.tables.s)
            .field("n", &self.start.len())
            .field("m", &self.nu.len())
            .field("mechanical", &self.mechanical.is_some())
            .field("stats", &self.stats)
            .finish_non_exhaustive()
    }
}

/// The largest `k` offered (order 8); beyond it the Newton matrix grows as `k²`.
pub const MAX_STAGES: usize = 4;

/// The most unknowns `k (n + m)` the dense Newton of a model without a mechanical form takes.
pub const DENSE_MAX_UNKNOWNS: usize = 2048;

impl<V, Sys, W> PetrovGalerkin<V, Sys, W>
where
    V: Vector,
    Sys: Model<V>,
    W: Vector<Real = V::Real>,
{
    /// The scheme of order `order = 2k` (`k = 1 … MAX_STAGES`) for `system` from `x0`, which must
    /// satisfy `g(x0) = 0` to `options.manifold_tol`; `options.newton` drives both solves.
    ///
    /// # Errors
    /// [`SetupError::Scheme`] for an odd or out-of-range order, a state-dependent `M`, or
    /// constraints whose forces `M Gᵀλ` move what `G` depends on (the energy identity needs
    /// constraints on positions with forces on momenta); the initial-state checks of a
    /// projection.
    pub fn try_new(
        system: Sys,
        x0: &V,
        order: u32,
        options: ProjectionOptions<V::Real>,
    ) -> Result<Self, SetupError> {
        let k = (order / 2) as usize;
        if !order.is_multiple_of(2) || k == 0 || k > MAX_STAGES {
            return Err(SetupError::Scheme {
                what: format!(
                    "the Petrov–Galerkin scheme has the even orders 2 to {}, not {order}",
                    2 * MAX_STAGES
                ),
            });
        }
        if !system.structure().is_constant() {
            return Err(SetupError::Scheme {
                what: "the Petrov–Galerkin scheme takes a constant structure matrix M (its energy identity is proven for M = J − R constant)".into(),
            });
        }
        let (case, pattern) = check_initial_state::<V, Sys, W::Solver>(
            &system,
            x0,
            &options.initial_checks(),
            false,
        )?;
        let (n, m) = (x0.len(), system.constraint().dim());
        if m > 0 && (case != Case::Degenerate || !half_step_keeps_jacobian(&system, x0)) {
            return Err(SetupError::Scheme {
                what: "the Petrov–Galerkin scheme's energy identity needs constraints whose forces M Gᵀλ move only what G does not depend on (positions constrained, forces on momenta)".into(),
            });
        }
        let hidden = if m > 0 {
            Some(HiddenSolver::new(
                &system,
                x0,
                options.newton,
                pattern.as_deref(),
            )?)
        } else {
            None
        };
        let s = exact_quadrature(
            k,
            m,
            system.hamiltonian().is_quadratic(),
            constraint_is_quadratic(system.constraint(), x0),
        );
        let tables = Tables::new(k, s);
        // Stiffly damped momentum rows carry `c h/m`: equilibrated, their size does not make
        // the multipliers' pivots look singular.
        let mut newton_options = options.newton;
        newton_options.equilibrate = true;
        let form = MechanicalForm::of(&system, system.hamiltonian(), x0)?;
        let (newton, mechanical) = match form {
            // With the constraints' curvature: the Schur iteration goes on while it contracts by
            // 0.5 (`reduced::CURVED_MAX_CONTRACTION`).
            // The step reads nothing from the residual at the solution (its end and its
            // dissipation follow from the unknowns alone): the iteration may stop on a
            // predicted contraction.
            Some(form) => {
                let mut reduced = Reduced::new(form, m, newton_options, true, &tables.ahat)?;
                reduced.solver.trust_contraction();
                (None, Some(reduced))
            }
            None => {
                if k * (n + m) > DENSE_MAX_UNKNOWNS {
                    return Err(SetupError::Scheme {
                        what: format!(
                            "the Petrov–Galerkin scheme of order {order} on a model without a mechanical form solves {} unknowns a step by dense Newton; at most {DENSE_MAX_UNKNOWNS}",
                            k * (n + m)
                        ),
                    });
                }
                // The difference Jacobian costs `k (n + m)` residuals (each `s` gradients) and
                // a dense factorization, a hundred iterations' worth on a mid-sized state: it
                // is kept while an iteration contracts at all (a stale one, 0.5–0.9, is still
                // far cheaper; a worse residual rebuilds it).
                newton_options.max_contraction = V::Real::lit(0.9);
                newton_options.broyden = false;
                (Some(Newton::new(k * (n + m), newton_options)?), None)
            }
        };
        let blocks = mechanical.as_ref().and_then(|reduced| {
            ConstraintBlocks::new(system.constraint(), x0, reduced.nq, &tables)
        });
        Ok(Self {
            tables,
            newton,
            mechanical,
            blocks,
            hidden,
            forcing: None,
            u: W::zeros(k * (n + m)),
            end: x0.clone(),
            ended: false,
            w: Scratch::new(x0, k, s, m),
            start: x0.zeros_like(),
            xe: x0.zeros_like(),
            tmp: x0.zeros_like(),
            t2: x0.zeros_like(),
            nu: vec![V::Real::zero(); m],
            g0: vec![V::Real::zero(); m],
            signs: rounding::rounding_signs(n),
            last: None,
            stats: FlowStats::default(),
            system,
        })
    }

    /// The number of Gauss points of its integrals ([`exact_quadrature`] unless set by
    /// [`with_quadrature`](Self::with_quadrature)).
    pub fn quadrature_points(&self) -> usize {
        self.tables.s
    }

    /// The same scheme for the open system `x' = M (∇H + Gᵀλ) + B(x) u(t)`: `map` is `B`,
    /// `signals` the inputs `u` (one per input). The step integrates `B u` against the test
    /// functions by its quadrature, reads the time from the [`Ledger`] (and advances it), and
    /// books the supplied work `S_n` (see `supplied.rs`) in the ledger and in
    /// [`last_dissipation`](Self::last_dissipation): `H_{n+1} − H_n = −D_n + S_n`.
    ///
    /// # Errors
    /// [`SetupError::Dimension`] when the signals and the map's inputs differ in number;
    /// [`SetupError::Scheme`] when the model has a mechanical form (its positions are
    /// eliminated) and `B(x0)` moves a position: inputs must be forces there.
    pub fn with_inputs(
        mut self,
        map: impl crate::port::InputMap<V> + 'static,
        signals: Vec<crate::port::Signal<V::Real>>,
    ) -> Result<Self, SetupError> {
        let nq = self.mechanical.as_ref().map(|reduced| reduced.nq);
        let forcing = Forcing::try_new(
            "Petrov–Galerkin scheme",
            Box::new(map),
            signals,
            &self.system,
            &self.end,
            nq,
        )?;
        self.w.forced(self.tables.k);
        self.forcing = Some(forcing);
        Ok(self)
    }

    /// The same scheme with an `s`-point Gauss rule for its integrals (`s ≥ k`).
    ///
    /// # Errors
    /// [`SetupError::Scheme`] when `s < k` (then not even `∫ G(x) x' = g(x_{n+1}) − g(x_n)`,
    /// of degree `2k − 1` for a quadratic `g`, is integrated exactly) or `s > 16`. Between `k`
    /// and [`exact_quadrature`]'s count the rows tested with non-constant `μ`, `v` are not
    /// exact for quadratic constraints (degree `3k − 2`): another scheme, of the same order on
    /// the damped pendulum.
    pub fn with_quadrature(mut self, s: usize) -> Result<Self, SetupError> {
        let k = self.tables.k;
        if s < k || s > 16 {
            return Err(SetupError::Scheme {
                what: format!("{s} quadrature points for k = {k}: between k and 16"),
            });
        }
        self.tables = Tables::new(k, s);
        self.w.xs = vec![self.start.zeros_like(); s];
        if let Some(blocks) = self.blocks.as_mut() {
            blocks.for_quadrature(&self.tables);
        }
        if let Some(reduced) = self.mechanical.as_mut() {
            // Its stage matrix is the same (`Â` is exact for any `s ≥ k`); its past steps are not.
            reduced.invalidate();
        }
        Ok(self)
    }

    /// Forgets the kept Newton matrices and the past steps (after a failure, and at a
    /// checkpoint, so that a restored run continues as the saved one).
    fn forget(&mut self) {
        if let Some(newton) = self.newton.as_mut() {
            newton.invalidate_jacobian();
        }
        if let Some(reduced) = self.mechanical.as_mut() {
            reduced.invalidate();
        }
        self.ended = false;
    }

    /// The energy account of the last step (`None` before the first and after a failed one).
    /// Its energies are evaluated here, from the step's start and its end before the
    /// projection (both kept until the next step): a run that does not ask pays for no energy
    /// evaluation.
    pub fn last_dissipation(&self) -> Option<DiscreteDissipation<V::Real>> {
        let (damping, projection, supplied) = self.last?;
        let energy = self.system.hamiltonian();
        Some(DiscreteDissipation {
            before: energy.energy(&self.start),
            after: energy.energy(&self.xe) - projection,
            damping,
            projection,
            supplied,
        })
    }

    /// The initial guess: the explicit Euler increments `h M ∇H(x)` at every Gauss point, the
    /// previous step's multipliers (scaled to this step).
    fn guess(&mut self, h: V::Real, x: &V) {
        let (k, n) = (self.tables.k, x.len());
        let m = self.nu.len();
        let u = self.u.as_mut_slice();
        let have = u[..k * n].iter().any(|v| *v != V::Real::zero());
        if have {
            return; // the last step's solution: the same increments to first order.
        }
        self.system.hamiltonian().gradient(x, &mut self.tmp);
        self.system.structure().apply(x, &self.tmp, &mut self.t2);
        for j in 0..k {
            for (o, &f) in u[j * n..(j + 1) * n].iter_mut().zip(self.t2.as_slice()) {
                *o = h * f;
            }
        }
        u[k * n..k * (n + m)]
            .iter_mut()
            .for_each(|v| *v = V::Real::zero());
    }
}

impl<V, Sys, W> Flow<V> for PetrovGalerkin<V, Sys, W>
where
    V: Vector,
    Sys: Model<V>,
    W: Vector<Real = V::Real>,
{
    fn step(&mut self, h: V::Real, x: &mut V) -> Result<(), StepError> {
        self.step_at(&mut Ledger::default(), h, x)
    }

    fn step_at(
        &mut self,
        ledger: &mut Ledger<V::Real>,
        h: V::Real,
        x: &mut V,
    ) -> Result<(), StepError> {
        if !super::check_step(h, x)? {
            return Ok(());
        }
        if x.len() != self.start.len() {
            return Err(StepError::StateLength {
                flow: "Petrov–Galerkin",
                expected: self.start.len(),
                got: x.len(),
            });
        }
        self.last = None;
        self.start.copy_from(x);
        // Whether this step continues the last one (its predictor and measured contraction).
        let continued = self.ended && self.start.as_slice() == self.end.as_slice();
        self.guess(h, x);
        let t0 = ledger.t;
        if let Some(forcing) = self.forcing.as_mut() {
            forcing.begin(t0, h, &self.tables.nodes, h)?;
        }
        let floor = self.rounding_floor(x);
        self.system.constraint().residual(x, &mut self.g0);
        let (k, n) = (self.tables.k, x.len());
        let mut problem = Problem {
            h,
            x: &self.start,
            tables: &self.tables,
            w: &mut self.w,
            system: &self.system,
            g0: &self.g0,
            noise: V::Real::zero(),
            floor,
            forcing: self.forcing.as_mut(),
        };
        let solved = if let Some(reduced) = self.mechanical.as_mut() {
            let Reduced {
                w,
                z,
                solver,
                momentum_block,
                ..
            } = reduced;
            solver.begin(h, continued);
            let mut stages = Stages {
                full: &mut problem,
                w,
                u: self.u.as_mut_slice(),
                momentum_block,
                blocks: self.blocks.as_mut(),
                keep: false,
            };
            stages.compress(z);
            solver.predict(z);
            let solved = solver.solve(&mut stages, z);
            if solved.is_ok() {
                stages.expand(z);
                solver.record(z, continued);
            }
            solved
        } else if let Some(newton) = self.newton.as_mut() {
            newton.solve(&mut problem, self.u.as_mut_slice())
        } else {
            unreachable!("a Petrov–Galerkin scheme has a dense or a reduced solver")
        };
        let report = match solved {
            Ok(r) => r,
            Err(e) => {
                ops::fill_zero(self.u.as_mut_slice());
                self.forget();
                return Err(StepError::from_newton("Petrov–Galerkin stages", e));
            }
        };
        self.stats.record(&report);
        // h z(c_i) is the ∇H part of acc_i: recompute acc without the multipliers.
        let u = self.u.as_slice();
        let t = &self.tables;
        // x_{n+1} = x_n + Σ β_j Y_j.
        self.xe.copy_from(&self.start);
        for j in 0..k {
            ops::axpy(self.xe.as_mut_slice(), t.beta[j], &u[j * n..(j + 1) * n]);
        }
        // D = −h Σ_r b_r z_rᵀ M z_r with z_r = Σ_j ℓ_j(e_r) z(c_j), z(c_j) = acc_j(L = 0)/h.
        // `zᵀMz` is a polynomial of degree 2k − 2 in t, which the k-point Gauss rule at the
        // c_j integrates exactly as the s-point rule does: D = −h Σ_j β_j z(c_j)ᵀ M z(c_j),
        // k products with M instead of s (and ≥ 0 term by term for M = J − R, β_j > 0).
        let mut damping = V::Real::zero();
        let dissipative = self.system.structure().is_dissipative();
        match self.mechanical.as_ref() {
            _ if !dissipative => {}
            Some(reduced) => {
                // The momentum rows of `h z(c_j)` are `h W⁻¹` times the projection of `p`,
                // which is `Y^q_j` exactly (`reduced.rs`); `M = [[0, I], [−I, B]]` pairs the
                // position rows with them only in the skew part, which `zᵀMz` cancels. So
                // `h² z_pᵀ B z_p = Y^q_jᵀ B Y^q_j` from the unknowns and the entries of `B`
                // (the solve may have stopped without a residual at the solution).
                for (y, &beta) in u.chunks_exact(n).zip(&self.tables.beta) {
                    let zbz = reduced
                        .momentum_block
                        .iter()
                        .fold(V::Real::zero(), |acc, &(r, c, v)| acc + v * y[r] * y[c]);
                    damping = damping - beta * zbz / h;
                }
            }
            None => {
                // The last residual was evaluated at the solution: `accz` holds its `h z(c_j)`.
                for (acc, &beta) in self.w.accz.iter().zip(&self.tables.beta) {
                    self.system
                        .structure()
                        .apply(&self.start, acc, &mut self.t2);
                    let zmz = ops::dot(acc.as_slice(), self.t2.as_slice());
                    damping = damping - beta * zmz / h;
                }
            }
        }
        let supplied = match self.forcing.as_mut() {
            None => V::Real::zero(),
            Some(forcing) => match self.mechanical.as_ref() {
                Some(reduced) => forcing.supplied_mechanical(
                    &self.tables,
                    &self.start,
                    u,
                    reduced.nq,
                    h,
                    &mut self.t2,
                ),
                None => forcing.supplied(&self.tables, &self.w.accz, &self.w.accu, h),
            },
        };
        let mut projection = V::Real::zero();
        if self.hidden.is_some() {
            // φ(x_{n+1} + M Gᵀν) = 0: the base is xe, the result goes to x.
            ops::fill_zero(&mut self.nu);
            let Some(hidden) = self.hidden.as_mut() else {
                unreachable!()
            };
            let solved = step_end::project(
                hidden,
                &self.system,
                &self.xe,
                x,
                &mut self.tmp,
                &mut self.t2,
                &mut self.nu,
            );
            if let Err(e) = solved {
                x.copy_from(&self.start);
                self.ended = false;
                if let Some(HiddenSolver::General(n)) = self.hidden.as_mut() {
                    n.invalidate_jacobian();
                }
                return Err(StepError::from_newton("hidden-constraint projection", e));
            }
            projection = step_end::removed_energy(
                &self.system,
                self.mechanical.as_ref().map(|r| (r.nq, &r.w[..])),
                &self.xe,
                x,
            );
        } else {
            x.copy_from(&self.xe);
        }
        if let Some(component) = ops::first_non_finite(x.as_slice()) {
            x.copy_from(&self.start);
            ops::fill_zero(self.u.as_mut_slice());
            self.forget();
            return Err(StepError::NonFinite { component });
        }
        self.end.copy_from(x);
        self.ended = true;
        ledger.dissipated = ledger.dissipated + damping + projection;
        if self.forcing.is_some() {
            // The step carries the time of its inputs.
            ledger.supplied = ledger.supplied + supplied;
            ledger.t = t0 + h;
        }
        self.last = Some((damping, projection, supplied));
        self.stats.projected_steps += 1;
        Ok(())
    }

    fn order(&self) -> u32 {
        2 * self.tables.k as u32
    }

    fn is_symmetric(&self) -> bool {
        self.hidden.is_none()
    }

    fn stats(&self) -> FlowStats {
        self.stats
    }

    fn dissipates(&self) -> bool {
        self.system.structure().is_dissipative()
    }

    fn save_memory(&mut self, out: &mut Vec<V::Real>) {
        self.forget();
        out.extend_from_slice(self.u.as_slice());
    }

    fn restore_memory(&mut self, from: &mut &[V::Real]) {
        self.forget();
        let saved = super::take_memory(from, self.u.len());
        self.u.as_mut_slice()[..saved.len()].copy_from_slice(saved);
    }
}
