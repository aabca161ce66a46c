//! The discrete-gradient method with holonomic constraints (Gonzalez 1999).

mod account;
mod mechanical;
mod step_problem;

use super::forcing::Forcing;
use super::projection::HiddenSolver;
use super::{Flow, FlowStats, Ledger, ProjectionOptions, step_end};
use crate::error::{NewtonError, SetupError, StepError};
use crate::flow::reduced::Reduced;
use crate::nonlinear::{Newton, NonlinearSolver, SolveReport};
use crate::real::Real;
use crate::system::MechanicalForm;
use crate::system::Model;
use crate::system::{Case, Hamiltonian, HolonomicConstraint, StructureMatrix, check_initial_state};
use crate::vector::{Vector, ops};
pub use account::EnergyBalance;
use num_traits::{Float as _, One, Zero};
use step_problem::Problem;

/// The discrete-gradient method for the constrained system `x' = M(x)(∇H + Gᵀλ)`, `g(x) = 0`
/// (Gonzalez, J. Nonlinear Sci. 9, 1999; Gonzalez, J. Nonlinear Sci. 6, 1996):
///
/// ```text
/// x_{k+1} = x_k + h M(x̄) (∇̄H(x_k, x_{k+1}) + ∇̄g(x_k, x_{k+1})ᵀ λ),     g(x_{k+1}) = 0,
/// ```
///
/// with Gonzalez's midpoint discrete gradient `∇̄` (see [`DiscreteGradient`](super::DiscreteGradient))
/// applied to `H` and to each constraint `gᵢ`. Since `∇̄gᵢ · Δ = gᵢ(x_{k+1}) − gᵢ(x_k) = 0`, the
/// constraint force does no work, and with `F̄ = ∇̄H + ∇̄gᵀλ`
///
/// ```text
/// H(x_{k+1}) − H(x_k) = ∇̄H · Δ = F̄ · Δ = h F̄ᵀ M(x̄) F̄
/// ```
///
/// holds to round-off for any `M`: energy is conserved when `M` is skew and never increases when
/// `M + Mᵀ ⪯ 0` ([`EnergyBalance`], [`energy_balance`](Self::energy_balance)). Order 2.
///
/// **Hidden constraint.** The step enforces `g = 0` but not the hidden constraint
/// `φ = G M ∇H = 0` of the degenerate (mechanical) case, which it keeps only to `O(h²)`. By
/// default each step is therefore followed by the projection `x ← x + M(x) G(x)ᵀ ν` with
/// `φ(x) = 0` (the direction of the projection half-steps of Zhang & Deng). For a mechanical
/// system (`g` depends on positions only, `H` quadratic in the momenta, `R` acting on momenta)
/// this changes only momenta, keeps `g = 0` exactly, and removes the kinetic energy of the
/// constraint-violating velocity: it never increases `H`. The step is then not symmetric.
/// [`without_hidden_projection`](Self::without_hidden_projection) turns it off (symmetric step,
/// `|φ| = O(h²)`). In the non-degenerate case there is no hidden constraint and no projection.
///
/// **A model of mechanical form** ([`MechanicalForm`]: `H = ½pᵀW⁻¹p + V(q)`,
/// `M = [[0, I], [−I, B]]`, constraints on positions) takes the discrete gradient block by block,
/// `∇̄H = (∇̄V(q, q'), W⁻¹p̄)` and `∇̄g(q, q')`, solves the momentum rows exactly and runs Newton
/// on `(δq, (h²/2) λ)` (`n/2 + m` unknowns) with the model's sparsity and a kept matrix; the
/// identity above holds with `h F̄ᵀM F̄ = δqᵀB δq / h` (docs/method.md §10).
///
/// Otherwise each step solves for `(δ, hλ)` (`n + m` unknowns) by Newton, stored in `W` (heap `faer::Col`
/// by default, since `n + m` exceeds a stack vector's capacity `n`). When the model gives
/// `∇²H` ([`Hamiltonian::hessian_apply`]) and `DM` ([`StructureMatrix::derivative_apply_add`];
/// automatic for a constant `M`) the Newton matrix is assembled in closed form at every
/// iteration (full Newton); otherwise by differences, kept across steps. The hidden-constraint
/// projection of up to four constraints runs on stack arrays with closed-form columns, and is
/// one linear solve when `H` is quadratic and `M` constant. The increment is added with compensated summation. Workspace is
/// allocated at construction; a step allocates nothing; on error the state is unchanged.
pub struct ConstrainedDiscreteGradient<
    V: Vector,
    Sys,
    W: Vector<Real = V::Real> = faer::Col<<V as Vector>::Real>,
