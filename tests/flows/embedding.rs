//! The stepping object for embedders: checkpoints that continue bit for bit, advancing to a
//! time, dense output, events located on it, and re-projection after an external change.

use crate::common;

use faer::Col;
use lieflow::flow::{CompositionTable, coefficients};
use lieflow::models::{PendulumChain, RigidBody, SphericalPendulum};
use lieflow::nonlinear::NewtonOptions;
use lieflow::port::{ComponentInputs, Held, InputFlow, Signal};
use lieflow::prelude::*;
use lieflow::stepper::{Direction, Event, Events};
use lieflow::system::reproject;
use nalgebra::SVector;

type V4 = SVector<f64, 4>;
type V6 = SVector<f64, 6>;

fn pendulum() -> SphericalPendulum<f64> {
    SphericalPendulum::try_new(1.0, 1.0, 9.81).unwrap()
}

/// At rest at angle `theta` from the downward vertical, in the x–z plane.
fn at_angle(theta: f64) -> V6 {
    V6::from_column_slice(&[theta.sin(), 0.0, -theta.cos(), 0.0, 0.0, 0.0])
}

fn g_residual(x: &V6) -> f64 {
    ((x[0] * x[0] + x[1] * x[1] + x[2] * x[2]) - 1.0).abs() / 2.0
}

/// The projected Strang splitting of the pendulum, composed with `table`.
fn projected(x0: &V6, table: &'static CompositionTable) -> impl Flow<V6> + use<> {
    let m = pendulum();
    m.kick::<V6>()
        .strang(m.drift::<V6>())
        .projected(m.system(), x0, ProjectionOptions::default())
        .unwrap()
        .composed(table)
}

/// Runs `steps` steps, saves, runs `steps` more; restores and runs them again, and into a
/// second stepper built the same way: every state equal bit for bit.
fn continues_bit_for_bit<V: Vector<Real = f64> + PartialEq, F: Flow<V>>(
    make: impl Fn() -> F,
    x0: V,
    h: f64,
    steps: usize,
    between: impl Fn(usize),
) {
    let mut s = Stepper::new(make(), x0.clone(), 0.0, h).unwrap();
    for k in 0..steps {
        between(k);
        s.step().unwrap();
    }
    let checkpoint = s.save();
    let run = |s: &mut Stepper<V, F>| -> Vec<V> {
        (0..steps)
            .map(|k| {
                between(steps + k);
                s.step().unwrap();
                s.state().clone()
            })
            .collect()
    };
    let first = run(&mut s);
    s.restore(&checkpoint).unwrap();
    let again = run(&mut s);
    assert!(first == again, "restored run differs");
    let mut other = Stepper::new(make(), x0, 0.0, h).unwrap();
    other.restore(&checkpoint).unwrap();
    let elsewhere = run(&mut other);
    assert!(
        first == elsewhere,
        "run restored into a new stepper differs"
    );
    assert_eq!(other.time(), s.time());
}

#[test]
fn checkpoints_continue_bit_for_bit_for_every_kind_of_flow() {
    let x0 = at_angle(1.2);
    let m = pendulum();
    // The fused projected composition, driven by a held input set before every step.
    let held = Held::new(0.0);
    let make = || {
        let input =
            InputFlow::try_new(ComponentInputs::new(&[3]), vec![Signal::Held(held.clone())])
                .unwrap()
                .supplying(m);
        m.kick::<V6>()
            .strang(input.strang(m.drift::<V6>()))
            .projected(m.system(), &x0, ProjectionOptions::default())
            .unwrap()
            .triple_jump()
    };
    continues_bit_for_bit(make, x0, 0.01, 40, |k| held.set((0.1 * k as f64).cos()));
    // Gonzalez's constrained discrete gradient and the joint §2 step.
    let cdg = || -> ConstrainedDiscreteGradient<V6, _, Col<f64>> {
        ConstrainedDiscreteGradient::try_new(m.system(), &x0, ProjectionOptions::default()).unwrap()
    };
    continues_bit_for_bit(cdg, x0, 0.01, 40, |_| {});
    let joint = || -> ProjectedMidpoint<V6, _, _> {
        ProjectedMidpoint::try_new(m.system(), m, &x0, ProjectionOptions::default()).unwrap()
    };
    continues_bit_for_bit(joint, x0, 0.01, 40, |_| {});
    // The general path (six constraints) and an implicit midpoint rule.
    let chain = PendulumChain::<f64>::uniform(2, 6).unwrap();
    let xc: Col<f64> = chain.at_rest(|i| 0.4 + 0.3 * i as f64);
    let general = || -> ProjectedMidpoint<Col<f64>, _, _> {
        ProjectedMidpoint::try_new(
            chain.system(),
            chain.clone(),
            &xc,
            chain.projection_options(),
        )
        .unwrap()
    };
    continues_bit_for_bit(general, xc.clone(), 0.01, 20, |_| {});
    let body = RigidBody::gni();
    let y0: SVector<f64, 3> = RigidBody::gni_initial_state();
    let midpoint = || {
        ImplicitMidpoint::<SVector<f64, 3>, _, _>::try_new(
            body.structure(),
            body,
            &y0,
            NewtonOptions::default(),
        )
        .unwrap()
    };
    continues_bit_for_bit(midpoint, y0, 0.1, 40, |_| {});
}

