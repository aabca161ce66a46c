//! Redundant constraints (issue 12, case 4): refused by default with a located error naming one;
//! with `redundant = "drop-dependent"` an over-constrained mechanism runs — the dependent
//! constraint is dropped and reported, and every constraint, the dropped one included, holds at
//! round-off along the motion with the energy conserved to the scheme's accuracy.

use lieflow::scene::stress::chain_scene;
use lieflow::scene::{Scene, run};

fn parallel_cranks(redundant: &str) -> String {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/parallel_cranks.toml"
    ))
    .unwrap();
    text.replace(
        "redundant = \"drop-dependent\"",
        &format!("redundant = \"{redundant}\""),
    )
    .replace("t_end = 10.0", "t_end = 5.0")
}

#[test]
fn an_over_constrained_mechanism_is_refused_by_default() {
    let err = Scene::from_toml(&parallel_cranks("refuse"), "cranks.toml")
        .and_then(|s| s.compile())
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("redundant") && err.contains("cranks.toml:"),
        "{err}"
    );
    let err = Scene::from_toml(&parallel_cranks("ignore"), "cranks.toml")
        .and_then(|s| s.compile())
        .unwrap_err()
        .to_string();
    assert!(err.contains("integrator.redundant"), "{err}");
}

#[test]
fn dropping_the_dependent_constraint_runs_it_with_every_constraint_held() {
    let scene = Scene::from_toml(&parallel_cranks("drop-dependent"), "cranks.toml").unwrap();
    let mut c = scene.compile().unwrap();
    assert_eq!(
        c.assembly.dropped_constraints.len(),
        1,
        "{:?}",
        c.assembly.dropped_constraints
    );
    assert_eq!(c.assembly.constraint_rows, 5);
    let mut worst = 0.0f64;
    let s = run(c.simulation.as_mut(), &c.plan, &mut |sample| {
        // All six original constraints, the dropped one included.
        let q = &sample.x[..6];
        let d = |a: [f64; 2], b: [f64; 2], l: f64| {
            ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) - l * l).abs() / 2.0
        };
        let b = |i: usize| [q[2 * i], q[2 * i + 1]];
        let g = [
            d(b(0), [0.0, 0.0], 1.0),
            d(b(1), [1.0, 0.0], 1.0),
            d(b(2), [2.0, 0.0], 1.0),
            d(b(0), b(1), 1.0),
            d(b(1), b(2), 1.0),
            d(b(0), b(2), 2.0),
        ];
        worst = g.iter().fold(worst, |a, &v| a.max(v));
    });
    assert_eq!(s.error, None);
    // The scene's Newton tolerance is 16 ε ℓ L (ℓ = 1, L ≈ 2.2), plus rounding: 64 ε ℓ L.
    assert!(
        worst <= 64.0 * f64::EPSILON * 2.3,
        "max |g| over all six: {worst:e}"
    );
    // RATTLE's energy error: bounded, O(h²) (h = 1e-3): 1e-5 of H ≈ 31.
    let e0 = s.energy_initial.unwrap();
    assert!(
        s.max_abs_energy_error.unwrap() <= 1e-5 * e0.abs(),
        "{:?}",
        s.max_abs_energy_error
    );
}

#[test]
fn a_duplicated_rod_is_dropped_on_request() {
    let text = chain_scene(&[1.0; 3], 0.5, None, 0.01, 100)
        .replace(
            "[[effects]]",
            "[[constraints]]\ntype = \"rod\"\nbodies = [\"b0\", \"b1\"]\n[[effects]]",
        )
        .replace(
            "[integrator]",
            "[integrator]\nredundant = \"drop-dependent\"",
        );
    let mut c = Scene::from_toml(&text, "dup.toml")
        .unwrap()
        .compile()
        .unwrap();
    assert_eq!(
        c.assembly.dropped_constraints,
        ["constraints[3] rod 'b0'–'b1'"]
    );
    let s = run(c.simulation.as_mut(), &c.plan, &mut |_| {});
    assert_eq!(s.error, None);
    assert!(s.max_abs_g.unwrap() < 1e-14);
}

#[test]
fn a_dependent_constraint_that_contradicts_the_others_is_not_dropped() {
    // A second rod between b0 and b1 of another length: parallel gradient, violated.
    let text = chain_scene(&[1.0; 3], 0.5, None, 0.01, 100)
        .replace(
            "[[effects]]",
            "[[constraints]]\ntype = \"rod\"\nbodies = [\"b0\", \"b1\"]\nlength = 0.7\n[[effects]]",
        )
        .replace(
            "[integrator]",
            "[integrator]\nredundant = \"drop-dependent\"",
        );
    let err = Scene::from_toml(&text, "contradiction.toml")
        .and_then(|s| s.compile())
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("contradicts") || err.contains("off the constraints"),
        "{err}"
    );
}
