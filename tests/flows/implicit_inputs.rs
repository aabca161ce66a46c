//! The projected midpoint rule and the constrained discrete gradient of an open system
//! `x' = M (∇H + Gᵀλ) + B(x) u(t)`: the damped pendulum driven at its pivot. Order 2 with the
//! time-dependent torque (and order 4 for the midpoint rule composed, undamped: its step is
//! symmetric in `(t, x)`), the discrete gradient's balance `H_{n+1} − H_n = −D_n + S_n` at every
//! step, constraints at round-off, non-finite inputs named, inputs it cannot take refused.

use crate::common;
use crate::driven::{PivotTorque, THETA0, V, model_with, reference_with, signal};
use common::fitted_order;
use lieflow::flow::{
    CompositionTable, ConstrainedDiscreteGradient, Ledger, ProjectedMidpoint, coefficients,
};
use lieflow::models::DampedPendulum;
use lieflow::port::{ComponentInputs, Signal};
use lieflow::prelude::*;

type Sys = lieflow::System<
    lieflow::models::damped_pendulum::DampedStructure<f64>,
    DampedPendulum<f64>,
    lieflow::models::paper::Circle,
>;
type Dg = ConstrainedDiscreteGradient<V, Sys, faer::Col<f64>>;
type Mid = ProjectedMidpoint<V, Sys, DampedPendulum<f64>>;

fn dg(c: f64, x0: &V) -> Dg {
    Dg::try_new(model_with(c).system(), x0, ProjectionOptions::default()).unwrap()
}

fn midpoint(c: f64, x0: &V) -> Mid {
    let m = model_with(c);
    Mid::try_new(m.system(), m, x0, ProjectionOptions::default()).unwrap()
}

/// The largest state error at `t_end` after steps of `h` (through `step`, which threads the
/// ledger's time), and the time the ledger reached.
fn error_at(flow: &mut dyn Flow<V>, x0: &V, h: f64, t_end: f64, r: &[f64; 4]) -> (f64, f64) {
    let mut x = *x0;
    let mut ledger = Ledger::at(0.0);
    for _ in 0..(t_end / h).round() as usize {
        flow.step_at(&mut ledger, h, &mut x).unwrap();
    }
    let err = (0..4).map(|i| (x[i] - r[i]).abs()).fold(0.0, f64::max);
    (err, ledger.t)
}

#[test]
fn the_forced_midpoint_rule_and_discrete_gradient_keep_order_2() {
    let c = 0.5;
    let x0: V = model_with(c).state(THETA0, 0.0);
    let t_end = 5.0;
    let r = reference_with(c, t_end, 1e-4);
    let hs = [0.1, 0.05, 0.025, 0.0125];
    type Make = fn(f64, &V) -> Box<dyn Flow<V>>;
    let schemes: [(&str, Make); 2] = [
        ("midpoint", |c, x0| {
            Box::new(
                midpoint(c, x0)
                    .with_inputs(PivotTorque, vec![signal()])
                    .unwrap(),
            )
        }),
        ("discrete gradient", |c, x0| {
            Box::new(dg(c, x0).with_inputs(PivotTorque, vec![signal()]).unwrap())
        }),
    ];
    for (name, make) in schemes {
        let errs: Vec<f64> = hs
            .iter()
            .map(|&h| {
                let (err, t) = error_at(make(c, &x0).as_mut(), &x0, h, t_end, &r);
                // The step carries the time of its inputs.
                assert!((t - t_end).abs() <= 1e-12, "{name}: {t}");
                err
            })
            .collect();
        let p = fitted_order(&hs, &errs, 1e-12);
        eprintln!("forced {name}: errors {errs:?}, fitted order {p:.3}");
        assert!((p - 2.0).abs() <= 0.2, "{name}: {p}");
        // Without the torque the run is another one: the input acts.
        let (unforced, _) = error_at(&mut dg(c, &x0) as &mut dyn Flow<V>, &x0, hs[3], t_end, &r);
        assert!(
            unforced > 1e3 * errs[3],
            "{name}: the torque changed nothing"
        );
    }
}

