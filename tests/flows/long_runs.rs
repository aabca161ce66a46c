//! Long runs: 10⁷ steps of the paper's example and of the spherical
//! pendulum. The constraint and its hidden constraint stay at round-off at every step, and the
//! invariants do not drift: a symmetric method on these reversible, integrable problems has an
//! energy error that oscillates with a bounded amplitude (Hairer, Lubich & Wanner, GNI §XI), so the
//! largest error over the last tenth of the run equals that over the first tenth up to the
//! oscillation's own spread — any drift, even `O(ε √N)` of round-off, would be orders of magnitude
//! below it, and a secular `O(t h²)` drift would be 10× larger at the end.

use lieflow::models::paper;
use lieflow::models::spherical_pendulum::SphericalPendulum;
use lieflow::prelude::*;
use nalgebra::SVector;

const STEPS: usize = 10_000_000;

/// Max over the first and over the last tenth of a run of `err(k)`.
struct Tenths {
    first: f64,
    last: f64,
}

#[test]
fn ten_million_steps_of_the_paper_example() {
    type V = SVector<f64, 4>;
    let mut x: V = paper::initial_state();
    let h0 = paper::h_tilde(&x);
    let mut flow = paper::drift()
        .projected(paper::system(), &x, ProjectionOptions::default())
        .unwrap();
    let (mut max_g, mut max_phi) = (0.0f64, 0.0f64);
    let mut tenths = Tenths {
        first: 0.0,
        last: 0.0,
    };
    for k in 0..STEPS {
        flow.step(0.1, &mut x).unwrap();
        let g = 0.5 * (x[0] * x[0] + x[1] * x[1] - 1.0);
        let phi = x[0] * x[2] + x[1] * x[3];
        max_g = max_g.max(g.abs());
        max_phi = max_phi.max(phi.abs());
        let de = (paper::h_tilde(&x) - h0).abs();
        if k < STEPS / 10 {
            tenths.first = tenths.first.max(de);
        } else if k >= STEPS - STEPS / 10 {
            tenths.last = tenths.last.max(de);
        }
    }
    eprintln!(
        "paper, 1e7 steps: max|g| {max_g:e}, max|phi| {max_phi:e}, H~ error first tenth {:e}, last tenth {:e}",
        tenths.first, tenths.last
    );
    // |g| ≤ a few ulps of |q|² = 1; φ is a product of O(1) and O(0.15) numbers.
    assert!(max_g <= 4.0 * f64::EPSILON, "max |g| = {max_g:e}");
    assert!(max_phi <= 4.0 * f64::EPSILON, "max |phi| = {max_phi:e}");
    // The H̃ error's amplitude (1.8e-7 at h = 0.1, README) without drift.
    assert!(
        tenths.first > 1e-8 && tenths.first < 1e-6,
        "{}",
        tenths.first
    );
    let ratio = tenths.last / tenths.first;
    assert!(
        (0.9..1.1).contains(&ratio),
        "first tenth {:e}, last {:e}",
        tenths.first,
        tenths.last
    );
}

#[test]
fn ten_million_steps_of_the_spherical_pendulum() {
    type V = SVector<f64, 6>;
    let model = SphericalPendulum::try_new(1.0, 1.0, 9.81).unwrap();
    let mut x: V = model.state(1.0, 1.0);
    let (e0, l0) = (model.energy(&x), model.vertical_angular_momentum(&x));
    let sys = model.system();
    let mut flow = model
        .kick()
        .strang(model.drift())
        .projected(model.system(), &x, ProjectionOptions::default())
        .unwrap();
    let (mut max_g, mut max_phi, mut max_dl) = (0.0f64, 0.0f64, 0.0f64);
    let mut tenths = Tenths {
        first: 0.0,
        last: 0.0,
    };
    let (mut t1, mut t2) = (V::zeros(), V::zeros());
    let mut r = [0.0];
    for k in 0..STEPS {
        flow.step(0.01, &mut x).unwrap();
        sys.constraint.residual(&x, &mut r);
        max_g = max_g.max(r[0].abs());
        sys.hidden_constraint(&x, &mut t1, &mut t2, &mut r);
        max_phi = max_phi.max(r[0].abs());
        max_dl = max_dl.max((model.vertical_angular_momentum(&x) - l0).abs());
        let de = (model.energy(&x) - e0).abs();
        if k < STEPS / 10 {
            tenths.first = tenths.first.max(de);
        } else if k >= STEPS - STEPS / 10 {
            tenths.last = tenths.last.max(de);
        }
    }
    eprintln!(
        "spherical pendulum, 1e7 steps: max|g| {max_g:e}, max|phi| {max_phi:e}, max|L-L0| {max_dl:e}, energy error first tenth {:e}, last tenth {:e}",
        tenths.first, tenths.last
    );
    assert!(max_g <= 4.0 * f64::EPSILON, "max |g| = {max_g:e}");
    // φ = q·p/m with |q| = 1 and |p| up to ~5: a few ulps of 5.
    assert!(max_phi <= 32.0 * f64::EPSILON, "max |phi| = {max_phi:e}");
    // RATTLE conserves the angular momentum about the axis of symmetry exactly (a quadratic
    // invariant of a symmetric projection): only round-off accumulates.
    // Round-off random walk: ε √N |L| ≈ 7e-13 (measured 1.6e-13).
    assert!(max_dl < 1e-11, "max |L - L0| = {max_dl:e}");
    let ratio = tenths.last / tenths.first;
    assert!(
        (0.8..1.25).contains(&ratio),
        "first tenth {:e}, last {:e}",
        tenths.first,
        tenths.last
    );
}
