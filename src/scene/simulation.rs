//! The object-safe face of a run — a [`Stepper`], its system and, for scenes, its model —
//! shared by compiled scenes and the built-in models.

use crate::error::{IntegrateError, StepError};
use crate::flow::{Flow, FlowStats};
pub use crate::scene::effect_report::EffectReport;
use crate::scene::effects::dissipated_power;
use crate::scene::gram::MassGram;
use crate::scene::model::SceneModel;
pub use crate::scene::simulation_checkpoint::SimulationCheckpoint;
use crate::scene::watch::{EventRecord, Watch};
use crate::stepper::{Checkpoint, Events, Stepper};
use crate::system::Reprojection;
use crate::system::{Hamiltonian, HolonomicConstraint, Model};
use crate::vector::{Vector, ops};
use std::sync::Arc;

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
    /// One step of the scheme's own size toward `t_end`: an adaptive scheme's next accepted
    /// step (see [`Stepper::step_own`]), with the events located in it as [`step`](Self::step)
    /// locates them. Returns the step taken; `None` when the time is `t_end` already or the
    /// scheme has no steps of its own (a fixed step size: [`step`](Self::step) and
    /// [`advance_to`](Self::advance_to) take its steps).
    ///
    /// # Errors
    /// The step's error (the state is the last good one).
    fn step_own(&mut self, t_end: f64) -> Result<Option<f64>, StepError> {
        let _ = t_end;
        Ok(None)
    }
    /// Calls `observe` with the simulation showing its state at `t` inside its last step —
    /// the adaptive extrapolation's polynomial with `dense = true`, projected — then returns
    /// to the step's end, from where the run goes on. `Ok(false)`, nothing called, without.
    ///
    /// # Errors
    /// The dense output's projection failing (the state is the step's end).
    fn observe_at(
        &mut self,
        t: f64,
        observe: &mut dyn FnMut(&mut dyn Simulation),
    ) -> Result<bool, StepError> {
        let _ = (t, observe);
        Ok(false)
    }
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
    /// What the step controller did, when the scene gives a tolerance.
    fn adaptive_stats(&self) -> Option<crate::flow::AdaptiveStats> {
        None
    }
    /// `(dimension, bodies)` when the state is `(q, p)` of point bodies (for path plots).
    fn bodies(&self) -> Option<(usize, usize)>;
    /// Zeroes the terms' evaluation counters and clocks (a run starts with it, so that the
    /// evaluations of the compile-time checks do not count).
    fn reset_counters(&self) {}
    /// Energy supplied through the inputs so far, as the flow books it exactly (`None` without
    /// inputs).
    fn supplied(&self) -> Option<f64> {
        None
    }
    /// Energy dissipated so far, when the flow books it exactly (the damping's closed-form
    /// sub-flow in a splitting); `None` otherwise.
    fn dissipated(&self) -> Option<f64> {
        None
    }
    /// Whether the caller reads [`dissipated`](Self::dissipated) from now on. Without a reader
    /// (nor an output of the scene) its flows skip the books' work (`Books`), the motion the
    /// same to the bit, and `dissipated` is `None` from then on, in a checkpoint's too.
    fn read_books(&mut self, _read: bool) {}
    /// The names of the declared outputs.
    fn output_names(&self) -> Vec<String> {
        Vec::new()
    }
    /// The names of the state's components: `q.<body>.<axis>` then `p.<body>.<axis>` for a
    /// scene of bodies, `x<i>` otherwise.
    fn state_names(&self) -> Vec<String> {
        (0..self.state().len()).map(|i| format!("x{i}")).collect()
    }
    /// The velocities `v = p/m` of a scene's bodies (in the order of the positions) into
    /// `out`, and `true`; `false` (and `out` empty) when the state has no bodies.
    fn velocities(&self, out: &mut Vec<f64>) -> bool {
        out.clear();
        false
    }
    /// One name per constraint row (the multipliers' columns): the constraint's `name`, or
    /// its kind and bodies (`rod:a-b`).
    fn multiplier_names(&self) -> Vec<String> {
        Vec::new()
    }
    /// The declared outputs at the current state, into `out` (allocates nothing once `out`
    /// has room).
    fn outputs(&mut self, out: &mut Vec<f64>) {
        out.clear();
    }
    /// The events that happened so far.
    fn events(&self) -> &[EventRecord] {
        &[]
    }
    /// The name of the event that stopped the run, if one did.
    fn stopped(&self) -> Option<&str> {
        None
    }
    /// The names of the declared inputs.
    fn input_names(&self) -> Vec<String> {
        Vec::new()
    }
    /// Sets the `held` input `name` to `value` from now on (zero-order hold).
    ///
    /// # Errors
    /// The input does not exist or is not `held` (its signal is a function of time).
    fn set_input(&mut self, name: &str, value: f64) -> Result<(), String> {
        let _ = value;
        Err(format!(
            "no input '{name}': this simulation declares no inputs"
        ))
    }
    /// The value of input `name` at the current time.
    fn input(&self, name: &str) -> Option<f64> {
        let _ = name;
        None
    }
    /// Steps until the time is `t`: steps of `dt` while they fit, then one shorter step that
    /// lands on `t` (see [`Stepper::advance_to`]); stops early at a `stop` event. Returns the
    /// steps taken.
    ///
    /// # Errors
    /// The failing step's error (the state is the last good one).
    fn advance_to(&mut self, t: f64) -> Result<usize, StepError>;
    /// A checkpoint of everything the continuation depends on (see [`Stepper::save`]).
    fn save(&mut self) -> SimulationCheckpoint;
    /// Restores a checkpoint of this simulation: the continuation equals, bit for bit, the
    /// run that went on after it was saved.
    ///
    /// # Errors
    /// A checkpoint of another simulation.
    fn restore(&mut self, checkpoint: &SimulationCheckpoint) -> Result<(), String>;
    /// Replaces the state (an external change: an impulse, a reset). With `reproject`, the new
    /// state is projected onto `g = 0`, `φ = 0` (see [`reproject`]) and the report says how
    /// far it moved; without, a state off the constraints is refused by the next step.
    ///
    /// # Errors
    /// A state of the wrong length or not finite, or a re-projection that did not converge
    /// (the state is then unchanged).
    fn set_state(&mut self, x: &[f64], reproject: bool) -> Result<Option<Reprojection>, String>;
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
    /// Names what this simulation is — its scene's name and a fingerprint of the compiled
    /// scene and scheme — so that a checkpoint of another one is refused at
    /// [`restore`](Self::restore) (set by [`compile`](crate::scene::compile)).
    fn set_identity(&mut self, _name: String, _fingerprint: u64) {}
}

