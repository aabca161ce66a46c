//! Andrews' squeezing mechanism (IVP test set): a position-dependent mass
//! matrix, so no closed-form drift — the projection around the implicit midpoint rule, with
//! every derivative from autodiff elements. At t = 0.03 the angles and angular velocities match
//! the test set's reference within twice this order-2 run's Richardson error estimate; the
//! constraints hold at round-off throughout; the model's derivatives pass `check_model`.

use lieflow::models::andrews::{self, REFERENCE, run};
use lieflow::system::check_model;
use nalgebra::SVector;

type V = SVector<f64, 14>;

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
    let (coarse, fine) = (run(3000).unwrap(), run(6000).unwrap());
    let (g1, g2) = (coarse.max_g, fine.max_g);
    let (coarse, fine) = (coarse.end, fine.end);
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
