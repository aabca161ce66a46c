//! A scene with a tolerance and `dense = true`: the controller takes its own steps and every
//! report time inside one is read from the step's polynomial (dense output), projected.

use crate::scene_text::{damped_pendulum as pendulum, parse};
use lieflow::scene::{RunSummary, Scene, SceneErrorKind, run};

/// An observed row: `(t, x, |g|)`.
type Row = (f64, Vec<f64>, Option<f64>);

/// Runs `scene`: the summary and every observed row.
fn observed(scene: &Scene) -> (RunSummary, Vec<Row>) {
    let mut c = scene.compile().unwrap_or_else(|e| panic!("{e}"));
    let mut seen = Vec::new();
    let s = run(c.simulation.as_mut(), &c.plan, &mut |s| {
        seen.push((s.t, s.x.to_vec(), s.g));
    });
    (s, seen)
}

#[test]
fn reports_inside_the_steps_come_from_the_polynomial() {
    // The damped pendulum reporting every 0.01 s over 10 s at tol 1e-8: landing on every
    // report time takes 1000 steps; with dense output the controller's own steps (tens),
    // the 1001 rows at the same times, each within 10 tol of the landing run's row (both
    // runs' errors are a few tol: each step's local error below tol, the pendulum's damping
    // contracting them), each on the constraint at round-off.
    let tol = 1e-8;
    let (landed, rows_l) = observed(&parse(&pendulum(0.01, &format!("tol = {tol}"))));
    let (dense, rows_d) = observed(&parse(&pendulum(
        0.01,
        &format!("tol = {tol}\ndense = true"),
    )));
    assert!(
        landed.error.is_none() && dense.error.is_none(),
        "{:?}",
        dense.error
    );
    let (a_l, a_d) = (landed.adaptive.unwrap(), dense.adaptive.unwrap());
    assert_eq!(rows_l.len(), 1001);
    assert_eq!(rows_d.len(), 1001);
    assert_eq!(dense.steps, 1000);
    let mut worst = 0.0f64;
    for (l, d) in rows_l.iter().zip(&rows_d) {
        assert_eq!(l.0, d.0);
        let gap = (0..4).map(|k| (l.1[k] - d.1[k]).abs()).fold(0.0, f64::max);
        worst = worst.max(gap);
        assert!(
            d.2.unwrap() <= 64.0 * f64::EPSILON,
            "t {}: |g| {:e}",
            d.0,
            d.2.unwrap()
        );
    }
    eprintln!(
        "landing: {} accepted, {} base steps; dense: {} accepted, {} rejected, {} base steps; rows apart by {worst:.2e}",
        a_l.accepted, a_l.base_steps, a_d.accepted, a_d.rejected, a_d.base_steps
    );
    assert!(worst <= 10.0 * tol, "{worst:e}");
    assert!(a_d.accepted * 10 < a_l.accepted, "{a_d:?}");
    assert!(a_d.base_steps * 3 < a_l.base_steps, "{a_d:?}");
    // The last row is the run's end, on t_end exactly.
    assert_eq!(dense.t, 10.0);
    assert_eq!(rows_d.last().unwrap().1, dense.x);
}

#[test]
fn dense_output_goes_with_the_adaptive_extrapolation() {
    let refused = |extra: &str, key: &str| {
        let e = parse(&pendulum(0.01, extra))
            .compile()
            .map(|_| ())
            .expect_err("refused");
        assert!(e.to_string().contains(&format!("integrator.{key}")), "{e}");
        e
    };
    let e = refused("dense = true", "dense");
    assert_eq!(e.kind, SceneErrorKind::Value);
    let e = refused("tol = 1e-8\nscheme = \"strang\"\ndense = true", "dense");
    assert_eq!(e.kind, SceneErrorKind::Unsupported);
}

#[test]
fn events_are_located_on_the_polynomial() {
    // scenes/forced_pendulum.toml (a rod, damping, a motor; nine passes through the bottom
    // and a stop when the bob rises above a plane) at tol 1e-9, reporting every 0.05 s from
    // the dense output, the steps bounded by 0.045 s (the stop's excursion above its plane
    // lasts 0.15 s; a crossing is seen as a sign change between a step's ends). Each event
    // is located on the step's polynomial — no partial step — where a fixed order-8 run at
    // dt = 2e-3 (error below 1e-12) finds it, to 1e-8, and the run stops there.
    let text = include_str!("../../scenes/forced_pendulum.toml");
    let dense = parse(&text.replace(
        "dt = 0.001",
        "dt = 0.05\ntol = 1e-9\nh_max = 0.045\ndense = true",
    ));
    let (d, rows) = observed(&dense);
    let (fixed, _) = observed(&parse(&text.replace("dt = 0.001", "dt = 0.002\norder = 8")));
    assert!(d.error.is_none() && fixed.error.is_none(), "{:?}", d.error);
    assert_eq!(d.stopped_by.as_deref(), Some("high"));
    assert_eq!(d.events.len(), fixed.events.len());
    for (a, f) in d.events.iter().zip(&fixed.events) {
        assert_eq!(a.name, f.name);
        assert!((a.t - f.t).abs() <= 1e-8, "{}: {} vs {}", a.name, a.t, f.t);
    }
    // Rows at the report times up to the stop, then the stop's, each on the constraint.
    let stop = d.events.last().unwrap().t;
    assert_eq!(rows.last().unwrap().0, stop);
    assert_eq!(d.t, stop);
    assert_eq!(rows.len(), (stop / 0.05).floor() as usize + 2);
    for (k, r) in rows.iter().enumerate() {
        if k + 1 < rows.len() {
            assert!((r.0 - 0.05 * k as f64).abs() <= 1e-12, "row {k}: t {}", r.0);
        }
        assert!(r.0 <= stop);
        assert!(
            r.2.unwrap() <= 64.0 * f64::EPSILON,
            "t {}: {:e}",
            r.0,
            r.2.unwrap()
        );
    }
    eprintln!(
        "forced pendulum, dense: {} events, {} rows, {:?}",
        d.events.len(),
        rows.len(),
        d.adaptive
    );
}