/// A [`Stepper`] and the flow's system: the [`Simulation`] of a scene and of the built-in
/// models.
pub(crate) struct ModelRun<V: Vector, Sys> {
    stepper: Stepper<V, Box<dyn Flow<V>>>,
    pub(crate) system: Sys,
    t1: V,
    t2: V,
    g: Vec<f64>,
    pub(crate) model: Option<Arc<SceneModel>>,
    /// The Gram matrix of the condition estimate, built on first use.
    gram: Option<MassGram>,
    /// Outputs, events and exact energy accounts (scenes).
    pub(crate) watch: Option<Watch<V>>,
    /// The scene's name and fingerprint ([`Simulation::set_identity`]).
    identity: Option<(String, u64)>,
    /// Steps were taken with the books off ([`Simulation::read_books`]): no total dissipated.
    unbooked: bool,
    /// Where the step's end waits while a dense state is shown ([`Simulation::observe_at`]).
    end: Option<V>,
}

impl<V, Sys> ModelRun<V, Sys>
where
    V: Vector<Real = f64>,
{
    pub(crate) fn new(
        flow: Box<dyn Flow<V>>,
        system: Sys,
        x: V,
        dt: f64,
        m: usize,
        model: Option<Arc<SceneModel>>,
    ) -> Result<Self, IntegrateError> {
        let (t1, t2) = (x.zeros_like(), x.zeros_like());
        Ok(Self {
            stepper: Stepper::new(flow, x, 0.0, dt)?,
            system,
            t1,
            t2,
            g: vec![0.0; m],
            model,
            gram: None,
            watch: None,
            identity: None,
            unbooked: false,
            end: None,
        })
    }
}

impl<V: Vector<Real = f64>, Sys> ModelRun<V, Sys> {
    /// A step of `h` (`None`) or of `short` off the grid, watching the events if any.
    fn watched_step(&mut self, short: Option<f64>) -> Result<(), StepError> {
        self.events_step(short)?;
        self.unwrap_joints();
        Ok(())
    }