#[test]
fn the_forced_midpoint_rule_composed_keeps_order_4() {
    // Undamped (a composition's negative sub-steps would run damping backwards): the midpoint
    // rule with u(t_n + h/2) is symmetric in (t, x), so the triple jump raises it to order 4
    // with the sub-steps' times threaded through the ledger.
    let c = 0.0;
    let x0: V = model_with(c).state(THETA0, 0.0);
    let t_end = 5.0;
    let r = reference_with(c, t_end, 1e-4);
    let hs = [0.2, 0.1, 0.05, 0.025];
    let table: &CompositionTable = &coefficients::TRIPLE_JUMP;
    let errs: Vec<f64> = hs
        .iter()
        .map(|&h| {
            let mut f = midpoint(c, &x0)
                .with_inputs(PivotTorque, vec![signal()])
                .unwrap()
                .composed(table);
            let (err, t) = error_at(&mut f, &x0, h, t_end, &r);
            assert!((t - t_end).abs() <= 1e-12, "{t}");
            err
        })
        .collect();
    let p = fitted_order(&hs, &errs, 1e-12);
    eprintln!("forced midpoint, triple jump: errors {errs:?}, fitted order {p:.3}");
    assert!((p - 4.0).abs() <= 0.3, "{p}");
}

#[test]
fn the_forced_discrete_gradient_balance_is_exact_at_every_step() {
    let c = 0.5;
    let m = model_with(c);
    let x0: V = m.state(THETA0, 0.0);
    let mut f = dg(c, &x0).with_inputs(PivotTorque, vec![signal()]).unwrap();
    let mut x = x0;
    let mut ledger = Ledger::at(0.0);
    let (mut worst, mut max_g, mut max_phi) = (0.0f64, 0.0f64, 0.0f64);
    let h = 0.05;
    for step in 0..2000 {
        let (before, booked) = (m.energy(&x), ledger);
        f.step_at(&mut ledger, h, &mut x).unwrap();
        let (removed, supplied) = (
            ledger.dissipated - booked.dissipated,
            ledger.supplied - booked.supplied,
        );
        // |H| ≤ 2 and the torque's work a step ≤ h |u| |ω| < 0.2: a step's balance rounds at
        // a few ε of them (the energies, the dot products, the projection's kinetic energy).
        let defect = (m.energy(&x) - before + removed - supplied).abs();
        worst = worst.max(defect);
        // Dissipation never runs backwards: the damping's −h v̄ᵀB v̄ and the projection's
        // removed kinetic energy are both ≥ 0.
        assert!(removed >= -4.0 * f64::EPSILON, "step {step}: {removed:e}");
        let b = f.energy_balance().unwrap();
        assert!(
            (b.after_step - b.before - b.supplied - b.inputs).abs() <= 32.0 * f64::EPSILON,
            "step {step}: {b:?}"
        );
        assert!((b.inputs - supplied).abs() <= 4.0 * f64::EPSILON * supplied.abs().max(1.0));
        max_g = max_g.max((0.5 * (x[0] * x[0] + x[1] * x[1] - 1.0)).abs());
        max_phi = max_phi.max(m.hidden_constraint(&x).abs());
    }
    let total = m.energy(&x) - m.energy(&x0) + ledger.dissipated - ledger.supplied;
    eprintln!(
        "forced discrete gradient: worst step balance {worst:e}, over the run {total:e}, supplied {:.6}, dissipated {:.6}, |g| {max_g:e}, |phi| {max_phi:e}",
        ledger.supplied, ledger.dissipated
    );
    assert!(ledger.supplied.abs() > 0.1, "the torque did work");
    assert!(worst <= 32.0 * f64::EPSILON, "{worst:e}");
    assert!(total.abs() <= 2000.0 * 32.0 * f64::EPSILON, "{total:e}");
    assert!(max_g <= 8.0 * f64::EPSILON, "{max_g:e}");
    assert!(max_phi <= 16.0 * f64::EPSILON, "{max_phi:e}");
    assert!((ledger.t - 100.0).abs() <= 1e-10, "{}", ledger.t);
}

