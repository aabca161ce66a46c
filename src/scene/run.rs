//! Running a compiled scene: the stepping loop, the diagnostics the scene asked for, and the
//! run's summary.

use super::model::SceneModel;
use crate::error::StepError;
use crate::flow::{Flow, FlowStats};
use crate::system::{Hamiltonian, HolonomicConstraint, StructureMatrix, System};
use crate::vector::{Vector, ops};
use serde::Serialize;
use std::sync::Arc;
use std::time::Instant;

/// One assembled term and what it cost in a run.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EffectReport {
    /// The label (the effect's `name`, or its type).
    pub name: String,
    /// The kind (`gravity`, `spring`, …).
    pub kind: &'static str,
    /// Evaluations of the term (energy, gradient, Hessian products, flows, `M` products).
    pub evaluations: u64,
    /// Share of the run's time (stepping and the diagnostics after each step) spent in the
    /// term (with the `profile` diagnostic).
    pub time_share: Option<f64>,
}

/// A simulation ready to step: a compiled scene or a built-in model.
pub trait Simulation {
    /// The state `x`.
    fn state(&self) -> &[f64];
    /// The time of the state.
    fn time(&self) -> f64;
    /// The step size.
    fn dt(&self) -> f64;
    /// One step. On error the state is unchanged (the last good state).
    fn step(&mut self) -> Result<(), StepError>;
    /// `H(x)`.
    fn energy(&self) -> f64;
    /// The dissipated power `∇Hᵀ R ∇H` at `x` (`None` without dissipation).
    fn dissipation_power(&self) -> Option<f64>;
    /// `(max |g(x)|, max |φ(x)|)`, `None` without constraints.
    fn residuals(&mut self) -> Option<(f64, f64)>;
    /// The assembled terms and their evaluation counts so far.
    fn effects(&self) -> Vec<EffectReport>;
    /// The scheme's work counters.
    fn stats(&self) -> FlowStats;
    /// `(dimension, bodies)` when the state is `(q, p)` of point bodies (for path plots).
    fn bodies(&self) -> Option<(usize, usize)>;
    /// Zeroes the terms' evaluation counters and clocks (a run starts with it, so that the
    /// evaluations of the compile-time checks do not count).
    fn reset_counters(&self) {}
    /// The constraint multipliers of the last step, `(λ_k + λ_{k+1})/2` — the multiplier `λ`
    /// of `x' = M (∇H + Gᵀλ)` at the step — when the scheme is a projection.
    fn multipliers(&self) -> Option<Vec<f64>> {
        None
    }
    /// An estimate of the 2-norm condition number of the mass-weighted Gram matrix
    /// `G W⁻¹ Gᵀ` at the current positions (the matrix every multiplier system of a scene is a
    /// perturbation of), for scenes with constraints; `None` otherwise. `Some(∞)` when it is
    /// singular to working precision.
    fn multiplier_condition(&mut self) -> Option<f64> {
        None
    }
}

/// A flow, its system and its state: the [`Simulation`] of a scene and of the built-in models.
pub(crate) struct ModelRun<V: Vector, Ms, H, C> {
    pub(crate) flow: Box<dyn Flow<V>>,
    pub(crate) system: System<Ms, H, C>,
    pub(crate) x: V,
    last: V,
    t1: V,
    t2: V,
    g: Vec<f64>,
    pub(crate) dt: f64,
    t0: f64,
    k: usize,
    pub(crate) model: Option<Arc<SceneModel>>,
    /// The Gram matrix of the condition estimate, built on first use.
    gram: Option<super::gram::MassGram>,
}

impl<V, Ms, H, C> ModelRun<V, Ms, H, C>
where
    V: Vector<Real = f64>,
{
    pub(crate) fn new(
        flow: Box<dyn Flow<V>>,
        system: System<Ms, H, C>,
        x: V,
        dt: f64,
        m: usize,
        model: Option<Arc<SceneModel>>,
    ) -> Self {
        let mut flow = flow;
        flow.prepare(&x);
        Self {
            flow,
            system,
            last: x.clone(),
            t1: x.zeros_like(),
            t2: x.zeros_like(),
            x,
            g: vec![0.0; m],
            dt,
            t0: 0.0,
            k: 0,
            model,
            gram: None,
        }
    }
}

