//! Bricard's mechanism rebuilt from five rigid bars and six hinges (`scenes/bricard.toml`)
//! against the same mechanism in natural coordinates (`lieflow::models::bricard::Bricard`): the
//! loop repeats one hinge row, which `redundant = "drop-dependent"` drops alone. Each bar's
//! joint points and axis vectors are linear functions of its centre and directors, the mass
//! matrices constant in both, and RATTLE commutes with a linear change of coordinates that
//! carries one kinetic energy and one constraint manifold to the other (Hairer, Lubich &
//! Wanner, GNI §VII.1): the two runs are one discrete motion, equal at every step to the
//! rounding of their Newton solves.

use lieflow::flow::Flow;
use lieflow::models::bricard::Bricard;
use lieflow::scene::{Scene, run};

/// The bars' centres at `t_end` from the natural-coordinates model: the joint points
/// `P₁ … P₄` are its first twelve positions, `O` and `P₅ = (0, 0, 1)` fixed.
fn point_model(h: f64, t_end: f64) -> [[f64; 3]; 5] {
    type V = faer::Col<f64>;
    let x0: V = Bricard::initial_state();
    let mut flow = Bricard::rattle(&x0).unwrap();
    let mut x = x0;
    for _ in 0..(t_end / h).round() as usize {
        flow.step(h, &mut x).unwrap();
    }
    let p = |k: usize| -> [f64; 3] {
        match k {
            0 => [0.0; 3],
            5 => [0.0, 0.0, 1.0],
            k => core::array::from_fn(|d| x[3 * (k - 1) + d]),
        }
    };
    core::array::from_fn(|b| core::array::from_fn(|d| 0.5 * (p(b)[d] + p(b + 1)[d])))
}

/// The bars' centres at `t_end` from the scene (each rigid body four slots: its centre first).
fn scene(h: f64, t_end: f64) -> ([[f64; 3]; 5], Vec<String>) {
    let text = include_str!("../../scenes/bricard.toml")
        .replace("dt = 0.001", &format!("dt = {h}"))
        .replace("t_end = 2.0", &format!("t_end = {t_end}"));
    let mut c = Scene::from_toml(&text, "bricard.toml")
        .unwrap()
        .compile()
        .unwrap_or_else(|e| panic!("{e}"));
    let s = run(c.simulation.as_mut(), &c.plan, &mut |_| {});
    assert!(s.error.is_none(), "{:?}", s.error);
    assert!(
        s.max_abs_g.unwrap() < 64.0 * f64::EPSILON,
        "{:?}",
        s.max_abs_g
    );
    let centres = core::array::from_fn(|b| core::array::from_fn(|d| s.x[12 * b + d]));
    (centres, c.assembly.dropped_constraints.clone())
}

#[test]
fn bricard_of_rigid_bars_moves_as_the_natural_coordinates_model() {
    let t_end = 1.0;
    for h in [0.002, 0.0005] {
        let (a, dropped) = scene(h, t_end);
        assert_eq!(dropped.len(), 1, "{dropped:?}");
        assert!(
            dropped[0].contains("row"),
            "one hinge row, not a joint: {dropped:?}"
        );
        let b = point_model(h, t_end);
        let d = (0..5)
            .flat_map(|i| (0..3).map(move |k| (i, k)))
            .map(|(i, k)| (a[i][k] - b[i][k]).abs())
            .fold(0.0, f64::max);
        // The mechanism moved: the third bar's centre from where it started.
        let travel =
            ((b[2][0] - 1.0).powi(2) + (b[2][1] + 1.0).powi(2) + (b[2][2] - 0.5).powi(2)).sqrt();
        eprintln!(
            "Bricard, h = {h}: rigid bars against natural coordinates {d:e}, travel {travel:.3}"
        );
        assert!(travel > 0.1, "the mechanism barely moved: {travel}");
        // Newton stops each solve at 16 ε; a thousand or two steps of it.
        assert!(d < 1e-11, "{d:e}");
    }
}