> {
    system: Sys,
    /// Newton on `(δ, ℓ)`; `None` on the mechanical path.
    newton: Option<Newton<W>>,
    /// The momenta eliminated (a model of mechanical form): Newton on `(δq, ν)`.
    mechanical: Option<Reduced<V::Real, W::Solver>>,
    hidden: Option<HiddenSolver<V>>,
    /// The inputs `B(q) u(t)`, when the system is open ([`with_inputs`](Self::with_inputs)).
    forcing: Option<Forcing<V>>,
    /// The state the flow was built for (inputs are checked there).
    initial: V,
    /// Unknowns `(δ, ℓ = hλ)`.
    z: W,
    /// The multiplier `λ` of the last step (warm start).
    lambda: Vec<V::Real>,
    nu: Vec<V::Real>,
    g0: Vec<V::Real>,
    g1: Vec<V::Real>,
    gd: Vec<V::Real>,
    start: V,
    xm: V,
    xe: V,
    grad: V,
    f: V,
    tmp: V,
    t2: V,
    comp: V,
    comp_next: V,
    /// Scratch for closed-form Jacobian columns.
    s1: V,
    s2: V,
    em: Vec<V::Real>,
    last: V,
    /// `x'` before the hidden-constraint projection.
    after_step: V,
    last_h: V::Real,
    have_step: bool,
    /// The rounding floor of `h M ∇H` at the step's start (see `IncrementFlow::step`).
    base_noise: V::Real,
    stats: FlowStats,
}

impl<V: Vector, Sys, W: Vector<Real = V::Real>> core::fmt::Debug
    for ConstrainedDiscreteGradient<V, Sys, W>
{
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("ConstrainedDiscreteGradient")
            .field("n", &self.start.len())
            .field("m", &self.g0.len())
            .field("hidden_projection", &self.hidden.is_some())
            .field("mechanical", &self.mechanical.is_some())
            .field("stats", &self.stats)
            .finish_non_exhaustive()
    }
}

