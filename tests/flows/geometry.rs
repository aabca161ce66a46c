//! Geometry: constraint residuals every step, time symmetry, invariants without drift, and the
//! coupled and decoupled solves agreeing.

use crate::common;

use common::{V3, V4, gradient_sphere};
use lieflow::models::{SphericalPendulum, paper};
use lieflow::ops;
use lieflow::prelude::*;
use nalgebra::SVector;

type V6 = SVector<f64, 6>;

fn paper_g_phi(x: &V4) -> (f64, f64) {
    (
        0.5 * (x[0] * x[0] + x[1] * x[1] - 1.0),
        x[0] * x[2] + x[1] * x[3],
    )
}

fn pendulum() -> (SphericalPendulum<f64>, V6) {
    let model = SphericalPendulum::try_new(1.0, 1.0, 9.81).unwrap();
    let x0 = model.state(1.0, 1.0);
    (model, x0)
}

#[test]
fn paper_residuals_at_round_off_every_step_for_1e5_steps() {
    let mut x: V4 = paper::initial_state();
    let mut flow = paper::drift()
        .projected(paper::system(), &x, ProjectionOptions::default())
        .unwrap();
    let (mut mg, mut mp) = (0.0f64, 0.0f64);
    for _ in 0..100_000 {
        flow.step(0.1, &mut x).unwrap();
        let (g, p) = paper_g_phi(&x);
        mg = mg.max(g.abs());
        mp = mp.max(p.abs());
    }
    eprintln!("paper, 1e5 steps: max |g| = {mg:e}, max |phi| = {mp:e}");
    assert!(mg <= 1e-14 && mp <= 1e-14, "|g| = {mg:e}, |phi| = {mp:e}");
}

#[test]
fn composed_residuals_at_round_off_every_step() {
    let mut x: V4 = paper::initial_state();
    let mut flow = paper::drift()
        .projected(paper::system(), &x, ProjectionOptions::default())
        .unwrap()
        .composed(&coefficients::KAHAN_LI8);
    for _ in 0..10_000 {
        flow.step(0.1, &mut x).unwrap();
        let (g, p) = paper_g_phi(&x);
        assert!(
            g.abs() <= 1e-14 && p.abs() <= 1e-14,
            "g = {g:e}, phi = {p:e}"
        );
    }
}

#[test]
fn pendulum_residuals_at_round_off_every_step_for_1e5_steps() {
    let (model, mut x) = pendulum();
    let mut flow = model
        .kick()
        .strang(model.drift())
        .projected(model.system(), &x, ProjectionOptions::default())
        .unwrap();
    let (mut mg, mut mp) = (0.0f64, 0.0f64);
    for _ in 0..100_000 {
        flow.step(0.01, &mut x).unwrap();
        let q2 = x[0] * x[0] + x[1] * x[1] + x[2] * x[2];
        mg = mg.max((0.5 * (q2 - 1.0)).abs());
        mp = mp.max((x[0] * x[3] + x[1] * x[4] + x[2] * x[5]).abs());
    }
    eprintln!("pendulum, 1e5 steps: max |g| = {mg:e}, max |phi| = {mp:e}");
    assert!(mg <= 1e-14 && mp <= 1e-14, "|g| = {mg:e}, |phi| = {mp:e}");
}

fn assert_reversible<V: Vector<Real = f64>, F: Flow<V>>(name: &str, flow: &mut F, x0: &V, h: f64) {
    assert!(flow.is_symmetric(), "{name} should report symmetric");
    let mut x = x0.clone();
    // Several round trips from different points along the trajectory.
    for _ in 0..20 {
        let start = x.clone();
        flow.step(h, &mut x).unwrap();
        let after = x.clone();
        flow.step(-h, &mut x).unwrap();
        let d = ops::dist_inf(x.as_slice(), start.as_slice());
        assert!(d <= 1e-13, "{name}: step(h) then step(-h) is off by {d:e}");
        x = after;
    }
}

#[test]
fn projected_steps_are_symmetric() {
    let x0: V4 = paper::initial_state();
    let opts = ProjectionOptions::default();
    let mut f = paper::drift()
        .projected(paper::system(), &x0, opts)
        .unwrap();
    assert_reversible("paper projection", &mut f, &x0, 0.1);
    let mut f = paper::drift()
        .projected(paper::system(), &x0, opts)
        .unwrap()
        .triple_jump();
    assert_reversible("paper triple jump", &mut f, &x0, 0.1);
    let mut f = paper::drift()
        .projected(paper::system(), &x0, opts.with_coupling(Coupling::Coupled))
        .unwrap();
    assert_reversible("paper coupled", &mut f, &x0, 0.1);

    let (model, x0) = pendulum();
    let mut f = model
        .kick()
        .strang(model.drift())
        .projected(model.system(), &x0, opts)
        .unwrap();
    assert_reversible("RATTLE", &mut f, &x0, 0.01);

    let x0: V3 = gradient_sphere::x0();
    let mut f = gradient_sphere::projected();
    assert_reversible("symmetric projection", &mut f, &x0, 0.01);
}