#[test]
fn a_checkpoint_from_another_scheme_is_refused() {
    let x0 = at_angle(0.5);
    let mut a = Stepper::new(projected(&x0, &coefficients::TRIPLE_JUMP), x0, 0.0, 0.01).unwrap();
    let m = pendulum();
    let mut b = Stepper::new(m.kick::<V6>().strang(m.drift::<V6>()), x0, 0.0, 0.01).unwrap();
    let cp = a.save();
    let e = b.restore(&cp).unwrap_err();
    assert!(e.to_string().contains("another scheme"), "{e}");
    assert_eq!(b.state(), &x0);
    a.restore(&cp).unwrap();
}

#[test]
fn advance_to_ends_exactly_on_the_time_asked() {
    let x0 = V4::new(0.0, 1.0, 0.5, 0.0);
    let verlet = || {
        let kick = from_fn(|h: f64, x: &mut V4| x[3] -= h * x[1]);
        let drift = from_fn(|h: f64, x: &mut V4| {
            x[0] += h * x[2];
            x[1] += h * x[3];
        });
        kick.strang(drift)
    };
    let mut s = Stepper::new(verlet(), x0, 0.0, 0.3).unwrap();
    assert_eq!(s.advance_to(1.0, &mut ()).unwrap(), 4);
    assert_eq!(s.time(), 1.0);
    // The grid goes on from there: one more step of h.
    s.step().unwrap();
    assert_eq!(s.time(), 1.3);
    // 0.3 · 3 rounds to 0.8999…: the grid lands there, and the time reported is 0.9.
    let mut s = Stepper::new(verlet(), x0, 0.0, 0.3).unwrap();
    assert_eq!(s.advance_to(0.9, &mut ()).unwrap(), 3);
    assert_eq!(s.time(), 0.9);
    // Behind: nothing.
    assert_eq!(s.advance_to(0.5, &mut ()).unwrap(), 0);
    assert_eq!(s.time(), 0.9);
    let x0 = at_angle(0.5);
    // The last short step is the scheme's: the state at 1.0 matches a run with h = 0.1.
    let mut fine = Stepper::new(projected(&x0, &coefficients::KAHAN_LI8), x0, 0.0, 0.05).unwrap();
    fine.advance_to(1.0, &mut ()).unwrap();
    let mut coarse = Stepper::new(projected(&x0, &coefficients::KAHAN_LI8), x0, 0.0, 0.07).unwrap();
    coarse.advance_to(1.0, &mut ()).unwrap();
    assert_eq!(coarse.time(), 1.0);
    assert!((fine.state() - coarse.state()).amax() < 1e-6);
}

#[test]
fn dense_output_has_the_schemes_order_and_stays_on_the_manifold() {
    let x0 = at_angle(1.0);
    let t_mid = 0.5;
    // Reference at t_mid: the order-8 scheme at a small step.
    let mut r = Stepper::new(projected(&x0, &coefficients::KAHAN_LI8), x0, 0.0, 0.005).unwrap();
    r.advance_to(t_mid, &mut ()).unwrap();
    let reference = *r.state();
    let (mut hs, mut errs) = (vec![], vec![]);
    for n in [10usize, 20, 40, 80, 160] {
        // Steps that do not land on t_mid: it lies at 0.37 of a step.
        let h = 1.0 / (n as f64 + 0.63);
        let mut s = Stepper::new(projected(&x0, &coefficients::TRIPLE_JUMP), x0, 0.0, h).unwrap();
        while s.time() < t_mid {
            s.step().unwrap();
        }
        let mut out = x0;
        s.dense(t_mid, &mut out).unwrap();
        assert!(
            g_residual(&out) < 1e-15,
            "dense state off the sphere: {:e}",
            g_residual(&out)
        );
        hs.push(h);
        errs.push((out - reference).amax());
    }
    let p = common::fitted_order(&hs, &errs, 1e-13);
    eprintln!("dense output: fitted order {p:.3}, errors {errs:?}");
    assert!((p - 4.0).abs() < 0.3, "dense output order {p}: {errs:?}");
}

/// `K(k)` by the arithmetic–geometric mean: `π / (2 AGM(1, √(1 − k²)))`.
fn elliptic_k(k: f64) -> f64 {
    let (mut a, mut b) = (1.0f64, (1.0 - k * k).sqrt());
    // Quadratic convergence: six iterations reach round-off for k < 0.9.
    for _ in 0..8 {
        (a, b) = ((a + b) / 2.0, (a * b).sqrt());
    }
    std::f64::consts::PI / (2.0 * a)
}