    /// Joint angles unwrap against the last step's (less than half a turn a step).
    fn unwrap_joints(&self) {
        if let Some(w) = &self.watch {
            w.joints
                .advance(&self.stepper.state().as_slice()[..self.stepper.state().len() / 2]);
        }
    }

    /// A step of the flow's own size toward `t_end`, locating the events if any; the step
    /// taken, `None` when none was.
    fn events_own_step(&mut self, t_end: f64) -> Result<Option<f64>, StepError> {
        let Some(Watch {
            events: Some(events),
            ..
        }) = self.watch.as_mut()
        else {
            return self.stepper.step_own(t_end);
        };
        let Some((taken, hit)) = self.stepper.step_own_with_events(t_end, events)? else {
            return Ok(None);
        };
        if let (Some(hit), Some(w)) = (hit, self.watch.as_mut()) {
            w.record(hit, self.stepper.steps_taken());
        }
        Ok(Some(taken))
    }

    /// A step of `h` (`None`) or of `short`, locating the events if any.
    ///
    /// An adaptive flow's accepted steps are each watched: the events located at the
    /// resolution it integrates at, the joint angles unwrapped at each (a report interval may
    /// hold several crossings and turns).
    fn events_step(&mut self, short: Option<f64>) -> Result<(), StepError> {
        let adaptive = self.stepper.flow().adaptive_stats().is_some();
        let (has_events, turns) = self.watch.as_ref().map_or((false, false), |w| {
            (w.events.is_some(), adaptive && w.joints.reads_angles())
        });
        if !has_events && !turns {
            return match short {
                None => self.stepper.step(),
                Some(h) => self.stepper.step_off_grid(h),
            };
        }
        let Some(w) = self.watch.as_mut() else {
            return Ok(());
        };
        let joints = w.joints.clone();
        let mut events = w.events.take().unwrap_or_else(|| Events::new(Vec::new()));
        let mut each = |x: &V| joints.advance(&x.as_slice()[..x.len() / 2]);
        let stepped = self.stepper.step_watched(short, &mut events, &mut each);
        let step = self.stepper.steps_taken();
        if let Some(w) = self.watch.as_mut() {
            for &hit in events.hits() {
                w.record(hit, step);
            }
            if has_events {
                w.events = Some(events);
            }
        }
        stepped.map(|_| ())
    }
}