#[test]
fn the_forced_midpoint_rule_books_the_work_at_its_order() {
    // The midpoint rule conserves no energy exactly: its balance H − H₀ + D − S holds to its
    // order, the supplied work by the midpoint rule of ∫ yᵀu dt. Undamped, so D = 0: halving
    // the step divides the balance error by about 4.
    let m = model_with(0.0);
    let x0: V = m.state(THETA0, 0.0);
    let defect = |h: f64| {
        let mut f = midpoint(0.0, &x0)
            .with_inputs(PivotTorque, vec![signal()])
            .unwrap();
        let mut x = x0;
        let mut ledger = Ledger::at(0.0);
        let mut worst = 0.0f64;
        for _ in 0..(5.0 / h).round() as usize {
            f.step_at(&mut ledger, h, &mut x).unwrap();
            worst = worst.max((m.energy(&x) - m.energy(&x0) - ledger.supplied).abs());
        }
        assert!(ledger.supplied.abs() > 0.1, "the torque did work");
        worst
    };
    let (coarse, fine) = (defect(0.05), defect(0.025));
    eprintln!("forced midpoint balance: {coarse:e} at h = 0.05, {fine:e} at h = 0.025");
    let p = (coarse / fine).log2();
    assert!((p - 2.0).abs() <= 0.3, "balance order {p}");
}

#[test]
fn inputs_the_implicit_schemes_cannot_take_are_refused_and_a_non_finite_one_is_named() {
    let x0: V = model_with(0.5).state(THETA0, 0.0);
    // A signal count that is not the map's.
    let e = dg(0.5, &x0).with_inputs(PivotTorque, vec![]).unwrap_err();
    assert!(matches!(e, SetupError::Dimension { .. }), "{e}");
    let e = midpoint(0.5, &x0)
        .with_inputs(PivotTorque, vec![])
        .unwrap_err();
    assert!(matches!(e, SetupError::Dimension { .. }), "{e}");
    // A position moved by an input: the mechanical form eliminates them.
    let e = dg(0.5, &x0)
        .with_inputs(ComponentInputs::new(&[0]), vec![signal()])
        .unwrap_err();
    assert!(matches!(e, SetupError::Scheme { .. }), "{e}");
    // What the constraint reads, moved by an input (the midpoint rule's small path keeps the
    // full state).
    let e = midpoint(0.5, &x0)
        .with_inputs(ComponentInputs::new(&[0]), vec![signal()])
        .unwrap_err();
    assert!(matches!(e, SetupError::Scheme { .. }), "{e}");
    // `ln(t − 1)` before `t = 1`: the step fails naming the input; the state and the ledger
    // are those before the step.
    let bad = || vec![Signal::function(|t: f64| (t - 1.0).ln())];
    let flows: [Box<dyn Flow<V>>; 2] = [
        Box::new(dg(0.5, &x0).with_inputs(PivotTorque, bad()).unwrap()),
        Box::new(midpoint(0.5, &x0).with_inputs(PivotTorque, bad()).unwrap()),
    ];
    for mut f in flows {
        let mut x = x0;
        let mut ledger = Ledger::at(0.0);
        let e = f.step_at(&mut ledger, 0.1, &mut x).unwrap_err();
        match e {
            StepError::NonFiniteInput { input, t, value } => {
                assert_eq!(input, 0);
                assert!((0.0..=0.1).contains(&t) && value.is_nan(), "{e}");
            }
            e => panic!("{e}"),
        }
        assert_eq!(x, x0);
        assert_eq!(ledger, Ledger::at(0.0));
    }
}
