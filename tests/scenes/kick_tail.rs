//! A projected `kick ∘ drift ∘ kick` solves for `λ_k` on its lead `drift ∘ kick` and applies the
//! trailing kick once: the same map (the kick cannot change `g`), one force evaluation a step,
//! and a flow that calls itself a kick but moves positions is caught, not trusted.

use faer::Col;
use lieflow::error::StepError;
use lieflow::flow::{FlowExt, Ledger, from_fn};
use lieflow::models::sphere_particles::SphereParticles;
use lieflow::{Flow, HolonomicConstraint};

use crate::scene_text;

use scene_text::{parse, run_scene};

/// Ten particles on the unit sphere, repelling logarithmically, damped; nothing observed.
fn shell(dt: f64, t_end: f64, order: u32) -> String {
    format!(
        r#"version = 1
dim = 3
[[shells]]
name = "p"
radius = 1.0
mass = 1.0
rings = [1, 4, 4, 1]
[[effects]]
type = "pair"
law = "log"
strength = 1.0
[[effects]]
type = "damping"
coefficient = 0.5
[flags]
energy = false
residuals = false
[integrator]
dt = {dt}
t_end = {t_end}
order = {order}
"#
    )
}

fn pair_evaluations(text: &str) -> (u64, usize) {
    let s = run_scene(&parse(text));
    assert_eq!(s.error, None);
    let pair = s.effects.iter().find(|e| e.kind == "pair").unwrap();
    (pair.evaluations, s.steps)
}

#[test]
fn a_projected_step_evaluates_the_pair_force_once() {
    // Small steps (one Newton iteration) and large ones (several): the λ_k iterations run the
    // lead only, whose leading kick is at the positions the last trailing kick saw.
    for dt in [0.01, 0.25] {
        let (evaluations, steps) = pair_evaluations(&shell(dt, 5.0, 2));
        // One per step, and the first step's leading kick (the compile's checks of the
        // initial state may add one).
        let steps = steps as u64;
        assert!(
            (steps + 1..=steps + 2).contains(&evaluations),
            "dt = {dt}: {evaluations} pair evaluations in {steps} steps"
        );
    }
    // Extrapolated to order 8 (rows of 1, 2, 3, 4 steps from the same start): one per sub-step
    // and one for each row's first kick, at the start's positions.
    let (evaluations, steps) = pair_evaluations(&shell(0.25, 5.0, 8));
    assert!(
        evaluations <= (10 + 4) * steps as u64 + 2,
        "{evaluations} pair evaluations in {steps} steps of 10 sub-steps"
    );
}

/// The model's kick as a closure flow that does not say it is one.
fn unmarked(model: &SphereParticles<f64>) -> impl Flow<Col<f64>> + use<> {
    let mut kick = model.kick::<Col<f64>>();
    from_fn(move |h: f64, x: &mut Col<f64>| kick.step(h, x).unwrap())
}

fn particles() -> (SphereParticles<f64>, Col<f64>) {
    let model = SphereParticles::<f64>::row(4, 2.0).unwrap();
    let n = model.particles();
    let x0: Col<f64> = model.at_rest(|i| 0.4 + 0.5 * i as f64 / n as f64, |i| 1.3 * i as f64);
    (model, x0)
}

#[test]
fn the_lead_and_the_tail_are_the_step() {
    let (model, mut x0) = particles();
    // Some momentum, so that the drift moves the positions.
    let nq = x0.nrows() / 2;
    for i in 0..nq {
        x0[nq + i] = 0.1 * (i as f64 + 1.0).sin();
    }
    let mut marked = model.kick::<Col<f64>>().strang(model.drift());
    let mut plain = unmarked(&model).strang(model.drift());
    assert!(!marked.is_kick() && model.kick::<Col<f64>>().is_kick());
    let (mut a, mut b) = (x0.clone(), x0.clone());
    let (mut la, mut lb) = (Ledger::default(), Ledger::default());
    marked.prepare(&a);
    marked.step_lead(&mut la, 0.1, &mut a).unwrap();
    // The lead left the trailing kick out: positions already final, momenta not.
    plain.step_at(&mut lb, 0.1, &mut b).unwrap();
    assert!((0..nq).all(|i| a[i].to_bits() == b[i].to_bits()));
    assert!((nq..2 * nq).any(|i| a[i] != b[i]));
    marked.step_tail(&mut la, 0.1, &mut a).unwrap();
    for i in 0..2 * nq {
        assert_eq!(a[i].to_bits(), b[i].to_bits(), "entry {i}");
    }
    // A flow without a kick has no tail: its lead is the whole step.
    let mut no_tail = model.drift::<Col<f64>>().strang(model.kick());
    let (mut c, mut lc) = (x0.clone(), Ledger::default());
    no_tail.step_lead(&mut lc, 0.1, &mut c).unwrap();
    let mut d = x0.clone();
    model
        .drift::<Col<f64>>()
        .strang(model.kick())
        .step(0.1, &mut d)
        .unwrap();
    assert!((0..2 * nq).all(|i| c[i].to_bits() == d[i].to_bits()));
}

#[test]
fn the_projected_step_with_a_tail_is_the_same_map() {
    let (model, x0) = particles();
    let options = model.projection_options();
    let mut marked = model
        .kick::<Col<f64>>()
        .strang(model.drift())
        .projected(model.system(), &x0, options)
        .unwrap();
    let mut plain = unmarked(&model)
        .strang(model.drift())
        .projected(model.system(), &x0, options)
        .unwrap();
    let (mut a, mut b) = (x0.clone(), x0.clone());
    let mut g = vec![0.0_f64; model.particles()];
    for _ in 0..200 {
        marked.step(0.05, &mut a).unwrap();
        plain.step(0.05, &mut b).unwrap();
        model.system().constraint.residual(&a, &mut g);
        // The Newton tolerance: g at the rounding level of positions far from the origin.
        assert!(g.iter().all(|v| v.abs() <= options.newton.ftol), "{g:?}");
    }
    // The two solve the same equations to the Newton tolerance, from different Jacobians.
    let gap = (0..a.nrows())
        .map(|i| (a[i] - b[i]).abs())
        .fold(0.0, f64::max);
    assert!(gap < 1e-12, "{gap}");
}

#[test]
fn a_flow_that_moves_positions_cannot_pass_as_a_kick() {
    let (model, x0) = particles();
    let nq = x0.nrows() / 2;
    // "Kick" that also nudges every position outwards: g changes after the λ_k solve.
    let liar = from_fn(move |h: f64, x: &mut Col<f64>| {
        for i in 0..nq {
            x[i] *= 1.0 + 1e-3 * h;
        }
    })
    .kick();
    let mut flow = liar
        .strang(model.drift())
        .projected(model.system(), &x0, model.projection_options())
        .unwrap();
    let mut x = x0.clone();
    let err = flow.step(0.05, &mut x).unwrap_err();
    assert!(matches!(err, StepError::CouplingViolated { .. }), "{err:?}");
    assert!((0..x.nrows()).all(|i| x[i].to_bits() == x0[i].to_bits()));
}