#[test]
fn coupled_and_decoupled_solves_agree() {
    let x0: V4 = paper::initial_state();
    let opts = ProjectionOptions::default();
    let mut a = paper::drift()
        .projected(paper::system(), &x0, opts)
        .unwrap();
    let mut b = paper::drift()
        .projected(paper::system(), &x0, opts.with_coupling(Coupling::Coupled))
        .unwrap();
    assert_eq!(a.scheme(), Scheme::Decoupled);
    assert_eq!(b.scheme(), Scheme::Coupled);
    let (mut xa, mut xb) = (x0, x0);
    for _ in 0..1000 {
        a.step(0.1, &mut xa).unwrap();
        b.step(0.1, &mut xb).unwrap();
    }
    let d = (xa - xb).amax();
    assert!(d <= 1e-12, "coupled and decoupled differ by {d:e}");
}

/// Max of `|I − I₀|` over each tenth of a run: the first and last tenth must match (no
/// secular drift), and the whole run stays below `bound`.
fn assert_no_drift(name: &str, windows: &[f64], bound: f64) {
    let first = windows[0];
    let last = *windows.last().unwrap();
    let max = windows.iter().cloned().fold(0.0, f64::max);
    eprintln!("{name}: window maxima {windows:?}");
    assert!(max <= bound, "{name}: error {max:e} above {bound:e}");
    assert!(
        last <= 1.5 * first + 1e-14,
        "{name}: drift: first tenth {first:e}, last tenth {last:e}"
    );
}

#[test]
fn paper_h_tilde_bounded_without_drift_over_1e6_steps() {
    let mut x: V4 = paper::initial_state();
    let h0 = paper::h_tilde(&x);
    let mut flow = paper::drift()
        .projected(paper::system(), &x, ProjectionOptions::default())
        .unwrap();
    let mut windows = vec![0.0f64; 10];
    for k in 0..1_000_000 {
        flow.step(0.1, &mut x).unwrap();
        let w = &mut windows[k / 100_000];
        *w = w.max((paper::h_tilde(&x) - h0).abs());
    }
    // The O(h²) oscillation measured over T = 100 is 1.85e-7.
    assert_no_drift("paper H~", &windows, 1e-6);
}

#[test]
fn pendulum_energy_bounded_without_drift_over_1e6_steps() {
    let (model, mut x) = pendulum();
    let e0 = model.energy(&x);
    let mut flow = model
        .kick()
        .strang(model.drift())
        .projected(model.system(), &x, ProjectionOptions::default())
        .unwrap();
    let mut windows = vec![0.0f64; 10];
    for k in 0..1_000_000 {
        flow.step(0.01, &mut x).unwrap();
        let w = &mut windows[k / 100_000];
        *w = w.max((model.energy(&x) - e0).abs());
    }
    // RATTLE's O(h²) energy oscillation (1.3e-3 at h = 0.01 over T = 100, |E0| = 4.8).
    assert_no_drift("pendulum energy", &windows, 5e-3);
}

#[test]
fn tiny_step_sizes_keep_residuals_at_round_off() {
    // The multiplier Jacobians scale like h² and h; the difference steps follow, so Newton
    // works for any h (before, h ≤ 1e-5 made the λ_k column vanish).
    for &h in &[1e-3, 1e-4, 1e-5, 1e-6, -1e-5] {
        let mut x: V4 = paper::initial_state();
        let mut flow = paper::drift()
            .projected(paper::system(), &x, ProjectionOptions::default())
            .unwrap()
            .triple_jump();
        for _ in 0..100 {
            flow.step(h, &mut x)
                .unwrap_or_else(|e| panic!("h = {h:e}: {e}"));
            let (g, p) = paper_g_phi(&x);
            assert!(
                g.abs() <= 1e-14 && p.abs() <= 1e-14,
                "h = {h:e}: g = {g:e}, phi = {p:e}"
            );
        }
    }
}

#[test]
fn coupled_solve_inside_a_composition_matches_the_decoupled_one() {
    // Sub-steps of the triple jump change size and sign; the coupled system's kept Jacobian
    // must follow (its g-rows are divided by h so every row scales like h).
    let x0: V4 = paper::initial_state();
    let opts = ProjectionOptions::default();
    let mut a = paper::drift()
        .projected(paper::system(), &x0, opts)
        .unwrap()
        .triple_jump();
    let mut b = paper::drift()
        .projected(paper::system(), &x0, opts.with_coupling(Coupling::Coupled))
        .unwrap()
        .triple_jump();
    let (mut xa, mut xb) = (x0, x0);
    for _ in 0..1000 {
        a.step(0.1, &mut xa).unwrap();
        b.step(0.1, &mut xb).unwrap();
        let (g, p) = paper_g_phi(&xb);
        assert!(
            g.abs() <= 1e-14 && p.abs() <= 1e-14,
            "g = {g:e}, phi = {p:e}"
        );
    }
    let d = (xa - xb).amax();
    assert!(
        d <= 1e-12,
        "coupled and decoupled triple jumps differ by {d:e}"
    );
}

#[test]
fn a_zero_step_is_the_identity() {
    let x0: V4 = paper::initial_state();
    let mut f = paper::drift()
        .projected(paper::system(), &x0, ProjectionOptions::default())
        .unwrap();
    let mut x = x0;
    f.step(0.0, &mut x).unwrap();
    assert_eq!(x, x0);
}
