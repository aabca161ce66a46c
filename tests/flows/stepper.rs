//! The stepping object every driver is built on: the same trajectory as `integrate`, bit for
//! bit; a step that fails or produces a non-finite state leaves state and time as they were;
//! time is `t₀ + k h`.

use lieflow::flow::from_fn;
use lieflow::models::paper;
use lieflow::prelude::*;
use nalgebra::SVector;

type V = SVector<f64, 4>;

#[test]
fn stepper_and_integrate_agree_bit_for_bit() {
    let x0: V = paper::initial_state();
    let build = || {
        paper::drift()
            .projected(paper::system(), &x0, ProjectionOptions::default())
            .expect("the paper's example projects")
            .triple_jump()
    };
    let (h, steps) = (0.05, 400);
    let mut flow = build();
    let mut x = x0;
    integrate(&mut flow, &mut x, 0.0, h, steps, &mut ()).expect("the run succeeds");

    let mut stepper = Stepper::new(build(), x0, 0.0, h).expect("finite initial state");
    for _ in 0..steps {
        stepper.step().expect("every step succeeds");
    }
    assert_eq!(stepper.state(), &x, "same map, same order of operations");
    assert_eq!(stepper.steps_taken(), steps);
    // t = t0 + k h, not a running sum of h.
    assert_eq!(stepper.time(), steps as f64 * h);
}

#[test]
fn a_non_finite_step_is_undone_and_reported() {
    // A closed-form flow that blows up on its third step.
    let mut calls = 0;
    let flow = from_fn(move |h: f64, x: &mut V| {
        calls += 1;
        x[0] += if calls == 3 { f64::INFINITY } else { h };
    });
    let mut stepper = Stepper::new(flow, V::zeros(), 1.0, 0.25).expect("finite initial state");
    stepper.step().expect("first step");
    stepper.step().expect("second step");
    let before = *stepper.state();
    let err = stepper.step().expect_err("the third step yields infinity");
    assert!(
        matches!(err, StepError::NonFinite { component: 0 }),
        "{err}"
    );
    assert_eq!(stepper.state(), &before, "the state is the last good one");
    assert_eq!(stepper.steps_taken(), 2);
    assert_eq!(stepper.time(), 1.5);
}

#[test]
fn a_non_finite_initial_state_is_refused() {
    let mut x0 = V::zeros();
    x0[2] = f64::NAN;
    let flow = from_fn(|_h: f64, _x: &mut V| {});
    match Stepper::new(flow, x0, 0.0, 0.1) {
        Err(IntegrateError::NonFiniteInitialState { component }) => assert_eq!(component, 2),
        Err(other) => panic!("unexpected {other}"),
        Ok(_) => panic!("NaN in the initial state was accepted"),
    }
}

#[test]
fn advance_reports_the_failing_step_and_its_time() {
    let mut calls = 0;
    let flow = from_fn(move |_h: f64, x: &mut V| {
        calls += 1;
        x[1] = if calls == 5 { f64::NAN } else { calls as f64 };
    });
    let mut seen = Vec::new();
    let mut stepper = Stepper::new(flow, V::zeros(), 0.0, 0.5).expect("finite initial state");
    let err = stepper
        .advance(10, &mut |k: usize, t: f64, _x: &V| seen.push((k, t)))
        .expect_err("step 4 (0-based) yields NaN");
    match err {
        IntegrateError::Step { step, t, .. } => assert_eq!((step, t), (4, 2.0)),
        other => panic!("unexpected {other}"),
    }
    assert_eq!(seen, vec![(1, 0.5), (2, 1.0), (3, 1.5), (4, 2.0)]);
    assert_eq!(stepper.state()[1], 4.0);
}