impl<V, Ms, H, C> Simulation for ModelRun<V, Ms, H, C>
where
    V: Vector<Real = f64>,
    Ms: StructureMatrix<V>,
    H: Hamiltonian<V>,
    C: HolonomicConstraint<V>,
{
    fn state(&self) -> &[f64] {
        self.x.as_slice()
    }
    fn time(&self) -> f64 {
        self.t0 + self.k as f64 * self.dt
    }
    fn dt(&self) -> f64 {
        self.dt
    }
    fn step(&mut self) -> Result<(), StepError> {
        // Closed-form sub-flows cannot report a blow-up themselves: keep the last good state.
        self.last.copy_from(&self.x);
        self.flow.step(self.dt, &mut self.x)?;
        if let Some(component) = ops::first_non_finite(self.x.as_slice()) {
            self.x.copy_from(&self.last);
            return Err(StepError::NonFinite { component });
        }
        self.k += 1;
        Ok(())
    }
    fn energy(&self) -> f64 {
        self.system.hamiltonian.energy(&self.x)
    }
    fn dissipation_power(&self) -> Option<f64> {
        let model = self.model.as_ref()?;
        let damping = model.damping.as_ref()?;
        let (d, x) = (model.dim, self.x.as_slice());
        let p = &x[x.len() / 2..];
        let mut power = 0.0;
        for (b, c) in damping.per_body.iter().enumerate() {
            let w = model.inv_masses[b];
            for k in 0..d {
                let v = w * p[b * d + k];
                power += c * v * v;
            }
        }
        Some(power)
    }
    fn residuals(&mut self) -> Option<(f64, f64)> {
        if self.g.is_empty() {
            return None;
        }
        self.system.constraint.residual(&self.x, &mut self.g);
        let g = ops::norm_inf(&self.g);
        self.system
            .hidden_constraint(&self.x, &mut self.t1, &mut self.t2, &mut self.g);
        Some((g, ops::norm_inf(&self.g)))
    }
    fn effects(&self) -> Vec<EffectReport> {
        self.model.as_ref().map_or_else(Vec::new, |m| m.reports())
    }
    fn stats(&self) -> FlowStats {
        self.flow.stats()
    }
    fn bodies(&self) -> Option<(usize, usize)> {
        self.model.as_ref().map(|m| (m.space_dim(), m.bodies()))
    }
    fn reset_counters(&self) {
        if let Some(m) = &self.model {
            m.reset_counters();
        }
    }
    fn multipliers(&self) -> Option<Vec<f64>> {
        let (a, b) = self.flow.multipliers()?;
        Some(a.iter().zip(b).map(|(a, b)| 0.5 * (a + b)).collect())
    }
    fn multiplier_condition(&mut self) -> Option<f64> {
        let model = self.model.as_ref()?;
        if model.m == 0 {
            return None;
        }
        let x = self.x.as_slice();
        let q = &x[..x.len() / 2];
        if self.gram.is_none() {
            self.gram = super::gram::MassGram::new(model, q).ok();
        }
        let gram = self.gram.as_mut()?;
        Some(gram.condition_estimate(model, q))
    }
}

impl SceneModel {
    /// The assembled terms with their evaluation counts (and time shares when profiling).
    pub fn reports(&self) -> Vec<EffectReport> {
        let mut out = vec![EffectReport {
            name: "kinetic".into(),
            kind: "kinetic",
            evaluations: self.kinetic.evaluations(),
            time_share: None,
        }];
        for t in &self.potentials {
            out.push(EffectReport {
                name: t.label.clone(),
                kind: t.kind.name(),
                evaluations: t.counter.evaluations(),
                time_share: self.profile.then(|| t.counter.nanos() as f64),
            });
        }
        if let Some(t) = &self.damping {
            out.push(EffectReport {
                name: t.label.clone(),
                kind: "damping",
                evaluations: t.counter.evaluations(),
                time_share: None,
            });
        }
        if let Some(t) = &self.magnetic {
            out.push(EffectReport {
                name: t.label.clone(),
                kind: "magnetic",
                evaluations: t.counter.evaluations(),
                time_share: None,
            });
        }
        if !self.constraints.is_empty() {
            out.push(EffectReport {
                name: "constraints".into(),
                kind: "constraints",
                evaluations: self.constraint_counter.evaluations(),
                time_share: self.profile.then(|| self.constraint_counter.nanos() as f64),
            });
        }
        out
    }
}