#[test]
fn a_pendulum_crosses_the_vertical_at_the_elliptic_integrals_quarter_periods() {
    let theta0: f64 = 1.0;
    let x0 = at_angle(theta0);
    let quarter = elliptic_k((theta0 / 2.0).sin()) / 9.81f64.sqrt();
    let mut s = Stepper::new(projected(&x0, &coefficients::KAHAN_LI8), x0, 0.0, 0.02).unwrap();
    let mut events = Events::new(vec![Event::new(|_t, x: &V6| x[0], Direction::Either)]);
    let mut hits = vec![];
    while s.time() < 8.0 * quarter {
        let before = s.time();
        if let Some(hit) = s.step_with_events(&mut events).unwrap() {
            // Recorded, not stepped to: the stepper stays on its grid; the state at the
            // event is on the sphere, at the vertical.
            assert!((s.time() - before - 0.02).abs() < 1e-12);
            assert!(hit.t > before && hit.t <= s.time());
            let at = events.located().unwrap();
            assert!(g_residual(at) < 1e-15);
            assert!(at[0].abs() < 1e-12, "x at the event {:e}", at[0]);
            hits.push(hit);
        }
    }
    assert_eq!(hits.len(), 4, "{hits:?}");
    for (i, hit) in hits.iter().enumerate() {
        let expected = (2 * i + 1) as f64 * quarter;
        assert!(
            (hit.t - expected).abs() < 1e-10,
            "crossing {i}: {} vs {expected} ({:e})",
            hit.t,
            hit.t - expected
        );
        assert!(hit.evaluations < 30);
    }
}

#[test]
fn a_projectile_stops_on_the_plane_at_the_closed_form_time() {
    let (g, y0, vy0, vx) = (9.81, 2.0, 3.0, 1.5);
    let kick = from_fn(move |h: f64, x: &mut V4| x[3] -= g * h);
    let drift = from_fn(|h: f64, x: &mut V4| {
        x[0] += h * x[2];
        x[1] += h * x[3];
    });
    let x0 = V4::new(0.0, y0, vx, vy0);
    let mut s = Stepper::new(kick.strang(drift), x0, 0.0, 0.1).unwrap();
    let mut events = Events::new(vec![
        Event::new(|_t, x: &V4| x[1], Direction::Falling).terminal(),
        // Never crosses: the apex height is below 10.
        Event::new(|_t, x: &V4| x[1] - 10.0, Direction::Either),
    ]);
    let hit = loop {
        if let Some(hit) = s.step_with_events(&mut events).unwrap() {
            break hit;
        }
        assert!(s.time() < 10.0);
    };
    let exact = (vy0 + (vy0 * vy0 + 2.0 * g * y0).sqrt()) / g;
    assert!(hit.terminal && hit.index == 0);
    assert!((hit.t - exact).abs() < 1e-12, "{} vs {exact}", hit.t);
    assert!(s.state()[1].abs() < 1e-12);
    assert!((s.state()[0] - vx * exact).abs() < 1e-12);
}

#[test]
fn an_impulse_is_reprojected_onto_the_manifold_on_request() {
    let m = pendulum();
    let x0 = at_angle(0.7);
    let mut s = Stepper::new(projected(&x0, &coefficients::TRIPLE_JUMP), x0, 0.0, 0.01).unwrap();
    s.advance(10, &mut ()).unwrap();
    // An impulse with a component along the rod: the next projected step refuses it...
    let before = *s.state();
    s.state_mut()[3] += 1.0;
    s.state_mut()[5] += 0.5;
    assert!(matches!(s.step(), Err(StepError::OffManifold { .. })));
    assert_eq!(s.state()[3], before[3] + 1.0);
    // ...and the re-projection removes exactly that component (as an inelastic impact).
    let sys = m.system();
    let report = reproject(&sys, s.state_mut(), 1e-14, true).unwrap();
    let x = *s.state();
    let q = x.fixed_rows::<3>(0);
    let dp = x.fixed_rows::<3>(3) - before.fixed_rows::<3>(3);
    let kick = nalgebra::Vector3::new(1.0, 0.0, 0.5);
    let tangential = kick - q * q.dot(&kick);
    assert!((dp - tangential).amax() < 1e-13, "{dp} vs {tangential}");
    assert!(report.phi_before > 0.1 && report.phi_after < 1e-14);
    assert!((report.moved - (kick - tangential).amax()).abs() < 1e-13);
    s.step().unwrap();
    // A position off the sphere is brought back onto it along the normal.
    s.state_mut()[0] *= 1.01;
    let report = reproject(&sys, s.state_mut(), 1e-15, true).unwrap();
    assert!(report.g_before > 1e-3 && g_residual(s.state()) < 1e-15);
    let mut phi = [0.0];
    let (mut t1, mut t2) = (V6::zeros(), V6::zeros());
    sys.hidden_constraint(s.state(), &mut t1, &mut t2, &mut phi);
    assert!(phi[0].abs() < 1e-14);
    s.step().unwrap();
}