impl<V, Sys, W> ConstrainedDiscreteGradient<V, Sys, W>
where
    V: Vector,
    Sys: Model<V>,
    W: Vector<Real = V::Real>,
{
    /// The constrained discrete-gradient flow of `system` for states shaped like `x0`, which
    /// must satisfy `g(x0) = 0` to `options.manifold_tol`. The case (whether a hidden constraint
    /// exists) comes from `options.case` or the brackets at `x0`; `options.newton` is used for
    /// both Newton solves.
    pub fn try_new(
        system: Sys,
        x0: &V,
        options: ProjectionOptions<V::Real>,
    ) -> Result<Self, SetupError> {
        // φ(x0) need not vanish: the first hidden-constraint projection restores it.
        let (case, pattern) = check_initial_state::<V, Sys, W::Solver>(
            &system,
            x0,
            &options.initial_checks(),
            false,
        )?;
        let (n, m) = (x0.len(), system.constraint().dim());
        let g0 = vec![V::Real::zero(); m];
        let hidden = match case {
            Case::Degenerate if m > 0 => Some(HiddenSolver::new(
                &system,
                x0,
                options.newton,
                pattern.as_deref(),
            )?),
            _ => None,
        };
        let mechanical = match MechanicalForm::of(&system, system.hamiltonian(), x0)? {
            Some(form) => Some(Reduced::new(
                form,
                m,
                options.newton,
                true,
                &[<V::Real as crate::real::Real>::lit(0.5)],
            )?),
            _ => None,
        };
        let newton = match mechanical {
            Some(_) => None,
            None => Some(Newton::new(n + m, options.newton)?),
        };
        Ok(Self {
            newton,
            mechanical,
            hidden,
            forcing: None,
            initial: x0.clone(),
            z: W::zeros(n + m),
            lambda: vec![V::Real::zero(); m],
            nu: vec![V::Real::zero(); m],
            g1: g0.clone(),
            gd: g0.clone(),
            g0,
            start: x0.zeros_like(),
            xm: x0.zeros_like(),
            xe: x0.zeros_like(),
            grad: x0.zeros_like(),
            f: x0.zeros_like(),
            tmp: x0.zeros_like(),
            t2: x0.zeros_like(),
            comp: x0.zeros_like(),
            comp_next: x0.zeros_like(),
            s1: x0.zeros_like(),
            s2: x0.zeros_like(),
            em: vec![V::Real::zero(); m],
            last: x0.zeros_like(),
            after_step: x0.zeros_like(),
            last_h: V::Real::zero(),
            have_step: false,
            base_noise: V::Real::zero(),
            stats: FlowStats::default(),
            system,
        })
    }

    /// Turns the hidden-constraint projection off: the step is the symmetric Gonzalez step,
    /// `φ` stays `O(h²)`.
    pub fn without_hidden_projection(mut self) -> Self {
        self.hidden = None;
        self
    }

    /// The same scheme for the open system `x' = M (∇H + Gᵀλ) + B(x) u(t)`: `map` is `B`,
    /// `signals` the inputs `u`. The step takes the input at the step's midpoint,
    ///
    /// ```text
    /// x_{k+1} = x_k + h M(x̄)(∇̄H + ∇̄gᵀλ) + h B(x̄) u(t_n + h/2),
    /// ```
    ///
    /// reads the time from the [`Ledger`] and advances it, and books the supplied work
    /// `S_n = h F̄ᵀ B(x̄) u(t_n + h/2)` (`F̄ = ∇̄H + ∇̄gᵀλ`), for which the discrete-gradient
    /// identity becomes `H(x_{n+1}) − H(x_n) = h F̄ᵀM F̄ + S_n` exactly (`∇̄g·Δ = 0` still; the
    /// hidden-constraint projection then removes kinetic energy, booked as dissipated). Order 2
    /// for `u` with a bounded derivative. On a model of mechanical form `B` acts on the momenta
    /// (its rows `F`), `δp` gains `h F u` and `S_n = δqᵀ F u`, with `B` taken at `(q̄, p_n)`:
    /// forces of the positions and time (a force that depends on the momenta is taken at the
    /// step's start, first order in them). The kept Newton matrices leave out `D(B u)` (Newton
    /// tests the residual, which has it).
    ///
    /// # Errors
    /// [`SetupError::Scheme`] when an input moves a position of the mechanical form or what
    /// the constraints read (`G(x0) B(x0) ≠ 0`);
    /// [`SetupError::Dimension`] when the signals and the map's inputs differ in number.
    pub fn with_inputs(
        mut self,
        map: impl crate::port::InputMap<V> + 'static,
        signals: Vec<crate::port::Signal<V::Real>>,
    ) -> Result<Self, SetupError> {
        let nq = self.mechanical.as_ref().map(|reduced| reduced.nq);
        let forcing = Forcing::try_new(
            "constrained discrete gradient",
            Box::new(map),
            signals,
            &self.system,
            &self.initial,
            nq,
        )?;
        self.forcing = Some(forcing);
        Ok(self)
    }

    /// The system.
    pub fn system(&self) -> &Sys {
        &self.system
    }

    /// The multipliers `λ` of the last step.
    pub fn multipliers(&self) -> &[V::Real] {
        &self.lambda
    }
}

/// The step's nonlinear problem, borrowing the flow's fields one by one (so that the flow's
/// Newton solvers stay usable alongside).
macro_rules! problem {
    ($s:expr, $h:expr) => {
        Problem {
            h: $h,
            noise: V::Real::zero(),
            base_noise: $s.base_noise,
            x: &$s.start,
            xm: &mut $s.xm,
            xe: &mut $s.xe,
            grad: &mut $s.grad,
            f: &mut $s.f,
            tmp: &mut $s.tmp,
            g0: &$s.g0,
            g1: &mut $s.g1,
            gd: &mut $s.gd,
            s1: &mut $s.s1,
            s2: &mut $s.s2,
            em: &mut $s.em,
            system: &$s.system,
            forcing: $s.forcing.as_mut(),
        }
    };
}
use problem;

