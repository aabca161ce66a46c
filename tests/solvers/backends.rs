//! The stack (nalgebra) and heap (faer) storages run the same arithmetic: same trajectories.

use lieflow::models::{SphericalPendulum, paper};
use lieflow::prelude::*;
use nalgebra::SVector;

type S = SVector<f64, 4>;
type H = faer::Col<f64>;

fn run<V: Vector<Real = f64>, F: Flow<V>>(mut flow: F, mut x: V, h: f64, steps: usize) -> Vec<f64> {
    for _ in 0..steps {
        flow.step(h, &mut x).unwrap();
    }
    x.as_slice().to_vec()
}

fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

#[test]
fn stack_and_heap_paper_trajectories_agree() {
    let xs: S = paper::initial_state();
    let xh: H = paper::initial_state();
    let o = ProjectionOptions::default();
    let a = run(
        paper::drift().projected(paper::system(), &xs, o).unwrap(),
        xs,
        0.1,
        1000,
    );
    let b = run(
        paper::drift().projected(paper::system(), &xh, o).unwrap(),
        xh.clone(),
        0.1,
        1000,
    );
    assert!(
        max_diff(&a, &b) <= 1e-12,
        "projection: {:e}",
        max_diff(&a, &b)
    );
    let a = run(
        paper::drift()
            .projected(paper::system(), &xs, o)
            .unwrap()
            .triple_jump(),
        xs,
        0.1,
        1000,
    );
    let b = run(
        paper::drift()
            .projected(paper::system(), &xh, o)
            .unwrap()
            .triple_jump(),
        xh,
        0.1,
        1000,
    );
    assert!(
        max_diff(&a, &b) <= 1e-12,
        "triple jump: {:e}",
        max_diff(&a, &b)
    );
}

#[test]
fn stack_and_heap_pendulum_trajectories_agree() {
    let model = SphericalPendulum::try_new(1.0, 1.0, 9.81).unwrap();
    let xs: SVector<f64, 6> = model.state(1.0, 1.0);
    let xh: H = model.state(1.0, 1.0);
    let o = ProjectionOptions::default();
    let a = run(
        model
            .kick()
            .strang(model.drift())
            .projected(model.system(), &xs, o)
            .unwrap(),
        xs,
        0.01,
        1000,
    );
    let b = run(
        model
            .kick()
            .strang(model.drift())
            .projected(model.system(), &xh, o)
            .unwrap(),
        xh,
        0.01,
        1000,
    );
    assert!(max_diff(&a, &b) <= 1e-12, "RATTLE: {:e}", max_diff(&a, &b));
}

#[test]
fn single_precision_runs_with_residuals_at_its_round_off() {
    let mut x: SVector<f32, 4> = paper::initial_state();
    let mut f = paper::drift()
        .projected(paper::system(), &x, ProjectionOptions::default())
        .unwrap()
        .triple_jump();
    for _ in 0..1000 {
        f.step(0.1, &mut x).unwrap();
        let g = 0.5 * (x[0] * x[0] + x[1] * x[1] - 1.0);
        let phi = x[0] * x[2] + x[1] * x[3];
        // Newton stops at ‖F‖ ≤ 2ε or at a floor below 100·2ε (ε = 1.2e-7 for f32).
        let tol = 200.0 * f32::EPSILON;
        assert!(
            g.abs() <= tol && phi.abs() <= tol,
            "g = {g:e}, phi = {phi:e}"
        );
    }
    // Discretization error of the f64 run (3.6e-7) plus round-off of 3000 sub-steps, each of
    // relative size ε_f32: at most 3000 · 1.2e-7 ≈ 3.6e-4 if every rounding added up.
    let r = paper::reference(100.0, -0.15, 1e-3);
    let err = (0..4)
        .map(|i| (x[i] as f64 - r[i]).abs())
        .fold(0.0, f64::max);
    let bound = 3.6e-7 + 3000.0 * f32::EPSILON as f64;
    eprintln!("f32 triple jump error at T = 100: {err:e} (bound {bound:e})");
    assert!(err < bound, "f32 error at T = 100: {err:e}");
}