/// What to compute during a run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunPlan {
    /// Steps to take.
    pub steps: usize,
    /// Evaluate `H` after every step.
    pub energy: bool,
    /// Evaluate `|g|` and `|φ|` after every step.
    pub residuals: bool,
}

/// The state after a step, with the diagnostics the plan asked for; passed to the run's observer.
#[derive(Debug, Clone, Copy)]
pub struct Sample<'a> {
    /// Step index (0 for the initial state).
    pub step: usize,
    /// Time.
    pub t: f64,
    /// The state.
    pub x: &'a [f64],
    /// `H(x)`, if asked for.
    pub energy: Option<f64>,
    /// `max |g(x)|`, if asked for and there are constraints.
    pub g: Option<f64>,
    /// `max |φ(x)|`, likewise.
    pub phi: Option<f64>,
}

/// Why a run stopped early.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RunFailure {
    /// The step that failed (the state is the one before it).
    pub step: usize,
    /// Its time.
    pub t: f64,
    /// The error's kind, e.g. `Newton`, `NonFinite`.
    pub kind: String,
    /// The error's message.
    pub message: String,
}

/// The summary of a run (printed as the command's final JSON line).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RunSummary {
    /// Final time reached.
    pub t: f64,
    /// Steps taken.
    pub steps: usize,
    /// Steps planned.
    pub steps_planned: usize,
    /// Step size.
    pub dt: f64,
    /// The final state.
    pub x: Vec<f64>,
    /// `max |g|` over the run (`None` without constraints or with the diagnostic off).
    pub max_abs_g: Option<f64>,
    /// `max |φ|` over the run, likewise.
    pub max_abs_phi: Option<f64>,
    /// `H` at the start (`None` with the energy diagnostic off).
    pub energy_initial: Option<f64>,
    /// `H` at the end.
    pub energy_final: Option<f64>,
    /// `max |H − H₀|` over the run.
    pub max_abs_energy_error: Option<f64>,
    /// `max (H_{k+1} − H_k)` over the steps. With damping, ≤ 0 when the dissipation per step
    /// dominates the splitting's `O(h³)` energy error, and ≤ 0 by construction with the
    /// discrete gradient.
    pub max_energy_increase: Option<f64>,
    /// Energy dissipated, `∫ ∇Hᵀ R ∇H dt` by the trapezoidal rule (with damping).
    pub dissipated: Option<f64>,
    /// `max |H − H₀ + dissipated|` over the run: the energy budget's error (with damping; the
    /// quadrature's `O(h²)` is part of it).
    pub max_energy_balance_error: Option<f64>,
    /// Per-term evaluation counts.
    pub effects: Vec<EffectReport>,
    /// Residual evaluations of the multiplier solves.
    pub residual_evaluations: u64,
    /// Newton iterations of the multiplier solves.
    pub newton_iterations: u64,
    /// Wall time per step, stepping only (diagnostics excluded).
    pub ns_per_step: f64,
    /// Why the run stopped early, if it did.
    pub error: Option<RunFailure>,
}

