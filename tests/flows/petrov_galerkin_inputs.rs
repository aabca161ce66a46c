//! The Petrov–Galerkin scheme of an open system `x' = M (∇H + Gᵀλ) + B(x) u(t)`: a damped
//! pendulum driven by a torque at its pivot. Fitted orders 2, 4, 6 with the time-dependent
//! torque, the discrete balance `H_{n+1} − H_n = −D_n + S_n` at every step, the constraints at
//! round-off, and a signal that is not finite named as such.

use crate::common;

use crate::driven::{PivotTorque, THETA0, V, model, reference, signal};
use common::fitted_order;
use lieflow::flow::{Ledger, PetrovGalerkin};
use lieflow::models::DampedPendulum;
use lieflow::port::{ComponentInputs, Signal};
use lieflow::prelude::*;

type Pg = PetrovGalerkin<
    V,
    lieflow::System<
        lieflow::models::damped_pendulum::DampedStructure<f64>,
        DampedPendulum<f64>,
        lieflow::models::paper::Circle,
    >,
>;

fn forced(order: u32, x0: &V) -> Pg {
    Pg::try_new(model().system(), x0, order, ProjectionOptions::default())
        .unwrap()
        .with_inputs(PivotTorque, vec![signal()])
        .unwrap()
}

#[test]
fn a_forced_petrov_galerkin_run_keeps_orders_2_4_6() {
    let m = model();
    let x0: V = m.state(THETA0, 0.0);
    let t_end = 5.0;
    let r = reference(t_end, 1e-4);
    for (order, hs) in [
        (2u32, [0.1, 0.05, 0.025, 0.0125]),
        (4, [0.25, 0.125, 0.0625, 0.03125]),
        (6, [0.5, 0.25, 0.125, 0.0625]),
    ] {
        let errs: Vec<f64> = hs
            .iter()
            .map(|&h| {
                let mut f = forced(order, &x0);
                let mut x = x0;
                let mut ledger = Ledger::at(0.0);
                for _ in 0..(t_end / h).round() as usize {
                    f.step_at(&mut ledger, h, &mut x).unwrap();
                }
                // The step carries the time of its inputs.
                assert!((ledger.t - t_end).abs() <= 1e-12, "{}", ledger.t);
                (0..4).map(|i| (x[i] - r[i]).abs()).fold(0.0, f64::max)
            })
            .collect();
        let p = fitted_order(&hs, &errs, 1e-12);
        eprintln!("forced Petrov–Galerkin order {order}: errors {errs:?}, fitted {p:.3}");
        assert!((p - f64::from(order)).abs() <= 0.3, "order {order}: {p}");
    }
    // Without the torque the run is another one: the input acts.
    let mut unforced = Pg::try_new(m.system(), &x0, 4, ProjectionOptions::default()).unwrap();
    let mut x = x0;
    for _ in 0..40 {
        unforced.step(0.125, &mut x).unwrap();
    }
    assert!((x[0] - r[0]).abs() > 1e-3, "the torque changed nothing");
}

#[test]
fn the_forced_balance_is_exact_at_every_step() {
    let m = model();
    let x0: V = m.state(THETA0, 0.0);
    for order in [2, 4, 6, 8] {
        let mut f = forced(order, &x0);
        let mut x = x0;
        let mut ledger = Ledger::at(0.0);
        let (mut worst, mut max_g, mut max_phi, mut supplied) = (0.0f64, 0.0f64, 0.0f64, 0.0);
        let h = 0.1;
        for step in 0..1000 {
            f.step_at(&mut ledger, h, &mut x).unwrap();
            let d = f.last_dissipation().unwrap();
            // Every term is at most a few units here (|H| ≤ 2, the torque's work a step
            // ≤ h |u| |ω| < 0.5): the balance of a step rounds at a few ε of them.
            let defect = (d.after - d.before + d.total() - d.supplied).abs();
            worst = worst.max(defect);
            assert!(d.damping >= -4.0 * f64::EPSILON, "step {step}: {d:?}");
            assert!(d.projection >= -4.0 * f64::EPSILON, "step {step}: {d:?}");
            supplied += d.supplied;
            max_g = max_g.max((0.5 * (x[0] * x[0] + x[1] * x[1] - 1.0)).abs());
            max_phi = max_phi.max(m.hidden_constraint(&x).abs());
        }
        let total = m.energy(&x) - m.energy(&x0) + ledger.dissipated - ledger.supplied;
        eprintln!(
            "order {order}: worst step balance {worst:e}, over the run {total:e}, supplied {supplied:.6}, |g| {max_g:e}, |phi| {max_phi:e}"
        );
        assert!(supplied.abs() > 0.1, "the torque did work: {supplied}");
        assert_eq!(supplied, ledger.supplied);
        assert!(worst <= 32.0 * f64::EPSILON, "order {order}: {worst:e}");
        assert!(total.abs() <= 1000.0 * 32.0 * f64::EPSILON, "{total:e}");
        assert!(max_g <= 8.0 * f64::EPSILON, "{max_g:e}");
        assert!(max_phi <= 16.0 * f64::EPSILON, "{max_phi:e}");
    }
}

#[test]
fn inputs_it_cannot_take_are_refused_and_a_non_finite_one_is_named() {
    let m = model();
    let x0: V = m.state(THETA0, 0.0);
    let pg = || Pg::try_new(m.system(), &x0, 4, ProjectionOptions::default()).unwrap();
    // A signal count that is not the map's.
    let e = pg().with_inputs(PivotTorque, vec![]).unwrap_err();
    assert!(matches!(e, SetupError::Dimension { .. }), "{e}");
    // A position moved by an input: the mechanical form eliminates them.
    let e = pg()
        .with_inputs(ComponentInputs::new(&[0]), vec![signal()])
        .unwrap_err();
    assert!(matches!(e, SetupError::Scheme { .. }), "{e}");
    // `ln(t − 1)` before `t = 1`: the step fails naming the input, and the state is the one
    // before the step.
    let mut f = pg()
        .with_inputs(PivotTorque, vec![Signal::function(|t: f64| (t - 1.0).ln())])
        .unwrap();
    let mut x = x0;
    let e = f.step_at(&mut Ledger::at(0.0), 0.1, &mut x).unwrap_err();
    match e {
        StepError::NonFiniteInput { input, t, value } => {
            assert_eq!(input, 0);
            assert!((0.0..=0.1).contains(&t) && value.is_nan(), "{e}");
        }
        e => panic!("{e}"),
    }
    assert_eq!(x, x0);
}
