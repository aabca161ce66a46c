//! The stiff flyball governor (`scenes/flyball_governor.toml`, after IFToMM A05: couplers as
//! spring-dampers of 8e5 N/m and 4e4 N s/m, rods 1 m × 1 cm with 5 kg balls) at a step that
//! resolves it runs with every row at round-off, keeps its angular momentum about the shaft
//! (nothing turns it: bearing, gravity and the internal elements exert no torque about z),
//! never gains energy in a step and books what its dampers take; at a step far too coarse for
//! its springs it stops with a typed error that names the cure, keeping what it computed.

use lieflow::scene::{Scene, run};

const GOVERNOR: &str = include_str!("../../scenes/flyball_governor.toml");

fn with(dt: &str, t_end: &str) -> Scene {
    let text: String = GOVERNOR
        .lines()
        .map(|l| {
            if l.starts_with("dt =") {
                format!("dt = {dt}")
            } else if l.starts_with("t_end =") {
                format!("t_end = {t_end}")
            } else {
                l.to_owned()
            }
        })
        .collect::<Vec<_>>()
        .join("\n");
    Scene::from_toml(&text, "flyball_governor.toml").unwrap()
}

/// `L_z = Σ_s (q_x p_y − q_y p_x)` over every slot: centres, directors (a body's own angular
/// momentum is `Σᵢ dᵢ × p_dᵢ`) and the balls.
fn spin_momentum(x: &[f64]) -> f64 {
    let (q, p) = x.split_at(x.len() / 2);
    q.chunks(3)
        .zip(p.chunks(3))
        .map(|(q, p)| q[0] * p[1] - q[1] * p[0])
        .sum()
}

#[test]
fn the_stiff_governor_runs_at_a_resolving_step_and_stops_typed_at_a_coarse_one() {
    let mut c = with("1e-5", "0.002")
        .compile()
        .unwrap_or_else(|e| panic!("{e}"));
    let l0 = spin_momentum(c.simulation.state());
    let s = run(c.simulation.as_mut(), &c.plan, &mut |_| {});
    assert!(s.error.is_none(), "{:?}", s.error);
    assert_eq!(s.steps, 200);
    // At the projection's level for unit-scale rows, though thin rods (director masses
    // 2.5e-6 kg) beside 5 kg balls make the multiplier systems' condition ~1e6: Newton's
    // Jacobian is exact (the dampers act along directions the constraint forces do not reach).
    assert!(
        s.max_abs_g.unwrap() <= 64.0 * f64::EPSILON,
        "{:?}",
        s.max_abs_g
    );
    assert!(
        s.newton_iterations <= 3 * s.steps as u64,
        "{} in {}",
        s.newton_iterations,
        s.steps
    );
    let l1 = spin_momentum(&s.x);
    eprintln!(
        "L_z {l0} -> {l1}; dissipated {:?}, balance {:?}",
        s.dissipated, s.max_energy_balance_error
    );
    assert!((l1 - l0).abs() < 1e-11 * l0.abs(), "{l0} -> {l1}");
    assert!(
        s.max_energy_increase.unwrap() <= 0.0,
        "{:?}",
        s.max_energy_increase
    );
    let dissipated = s.dissipated.unwrap();
    assert!(dissipated > 0.0);
    assert!(s.max_energy_balance_error.unwrap() < 1e-2 * dissipated);

    // A thousand times the step (h √(k/m) far above 2): the multiplier solve fails within a
    // few steps, reported as such with what to try; the run ends there, keeping what it had.
    let mut c = with("1e-2", "0.5")
        .compile()
        .unwrap_or_else(|e| panic!("{e}"));
    let x0 = c.simulation.state().to_vec();
    let s = run(c.simulation.as_mut(), &c.plan, &mut |_| {});
    let e = s.error.as_ref().expect("a step this coarse fails");
    let shown = format!("{e:?}");
    assert!(
        shown.contains("Newton") && shown.contains("smaller step"),
        "{shown}"
    );
    assert!(s.steps < 50, "{}", s.steps);
    assert_eq!(c.simulation.state().len(), x0.len());
}

/// Under a tolerance `dt` is the report interval, not a step: a budget error above 1% of what
/// the dampers take is blamed on the tolerance. At `tol = 1e-4` the governor's steps (~7 ms)
/// are long for its 400 rad/s springs and the books are off by about what the dampers take;
/// at `tol = 1e-8` they close within the warning's 1%.
#[test]
fn under_a_tolerance_the_budget_warning_asks_for_a_tighter_one() {
    let run_at = |tol: &str| {
        let mut c = with(&format!("0.2\ntol = {tol}"), "0.2")
            .compile()
            .unwrap_or_else(|e| panic!("{e}"));
        let s = run(c.simulation.as_mut(), &c.plan, &mut |_| {});
        assert!(s.error.is_none(), "{:?}", s.error);
        assert!(s.adaptive.is_some());
        s
    };
    let loose = run_at("1e-4");
    let warning = loose.energy_balance_warning.expect("flagged");
    assert!(
        warning.contains("a tighter tol") && !warning.contains("dt"),
        "{warning}"
    );
    let tight = run_at("1e-8");
    assert!(
        tight.energy_balance_warning.is_none(),
        "{:?}",
        tight.energy_balance_warning
    );
}