impl<V, Sys, W> ConstrainedDiscreteGradient<V, Sys, W>
where
    V: Vector,
    Sys: Model<V>,
    W: Vector<Real = V::Real>,
{
    /// The step on the general path: Newton on `(δ, ℓ = hλ)` from the predictor
    /// `δ = M(x)(h ∇H(x) + G(x)ᵀ ℓ)`, `ℓ = h λ_prev`.
    fn solve_full(&mut self, h: V::Real) -> Result<SolveReport<V::Real>, StepError> {
        let n = self.start.len();
        {
            let (zd, zl) = self.z.as_mut_slice().split_at_mut(n);
            for (l, &lp) in zl.iter_mut().zip(&self.lambda) {
                *l = h * lp;
            }
            let sys = &self.system;
            sys.hamiltonian().gradient(&self.start, &mut self.grad);
            for g in self.grad.as_mut_slice() {
                *g = *g * h;
            }
            sys.constraint().jacobian_transpose_apply_add(
                &self.start,
                zl,
                V::Real::one(),
                &mut self.grad,
            );
            sys.structure().apply(&self.start, &self.grad, &mut self.f);
            zd.copy_from_slice(self.f.as_slice());
        }
        let Some(newton) = self.newton.as_mut() else {
            unreachable!("the full solve on the mechanical path");
        };
        let mut problem = problem!(self, h);
        newton
            .solve(&mut problem, self.z.as_mut_slice())
            .map_err(|e| {
                newton.invalidate_jacobian();
                newton_error("constrained discrete gradient", e)
            })
    }
}

fn newton_error(stage: &'static str, e: NewtonError<StepError>) -> StepError {
    StepError::from_newton(stage, e)
}

impl<V: Vector, Sys, W: Vector<Real = V::Real>> ConstrainedDiscreteGradient<V, Sys, W> {
    /// Forgets the step's kept Newton matrix (either path's).
    fn forget_step_jacobian(&mut self) {
        if let Some(newton) = self.newton.as_mut() {
            newton.invalidate_jacobian();
        }
        if let Some(reduced) = self.mechanical.as_mut() {
            reduced.invalidate();
        }
    }

    /// Forgets the kept Newton matrices (a checkpoint cannot hold them): the next step builds
    /// them anew.
    fn forget_jacobians(&mut self) {
        self.forget_step_jacobian();
        if let Some(HiddenSolver::General(n)) = self.hidden.as_mut() {
            n.invalidate_jacobian();
        }
    }
}