/// Runs `plan.steps` steps of `sim`, computing the planned diagnostics after every step and
/// passing each state to `observe` (also the initial one). A failing step ends the run: the
/// state stays the last good one and the summary's `error` says what happened.
pub fn run(
    sim: &mut dyn Simulation,
    plan: &RunPlan,
    observe: &mut dyn FnMut(&Sample<'_>),
) -> RunSummary {
    sim.reset_counters();
    let run_start = Instant::now();
    let e0 = plan.energy.then(|| sim.energy());
    let p0 = if plan.energy {
        sim.dissipation_power()
    } else {
        None
    };
    let mut last_e = e0;
    let mut last_power = p0;
    let mut dissipated = p0.map(|_| 0.0);
    let (mut max_de, mut max_inc, mut max_bal) = (0.0f64, f64::NEG_INFINITY, 0.0f64);
    let (mut max_g, mut max_phi) = (None::<f64>, None::<f64>);
    let mut sample = |sim: &mut dyn Simulation, step: usize, energy: Option<f64>| {
        let res = if plan.residuals {
            sim.residuals()
        } else {
            None
        };
        if let Some((g, phi)) = res {
            max_g = Some(max_g.unwrap_or(0.0).max(g));
            max_phi = Some(max_phi.unwrap_or(0.0).max(phi));
        }
        observe(&Sample {
            step,
            t: sim.time(),
            x: sim.state(),
            energy,
            g: res.map(|r| r.0),
            phi: res.map(|r| r.1),
        });
    };
    sample(sim, 0, e0);
    let mut stepping = std::time::Duration::ZERO;
    let mut error = None;
    let mut taken = 0;
    for k in 0..plan.steps {
        let start = Instant::now();
        let result = sim.step();
        stepping += start.elapsed();
        if let Err(e) = result {
            error = Some(RunFailure {
                step: k,
                t: sim.time(),
                kind: step_error_kind(&e).to_owned(),
                message: e.to_string(),
            });
            break;
        }
        taken += 1;
        let e = plan.energy.then(|| sim.energy());
        if let (Some(e), Some(e_prev), Some(e0)) = (e, last_e, e0) {
            max_de = max_de.max((e - e0).abs());
            max_inc = max_inc.max(e - e_prev);
            if let (Some(p_prev), Some(d)) = (last_power, dissipated.as_mut()) {
                let p = sim.dissipation_power().unwrap_or(0.0);
                *d += 0.5 * sim.dt() * (p + p_prev);
                last_power = Some(p);
                max_bal = max_bal.max((e - e0 + *d).abs());
            }
        }
        last_e = e;
        sample(sim, k + 1, e);
    }
    let stats = sim.stats();
    let effects = sim.effects();
    let total_ns = stepping.as_nanos() as f64;
    let run_ns = run_start.elapsed().as_nanos() as f64;
    let effects = effects
        .into_iter()
        .map(|mut r| {
            r.time_share = r
                .time_share
                .map(|ns| if run_ns > 0.0 { ns / run_ns } else { 0.0 });
            r
        })
        .collect();
    RunSummary {
        t: sim.time(),
        steps: taken,
        steps_planned: plan.steps,
        dt: sim.dt(),
        x: sim.state().to_vec(),
        max_abs_g: max_g,
        max_abs_phi: max_phi,
        energy_initial: e0,
        energy_final: last_e,
        max_abs_energy_error: e0.map(|_| max_de),
        max_energy_increase: (e0.is_some() && taken > 0).then_some(max_inc),
        dissipated,
        max_energy_balance_error: dissipated.map(|_| max_bal),
        effects,
        residual_evaluations: stats.residual_evaluations,
        newton_iterations: stats.newton_iterations,
        ns_per_step: if taken > 0 {
            total_ns / taken as f64
        } else {
            0.0
        },
        error,
    }
}

/// The variant name of a step error, for summaries.
fn step_error_kind(e: &StepError) -> &'static str {
    match e {
        StepError::Newton { .. } => "Newton",
        StepError::FixedPointNotConverged { .. } => "FixedPointNotConverged",
        StepError::NonFinite { .. } => "NonFinite",
        StepError::BadStepSize { .. } => "BadStepSize",
        StepError::BackwardDissipation { .. } => "BackwardDissipation",
        StepError::CouplingViolated { .. } => "CouplingViolated",
        StepError::StateLength { .. } => "StateLength",
        StepError::OffManifold { .. } => "OffManifold",
    }
}
