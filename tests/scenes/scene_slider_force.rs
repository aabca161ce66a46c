//! A linear motor on a slider (`slider-force`): two boxes on a slider along a tilted axis,
//! driven along it by a constant force between them. The slider's rows have no component along its
//! axis and the motor's kick adds exactly `F h` to the relative momentum along it a step, so the
//! relative rate is `s' = F t / μ` (`μ` the reduced mass) at every step to round-off under the
//! splitting; the reaction keeps the total momentum at zero and the energy is `½ μ s'²` to
//! round-off. The work booked as supplied is the input kicks' `H(after) − H(before)`; `∇s` has
//! a director part along the first body's own rows (the axis it carries, stretched), which the
//! projection absorbs whatever it is, and the kick leaves it out so that it books only the
//! impulse the motion keeps: the budget closes to round-off, the motion unchanged.

use crate::scene_text::boxes_on_a_slider;
use lieflow::scene::{Scene, run};

/// Boxes of 1 and 2 kg at rest, the second 0.5 m along `u = (1, 1, 0)/√2` from the first, a
/// slider between them along `u`, and the motor `push` of `force` newtons on it.
fn pushed(force: f64, dt: f64, t_end: f64, scheme: &str) -> String {
    boxes_on_a_slider(
        0.0,
        &format!(
            r#"[[inputs]]
type = "slider-force"
name = "push"
bodies = ["a", "b"]
axis = [1, 1, 0]
signal = {{ type = "constant", value = {force} }}
[[outputs]]
quantity = "port-output"
input = "push""#
        ),
        dt,
        t_end,
        scheme,
    )
}

#[test]
fn a_slider_motor_drives_two_bodies_along_it_with_its_exact_force_and_power() {
    let (force, mu, t_end) = (0.6, 2.0 / 3.0, 2.0);
    let text = pushed(force, 0.01, t_end, "");
    let mut c = Scene::from_toml(&text, "push.toml")
        .unwrap()
        .compile()
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(
        c.assembly
            .inputs
            .iter()
            .any(|(n, what)| n == "push" && what.contains("slider")),
        "{:?}",
        c.assembly.inputs
    );
    let mut worst = 0.0f64;
    let s = run(c.simulation.as_mut(), &c.plan, &mut |s| {
        // The port output is s' (of the first body from the second along the axis).
        worst = worst.max((s.outputs[0] - force * s.t / mu).abs());
    });
    assert!(s.error.is_none(), "{:?}", s.error);
    // s' grows to 1.8 over 200 steps, each adding round-off of its size.
    assert!(worst < 1e-12, "s' off F t/μ by {worst:e}");
    let rate = force * t_end / mu;
    let kinetic = 0.5 * mu * rate * rate;
    assert!(
        (s.energy_final.unwrap() - kinetic).abs() < 1e-12 * kinetic,
        "H = {:?}, ½ μ s'² = {kinetic}",
        s.energy_final
    );
    // The reaction: the centres' momenta (slots 0 and 4 of 8) sum to zero.
    let nq = s.x.len() / 2;
    for k in 0..3 {
        let total = s.x[nq + k] + s.x[nq + 12 + k];
        assert!(total.abs() < 1e-13, "total momentum {k}: {total:e}");
    }
    // The force pushes `s` (the first body's displacement from the second along u) up: the
    // first body moves along +u by m_b/(m_a + m_b) of s = F t²/(2μ).
    let gap = force * t_end * t_end / (2.0 * mu);
    let along = (s.x[0] + s.x[1]) * std::f64::consts::FRAC_1_SQRT_2;
    assert!(
        (along - gap * 2.0 / 3.0).abs() < 1e-12,
        "a moved {along} along u, want {}",
        gap * 2.0 / 3.0
    );
}

#[test]
fn the_splittings_booked_work_closes_the_budget_to_round_off_at_every_step_size() {
    // With the impulse along the body's rows booked, the budget error was 4.4e-2, 1.1e-2,
    // 2.7e-3, 6.8e-4 for these steps (order 2): now each is round-off of the energy's size.
    let (force, mu, t_end) = (0.6, 2.0 / 3.0, 2.0);
    let kinetic: f64 = 0.5 * mu * (force * t_end / mu) * (force * t_end / mu);
    for h in [0.02, 0.01, 0.005, 0.0025] {
        let text = pushed(force, h, t_end, "");
        let mut c = Scene::from_toml(&text, "push.toml")
            .unwrap()
            .compile()
            .unwrap();
        let s = run(c.simulation.as_mut(), &c.plan, &mut |_| {});
        assert!(s.error.is_none());
        let steps = t_end / h;
        let balance = s.max_energy_balance_error.unwrap();
        // Each step's kick and sum round: a few ε of the energy a step.
        assert!(
            balance < 8.0 * steps * f64::EPSILON * kinetic,
            "h = {h}: budget error {balance:e}"
        );
        assert!((s.energy_final.unwrap() - kinetic).abs() < 1e-12 * kinetic);
    }
}

#[test]
fn the_implicit_schemes_and_the_extrapolation_book_its_work_exactly() {
    // Petrov–Galerkin integrates `B u` in its residual and books its work; the discrete
    // gradient takes it at the midpoint with an exact budget; the extrapolation's budget is
    // its own order's: here, on motion at constant force, each to round-off.
    let (force, mu, t_end) = (0.6, 2.0 / 3.0, 2.0);
    let kinetic: f64 = 0.5 * mu * (force * t_end / mu) * (force * t_end / mu);
    for scheme in [
        "scheme = \"petrov-galerkin\"",
        "scheme = \"discrete-gradient\"",
        "scheme = \"extrapolation\"\norder = 6",
    ] {
        let text = pushed(force, 0.01, t_end, scheme);
        let mut c = Scene::from_toml(&text, "push.toml")
            .unwrap()
            .compile()
            .unwrap();
        let s = run(c.simulation.as_mut(), &c.plan, &mut |_| {});
        assert!(s.error.is_none(), "{scheme}: {:?}", s.error);
        let e = s.energy_final.unwrap();
        assert!((e - kinetic).abs() < 1e-12 * kinetic, "{scheme}: H = {e}");
        let balance = s.max_energy_balance_error.unwrap();
        assert!(
            balance < 1e-12 * kinetic,
            "{scheme}: budget error {balance:e}"
        );
        assert!(
            s.max_abs_g.unwrap() < 1e-12,
            "{scheme}: |g| {:?}",
            s.max_abs_g
        );
    }
}

#[test]
fn a_slider_motor_names_its_slider_errors() {
    // A point body cannot carry a slider's axis.
    let text = pushed(1.0, 0.01, 0.1, "").replace(
        "inertia = { shape = \"box\", size = [0.2, 0.1, 0.3] }\n",
        "",
    );
    let e = Scene::from_toml(&text, "point.toml")
        .unwrap()
        .compile()
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("inputs[0]") || e.contains("constraints[0]"),
        "{e}"
    );
}