impl<V, Sys, W> Flow<V> for ConstrainedDiscreteGradient<V, Sys, W>
where
    V: Vector,
    Sys: Model<V>,
    W: Vector<Real = V::Real>,
{
    fn save_memory(&mut self, out: &mut Vec<V::Real>) {
        self.forget_jacobians();
        out.extend_from_slice(&self.lambda);
        out.extend_from_slice(&self.nu);
        out.extend_from_slice(self.comp.as_slice());
        out.extend_from_slice(self.last.as_slice());
    }
    fn restore_memory(&mut self, from: &mut &[V::Real]) {
        self.forget_jacobians();
        for v in [
            self.lambda.as_mut_slice(),
            self.nu.as_mut_slice(),
            self.comp.as_mut_slice(),
            self.last.as_mut_slice(),
        ] {
            let saved = crate::flow::take_memory(from, v.len());
            v[..saved.len()].copy_from_slice(saved);
        }
    }
    fn step(&mut self, h: V::Real, x: &mut V) -> Result<(), StepError> {
        self.step_at(&mut Ledger::default(), h, x)
    }
    /// The step from `ledger.t`. It books the energy it removed (the damping's `−h F̄ᵀM F̄`,
    /// `−h v̄ᵀB v̄` on the mechanical path, and the kinetic energy the hidden-constraint
    /// projection removed) in `ledger.dissipated` and, with inputs, their work `S_n` in
    /// `ledger.supplied`, advancing `ledger.t` by `h`: `H_{n+1} − H_n = −D_n + S_n` to
    /// round-off.
    fn step_at(
        &mut self,
        ledger: &mut Ledger<V::Real>,
        h: V::Real,
        x: &mut V,
    ) -> Result<(), StepError> {
        let n = self.start.len();
        if x.len() != n {
            return Err(StepError::StateLength {
                flow: "constrained discrete gradient",
                expected: n,
                got: x.len(),
            });
        }
        if !super::check_step(h, x)? {
            return Ok(());
        }
        let t0 = ledger.t;
        if let Some(forcing) = self.forcing.as_mut() {
            forcing.begin(t0, h, &[V::Real::lit(0.5)], h)?;
        }
        // The stored step is overwritten below; report no balance unless this step succeeds.
        self.have_step = false;
        self.start.copy_from(x);
        self.system.constraint().residual(&self.start, &mut self.g0);
        // The rounding floor of h M ∇H itself (a stiff term's gradient rounds at its Hessian
        // times the state's rounding): ε |h M ∇²H(x) x|∞ when the model has a Hessian.
        self.base_noise = V::Real::zero();
        if self
            .system
            .hamiltonian()
            .hessian_apply(&self.start, &self.start, &mut self.tmp)
        {
            self.system
                .structure()
                .apply(&self.start, &self.tmp, &mut self.f);
            self.base_noise = V::Real::epsilon() * h.abs() * ops::norm_inf(self.f.as_slice());
        }
        let continued = self.start.as_slice() == self.last.as_slice();
        let solved = if self.mechanical.is_some() {
            self.solve_reduced(h, continued)
        } else {
            self.solve_full(h)
        };
        let report = solved?;
        self.stats.record(&report);
        // The full path's account from its last residual, evaluated at the solution (before
        // the projection reuses the scratch).
        let full = self.mechanical.is_none().then(|| self.full_account(h));
        let delta = &self.z.as_slice()[..n];
        if let Some(component) = ops::first_non_finite(self.z.as_slice()) {
            self.forget_step_jacobian();
            return Err(StepError::NonFinite {
                component: component.min(n - 1),
            });
        }
        // x' = x + δ, compensated (only for the state this flow returned last).
        self.after_step.copy_from(&self.start);
        if self.start.as_slice() != self.last.as_slice() {
            ops::fill_zero(self.comp.as_mut_slice());
        }
        self.comp_next.copy_from(&self.comp);
        ops::add_compensated(
            self.after_step.as_mut_slice(),
            delta,
            self.comp_next.as_mut_slice(),
        );
        // Hidden-constraint projection x'' = x' + M(x') G(x')ᵀ ν, φ(x'') = 0.
        self.last.copy_from(&self.after_step);
        if self.hidden.is_some() {
            ops::fill_zero(&mut self.nu);
            let Some(hidden) = self.hidden.as_mut() else {
                unreachable!("the hidden projection checked above");
            };
            let solved = step_end::project(
                hidden,
                &self.system,
                &self.after_step,
                &mut self.xe,
                &mut self.tmp,
                &mut self.t2,
                &mut self.nu,
            );
            let report = match solved {
                Ok(r) => r,
                Err(e) => {
                    if let Some(HiddenSolver::General(n)) = self.hidden.as_mut() {
                        n.invalidate_jacobian();
                    }
                    return Err(newton_error("hidden-constraint projection", e));
                }
            };
            self.stats.record(&report);
            self.last.copy_from(&self.xe);
        }
        if let Some(component) = ops::first_non_finite(self.last.as_slice()) {
            self.forget_step_jacobian();
            return Err(StepError::NonFinite { component });
        }
        core::mem::swap(&mut self.comp, &mut self.comp_next);
        for (l, &e) in self.lambda.iter_mut().zip(&self.z.as_slice()[n..]) {
            *l = e / h;
        }
        self.last_h = h;
        self.have_step = true;
        x.copy_from(&self.last);
        let (removed, supplied) = match full {
            Some((damping, supplied)) => (self.removed_by_projection() - damping, supplied),
            None => self.account(h),
        };
        ledger.dissipated = ledger.dissipated + removed;
        if self.forcing.is_some() {
            ledger.supplied = ledger.supplied + supplied;
            ledger.t = t0 + h;
        }
        Ok(())
    }
    fn order(&self) -> u32 {
        2
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
}
