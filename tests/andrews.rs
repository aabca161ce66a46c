//! Andrews' squeezing mechanism (issue 12, case 2; IVP test set): a position-dependent mass
//! matrix, so no closed-form drift — the projection around the implicit midpoint rule, with
//! every derivative from autodiff elements. At t = 0.03 the angles and angular velocities match
//! the test set's reference within twice this order-2 run's Richardson error estimate; the
//! constraints hold at round-off throughout; the model's derivatives pass `check_model`.

use lieflow::flow::ImplicitMidpoint;
use lieflow::models::andrews::{self, REFERENCE};
use lieflow::nonlinear::NewtonOptions;
use lieflow::prelude::*;
use lieflow::system::check_model;
use nalgebra::SVector;

type V = SVector<f64, 14>;

/// Runs to t = 0.03 with `steps` steps; the final (q, q') and max |g| over the run.
fn run(steps: usize) -> ([f64; 14], f64) {
    let x0: V = andrews::initial_state();
    let s = andrews::system();
    let mid = ImplicitMidpoint::<V, _, _>::try_new(
        Canonical,
        s.hamiltonian.clone(),
        &x0,
        NewtonOptions::default(),
    )
    .unwrap();
    let mut flow = mid
        .projected(andrews::system(), &x0, ProjectionOptions::default())
        .unwrap();
    let h = 0.03 / steps as f64;
    let mut x = x0;
    let mut max_g = 0.0f64;
    let mut g = [0.0; 6];
    for _ in 0..steps {
        flow.step(h, &mut x).unwrap();
        s.constraint.residual(&x, &mut g);
        max_g = max_g.max(g.iter().fold(0.0f64, |a, v| a.max(v.abs())));
    }
    let v = andrews::velocities(x.as_slice());
    let mut out = [0.0; 14];
    out[..7].copy_from_slice(&x.as_slice()[..7]);
    out[7..].copy_from_slice(&v);
    (out, max_g)
}

#[test]
fn the_model_passes_the_checker() {
    let mut x: V = andrews::initial_state();
    for (i, v) in x.iter_mut().enumerate().skip(7) {
        *v = 1e-3 * (i as f64 - 10.0);
    }
    let r = check_model(&andrews::system(), &x);
    assert!(r.passed(), "{r}");
}

#[test]
fn andrews_matches_the_test_set_reference() {
    let (coarse, g1) = run(3000);
    let (fine, g2) = run(6000);
    for i in 0..14 {
        // Relative to each component's scale (angles ~1–16 rad, velocities up to 1.4e3 rad/s).
        let scale = REFERENCE[i].abs().max(1.0);
        let err = (fine[i] - REFERENCE[i]).abs() / scale;
        let estimate = (fine[i] - coarse[i]).abs() / 3.0 / scale;
        eprintln!(
            "{i:2}: ours {:+.12e} ref {:+.12e} rel err {err:.2e} estimate {estimate:.2e}",
            fine[i], REFERENCE[i]
        );
        assert!(
            err <= 2.0 * estimate + 1e-12,
            "component {i}: error {err:e}, estimate {estimate:e}"
        );
    }
    eprintln!("max |g| {g1:e} {g2:e}");
    assert!(g1.max(g2) < 1e-14);
}