impl<V, Sys> Simulation for ModelRun<V, Sys>
where
    V: Vector<Real = f64>,
    Sys: Model<V>,
{
    fn state(&self) -> &[f64] {
        self.stepper.state().as_slice()
    }
    fn time(&self) -> f64 {
        self.stepper.time()
    }
    fn dt(&self) -> f64 {
        self.stepper.step_size()
    }
    fn step(&mut self) -> Result<(), StepError> {
        self.watched_step(None)
    }
    fn step_own(&mut self, t_end: f64) -> Result<Option<f64>, StepError> {
        let taken = self.events_own_step(t_end)?;
        if taken.is_some() {
            self.unwrap_joints();
        }
        Ok(taken)
    }
    fn observe_at(
        &mut self,
        t: f64,
        observe: &mut dyn FnMut(&mut dyn Simulation),
    ) -> Result<bool, StepError> {
        if self.stepper.flow().adaptive_stats().is_none() {
            return Ok(false);
        }
        // Allocated once and kept (what it holds is overwritten; a failed show drops it).
        let mut end = self
            .end
            .take()
            .unwrap_or_else(|| self.stepper.state().clone());
        let kept = self.stepper.show(t, &mut end)?;
        observe(self);
        self.stepper.resume(kept, &mut end);
        self.end = Some(end);
        Ok(true)
    }
    fn input_names(&self) -> Vec<String> {
        self.model
            .as_ref()
            .and_then(|m| m.inputs())
            .map_or_else(Vec::new, |i| i.names().to_vec())
    }
    fn set_input(&mut self, name: &str, value: f64) -> Result<(), String> {
        let inputs = self.model.as_ref().and_then(|m| m.inputs());
        let Some(inputs) = inputs else {
            return Err(format!("no input '{name}': the scene declares no inputs"));
        };
        let j = inputs
            .index(name)
            .ok_or_else(|| format!("no input '{name}' (inputs: {})", inputs.names().join(", ")))?;
        if !value.is_finite() {
            return Err(format!("input '{name}' = {value}: not finite"));
        }
        let held = inputs.held(j).ok_or_else(|| {
            format!("input '{name}' follows its signal; only `held` inputs are set between steps")
        })?;
        held.set(value);
        Ok(())
    }
    fn input(&self, name: &str) -> Option<f64> {
        let inputs = self.model.as_ref()?.inputs()?;
        Some(inputs.value(inputs.index(name)?, self.stepper.time()))
    }
    fn advance_to(&mut self, t: f64) -> Result<usize, StepError> {
        if !t.is_finite() {
            return Err(StepError::BadStepSize {
                h: t - self.stepper.time(),
            });
        }
        let start = self.stepper.steps_taken();
        while self.stopped().is_none() {
            match self.stepper.next_step_to(t, start) {
                Some(short) => self.watched_step(short)?,
                None => break,
            }
        }
        Ok(self.stepper.steps_taken() - start)
    }
    fn save(&mut self) -> SimulationCheckpoint {
        let checkpoint = self.stepper.save();
        let events = self.watch.as_ref().and_then(|w| {
            w.events
                .as_ref()
                .map(|e| (e.values().to_vec(), w.log.len()))
        });
        SimulationCheckpoint {
            state: Box::new(checkpoint),
            identity: self.identity.clone(),
            events,
            joints: self.watch.as_ref().map(|w| w.joints.save()),
            unbooked: self.unbooked,
        }
    }
    fn set_identity(&mut self, name: String, fingerprint: u64) {
        self.identity = Some((name, fingerprint));
    }
    fn restore(&mut self, checkpoint: &SimulationCheckpoint) -> Result<(), String> {
        if let (Some((theirs, a)), Some((ours, b))) = (&checkpoint.identity, &self.identity)
            && a != b
        {
            return Err(format!(
                "the checkpoint was saved from scene '{theirs}' (fingerprint {a:016x}), not from this simulation of scene '{ours}' ({b:016x}): a checkpoint restores only into the scene and scheme it was saved from"
            ));
        }
        let saved = checkpoint
            .state
            .downcast_ref::<Checkpoint<V>>()
            .ok_or("a checkpoint of another kind of simulation")?;
        self.stepper.restore(saved).map_err(|e| e.to_string())?;
        if let (Some(w), Some((values, logged))) = (self.watch.as_mut(), &checkpoint.events) {
            if let Some(events) = w.events.as_mut() {
                events.set_values(values);
            }
            w.log.truncate(*logged);
        }
        if let (Some(w), Some(saved)) = (self.watch.as_ref(), &checkpoint.joints) {
            w.joints.restore(saved);
        }
        // A ledger without its total stays without one (also in a recompiled simulation).
        self.unbooked |= checkpoint.unbooked;
        Ok(())
    }
    fn set_state(&mut self, x: &[f64], reproject: bool) -> Result<Option<Reprojection>, String> {
        let n = self.stepper.state().len();
        if x.len() != n {
            return Err(format!("a state of {} values for a state of {n}", x.len()));
        }
        if let Some(i) = x.iter().position(|v| !v.is_finite()) {
            return Err(format!("state component {i} is not finite"));
        }
        let mut next = self.stepper.state().clone();
        next.as_mut_slice().copy_from_slice(x);
        let report = if reproject && !self.g.is_empty() {
            let tol = 16.0 * f64::EPSILON * x.iter().fold(1.0f64, |s, v| s.max(v.abs()));
            Some(
                crate::system::reproject(&self.system, &mut next, tol, true)
                    .map_err(|e| e.to_string())?,
            )
        } else {
            None
        };
        self.stepper.state_mut().copy_from(&next);
        // A state changed from outside a step: the flow keeps nothing of the old one.
        self.stepper.flow_mut().prepare(&next);
        Ok(report)
    }
    /// Booked by the flow, or carried over from before a parameter change.
    fn supplied(&self) -> Option<f64> {
        let s = self.stepper.ledger().supplied;
        let books = self.watch.as_ref().is_some_and(|w| w.supplied);
        (books || s != 0.0).then_some(s)
    }
    fn read_books(&mut self, read: bool) {
        let Some(model) = &self.model else {
            return;
        };
        // The scene's own outputs read the books whatever the caller does.
        let on = read || self.watch.as_ref().is_some_and(Watch::reads_dissipated);
        model.books.set(on);
        self.unbooked |= !on;
    }
    fn dissipated(&self) -> Option<f64> {
        if self.unbooked {
            return None;
        }
        let d = self.stepper.ledger().dissipated;
        let books = self.watch.as_ref().is_some_and(|w| w.dissipated);
        (books || d != 0.0).then_some(d)
    }
    fn state_names(&self) -> Vec<String> {
        match &self.model {
            Some(m) if m.state_names.len() == self.state().len() => m.state_names.clone(),
            _ => (0..self.state().len()).map(|i| format!("x{i}")).collect(),
        }
    }
    fn velocities(&self, out: &mut Vec<f64>) -> bool {
        out.clear();
        let Some(model) = &self.model else {
            return false;
        };
        let x = self.state();
        let p = &x[x.len() / 2..];
        let d = model.dim;
        out.extend(
            p.iter()
                .enumerate()
                .map(|(i, &pi)| pi * model.inv_masses[i / d]),
        );
        true
    }
    fn multiplier_names(&self) -> Vec<String> {
        self.model
            .as_ref()
            .map_or_else(Vec::new, |m| m.multiplier_names.clone())
    }
    fn output_names(&self) -> Vec<String> {
        self.watch.as_ref().map_or_else(Vec::new, |w| {
            w.outputs.iter().map(|o| o.name.clone()).collect()
        })
    }
    fn outputs(&mut self, out: &mut Vec<f64>) {
        out.clear();
        let Some(w) = self.watch.as_mut() else {
            return;
        };
        let l = self.stepper.ledger();
        w.values(
            self.stepper.time(),
            self.stepper.state().as_slice(),
            self.stepper.flow().multipliers(),
            (l.supplied, l.dissipated),
            out,
        );
    }
    fn events(&self) -> &[EventRecord] {
        self.watch.as_ref().map_or(&[], |w| &w.log)
    }
    fn stopped(&self) -> Option<&str> {
        let w = self.watch.as_ref()?;
        w.log.iter().find(|e| e.stop).map(|e| e.name.as_str())
    }
    fn energy(&self) -> f64 {
        self.system.hamiltonian().energy(self.stepper.state())
    }
    fn dissipation_power(&self) -> Option<f64> {
        let model = self.model.as_ref()?;
        if !model.is_dissipative() {
            // A damping declared zero dissipates nothing, and says so.
            return model.zero_damping.then_some(0.0);
        }
        let x = self.state();
        let p = &x[x.len() / 2..];
        let mut power = model.damping.as_ref().map_or(0.0, |damping| {
            dissipated_power(&damping.per_body, &model.inv_masses, p, model.dim)
        });
        if let Some(dashpots) = &model.dashpots {
            power += dashpots.power(&model.inv_masses, p, model.dim);
        }
        if let Some(dampers) = &model.hinge_dampers {
            power += dampers.power(&model.inv_masses, &x[..x.len() / 2], p);
        }
        Some(power)
    }
    fn residuals(&mut self) -> Option<(f64, f64)> {
        if self.g.is_empty() {
            return None;
        }
        let x = self.stepper.state();
        self.system.constraint().residual(x, &mut self.g);
        let g = ops::norm_inf(&self.g);
        self.system
            .hidden_constraint(x, &mut self.t1, &mut self.t2, &mut self.g);
        Some((g, ops::norm_inf(&self.g)))
    }
    fn effects(&self) -> Vec<EffectReport> {
        self.model.as_ref().map_or_else(Vec::new, |m| m.reports())
    }
    fn stats(&self) -> FlowStats {
        self.stepper.flow().stats()
    }
    fn adaptive_stats(&self) -> Option<crate::flow::AdaptiveStats> {
        self.stepper.flow().adaptive_stats()
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
        let (a, b) = self.stepper.flow().multipliers()?;
        if self.stepper.steps_taken() == 0 {
            // No step has solved for them yet.
            return Some(vec![f64::NAN; a.len()]);
        }
        Some(a.iter().zip(b).map(|(a, b)| 0.5 * (a + b)).collect())
    }
    fn multiplier_condition(&mut self) -> Option<f64> {
        let model = self.model.as_ref()?;
        if model.m == 0 {
            return None;
        }
        let x = self.stepper.state().as_slice();
        let q = &x[..x.len() / 2];
        if self.gram.is_none() {
            self.gram = MassGram::new(model, q).ok();
        }
        let gram = self.gram.as_mut()?;
        Some(gram.condition_estimate(model, q))
    }
}
