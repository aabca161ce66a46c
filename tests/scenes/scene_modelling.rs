//! What a mechanical user declares first: a spring to a fixed point, a chain or pendulum given
//! by its angles and angular velocities, and initial velocities made consistent with the
//! constraints. Each checked against its closed form or the constraint it must satisfy.

use crate::scene_text;

use scene_text::{parse, run_scene};

/// One body on a spring of rest length `rest` to the origin, released from rest at distance
/// `rest + a` on the x axis: it moves on the axis, `r(t) = L + a cos(ω t)`, `ω = √(k/m)`.
fn anchored(rest: f64, dt: f64) -> String {
    format!(
        r#"version = 1
name = "anchored spring"
dim = 2
[[bodies]]
name = "b"
mass = 2.0
position = [{}, 0.0]
[[effects]]
type = "spring"
bodies = ["b"]
point = [0.0, 0.0]
stiffness = 8.0
rest_length = {rest}
[integrator]
dt = {dt}
t_end = 1.0
"#,
        rest + 0.3
    )
}

#[test]
fn a_spring_to_a_fixed_point_oscillates_about_its_rest_length_at_second_order() {
    let omega = (8.0f64 / 2.0).sqrt();
    for rest in [0.0, 1.5] {
        let exact = rest + 0.3 * omega.cos();
        let error = |dt: f64| {
            let s = run_scene(&parse(&anchored(rest, dt)));
            assert!(s.error.is_none(), "{:?}", s.error);
            assert_eq!(s.x[1], 0.0, "it stays on the axis");
            // Strang conserves a modified energy: the energy error is O(h²), bounded.
            assert!(s.max_abs_energy_error.unwrap() < 10.0 * dt * dt);
            (s.x[0] - exact).abs()
        };
        let (e1, e2) = (error(0.01), error(0.005));
        let order = (e1 / e2).log2();
        assert!(
            (order - 2.0).abs() < 0.3,
            "rest {rest}: order {order} ({e1:e}, {e2:e})"
        );
    }
}

#[test]
fn a_spring_to_a_point_runs_under_the_implicit_schemes_with_its_hessian() {
    // The midpoint rule's Newton uses the Hessian product: it converges, at second order.
    let exact = 1.5 + 0.3 * 2.0f64.cos();
    let error = |dt: f64| {
        let text =
            anchored(1.5, dt).replace("[integrator]\n", "[integrator]\nscheme = \"midpoint\"\n");
        let s = run_scene(&parse(&text));
        assert!(s.error.is_none(), "{:?}", s.error);
        (s.x[0] - exact).abs()
    };
    let order = (error(0.01) / error(0.005)).log2();
    assert!((order - 2.0).abs() < 0.3, "order {order}");
}

#[test]
fn chain_angles_place_the_links_and_their_rates_satisfy_the_hidden_constraints() {
    let text = r#"version = 1
name = "double pendulum"
dim = 2
[[chains]]
name = "arm"
links = 2
anchor = [0.0, 1.0]
length = 0.5
mass = 1.0
angles_deg = [30.0, 90.0]
angular_velocities_deg = [45.0, -20.0]
[integrator]
dt = 0.01
t_end = 0.01
"#;
    let mut c = parse(text).compile().unwrap_or_else(|e| panic!("{e}"));
    let x = c.simulation.state().to_vec();
    let (s30, c30) = (30f64.to_radians().sin(), 30f64.to_radians().cos());
    let q0 = [0.5 * s30, 1.0 - 0.5 * c30];
    let q1 = [q0[0] + 0.5, q0[1]];
    for (got, want) in x[..4].iter().zip(q0.iter().chain(&q1)) {
        assert!(
            (got - want).abs() <= 4.0 * f64::EPSILON,
            "{got} against {want}"
        );
    }
    // v₀ = L θ̇₀ (cos θ₀, sin θ₀); v₁ = v₀ + L θ̇₁ (cos θ₁, sin θ₁).
    let (w0, w1) = (45f64.to_radians(), -20f64.to_radians());
    let v0 = [0.5 * w0 * c30, 0.5 * w0 * s30];
    let v1 = [v0[0], v0[1] + 0.5 * w1];
    for (got, want) in x[4..].iter().zip(v0.iter().chain(&v1)) {
        assert!(
            (got - want).abs() <= 4.0 * f64::EPSILON,
            "{got} against {want}"
        );
    }
    let (g, phi) = c.simulation.residuals().unwrap();
    assert!(
        g <= 4.0 * f64::EPSILON && phi <= 4.0 * f64::EPSILON,
        "{g:e} {phi:e}"
    );
    // One value serves every link; a wrong count and 3D are refused where they are written.
    let one = text
        .replace("[30.0, 90.0]", "[30.0]")
        .replace("[45.0, -20.0]", "[0.0]");
    let x = parse(&one).compile().unwrap().simulation.state().to_vec();
    assert!((x[3] - (1.0 - c30)).abs() <= 4.0 * f64::EPSILON);
    let e = parse(&text.replace("[30.0, 90.0]", "[30.0, 90.0, 10.0]"))
        .compile()
        .err()
        .unwrap();
    assert_eq!(e.path.to_string(), "chains[0].angles_deg");
    let e = parse(
        &text
            .replace("dim = 2", "dim = 3")
            .replace("[0.0, 1.0]", "[0.0, 1.0, 0.0]"),
    )
    .compile()
    .err()
    .unwrap();
    assert!(e.message.contains("in 3D give a `direction`"), "{e}");
}

#[test]
fn consistent_velocities_keep_the_tangential_part_in_the_kinetic_metric() {
    let text = r#"version = 1
name = "pendulum pushed along the rod"
dim = 2
[[bodies]]
name = "bob"
mass = 3.0
position = [0.6, -0.8]
velocity = [1.0, 1.0]
[[constraints]]
type = "rod"
bodies = ["bob"]
point = [0.0, 0.0]
length = 1.0
[integrator]
dt = 0.01
t_end = 0.01
"#;
    // Refused as given: the velocity has a component along the rod.
    let e = parse(text).compile().err().unwrap();
    assert!(e.message.contains("consistent_velocities = true"), "{e}");
    let fixed = text.replace(
        "t_end = 0.01\n",
        "t_end = 0.01\nconsistent_velocities = true\n",
    );
    let mut c = parse(&fixed).compile().unwrap_or_else(|e| panic!("{e}"));
    let x = c.simulation.state().to_vec();
    // One body: the projection keeps v − (v·u) u, u = q/|q| the rod's direction.
    let (u, v) = ([0.6, -0.8], [1.0, 1.0]);
    let along = u[0] * v[0] + u[1] * v[1];
    let want = [3.0 * (v[0] - along * u[0]), 3.0 * (v[1] - along * u[1])];
    assert_eq!(x[..2], [0.6, -0.8], "the positions are kept");
    for (got, want) in x[2..].iter().zip(&want) {
        assert!(
            (got - want).abs() <= 8.0 * f64::EPSILON,
            "{got} against {want}"
        );
    }
    let (_, phi) = c.simulation.residuals().unwrap();
    assert!(phi <= 8.0 * f64::EPSILON, "{phi:e}");
    let (dq, dp) = c.assembly.initial_projection.unwrap();
    assert_eq!(dq, 0.0);
    assert!(
        (dp - 3.0 * along.abs() * 0.8).abs() <= 8.0 * f64::EPSILON,
        "{dp}"
    );
}

/// Two free bodies (masses 1 and 3) joined by a dashpot of coefficient `c`, moving apart.
fn dashpot_pair(c: f64, dt: f64, scheme: &str) -> String {
    format!(
        r#"version = 1
name = "dashpot"
dim = 2
[[bodies]]
name = "a"
mass = 1.0
position = [0.0, 0.0]
velocity = [1.0, 0.5]
[[bodies]]
name = "b"
mass = 3.0
position = [1.0, 0.0]
velocity = [-0.2, 0.1]
[[effects]]
type = "dashpot"
bodies = ["a", "b"]
coefficient = {c}
[integrator]
scheme = "{scheme}"
dt = {dt}
t_end = 2.0
"#
    )
}

#[test]
fn a_dashpot_damps_the_relative_velocity_keeps_the_momentum_and_books_its_energy_exactly() {
    let (c, t) = (1.5f64, 2.0f64);
    // μ = 3/4, γ = c/μ; u₀ = v_a − v_b = (1.2, 0.4); the relative position q_a − q_b moves by
    // u₀ (1 − e^{−γt})/γ, the centre of mass uniformly.
    let (mu, u0) = (0.75, [1.2, 0.4]);
    let gamma = c / mu;
    let exact_rel = [
        -1.0 + u0[0] * (1.0 - (-gamma * t).exp()) / gamma,
        u0[1] * (1.0 - (-gamma * t).exp()) / gamma,
    ];
    let error = |dt: f64| {
        let s = run_scene(&parse(&dashpot_pair(c, dt, "auto")));
        assert!(s.error.is_none(), "{:?}", s.error);
        let x = &s.x;
        // Total momentum p_a + p_b = (1 − 0.6, 0.5 + 0.3), kept by every sub-flow.
        assert!((x[4] + x[6] - 0.4).abs() <= 16.0 * f64::EPSILON);
        assert!((x[5] + x[7] - 0.8).abs() <= 16.0 * f64::EPSILON);
        // The drift keeps T, the dashpot flow books exactly what it removes: the budget closes
        // to the rounding of the steps (a few ε of H per step).
        let steps = (t / dt).round();
        let budget = s.max_energy_balance_error.unwrap();
        assert!(budget <= 8.0 * f64::EPSILON * steps, "budget {budget:e}");
        assert!(s.max_energy_increase.unwrap() <= 0.0);
        let rel = [x[0] - x[2], x[1] - x[3]];
        (rel[0] - exact_rel[0])
            .abs()
            .max((rel[1] - exact_rel[1]).abs())
    };
    let (e1, e2) = (error(0.02), error(0.01));
    let order = (e1 / e2).log2();
    assert!((order - 2.0).abs() < 0.3, "order {order} ({e1:e}, {e2:e})");
}

#[test]
fn a_dashpot_enters_the_implicit_schemes_through_r() {
    // The discrete gradient with the dashpot in M: the energy never rises, and the run agrees
    // with the splitting to the two schemes' O(h²) errors.
    let dg = run_scene(&parse(&dashpot_pair(1.5, 0.005, "discrete-gradient")));
    let strang = run_scene(&parse(&dashpot_pair(1.5, 0.005, "auto")));
    assert!(dg.error.is_none(), "{:?}", dg.error);
    assert!(dg.max_energy_increase.unwrap() <= 0.0);
    assert!(dg.dissipated.unwrap() > 0.1);
    let diff =
        dg.x.iter()
            .zip(&strang.x)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    assert!(diff < 1e-4, "{diff:e}");
    // Switched off by the damping flag or its kind's absence, the bodies fly apart freely.
    let free = run_scene(&parse(
        &dashpot_pair(1.5, 0.01, "auto")
            .replace("[integrator]", "[flags]\ndamping = false\n[integrator]"),
    ));
    assert!((free.x[0] - 2.0).abs() < 1e-12, "{}", free.x[0]);
    assert!(free.dissipated.is_none());
}

#[test]
fn parameters_name_numbers_of_the_scene_and_a_bad_path_is_refused_where_it_is_written() {
    let text = dashpot_pair(1.5, 0.01, "auto").replace(
        "[integrator]",
        "[[parameters]]\nname = \"c\"\npath = \"effects[0].coefficient\"\n[[parameters]]\nname = \"m\"\npath = \"bodies[1].mass\"\n[integrator]",
    );
    let scene = parse(&text);
    let values = scene.parameter_values().unwrap();
    assert_eq!(
        values,
        [
            ("c".to_owned(), "effects[0].coefficient".to_owned(), 1.5),
            ("m".to_owned(), "bodies[1].mass".to_owned(), 3.0)
        ]
    );
    // The scene with a parameter set is the scene with that number.
    let changed = scene.with_value("effects[0].coefficient", 0.5).unwrap();
    assert_eq!(changed.parameter_values().unwrap()[0].2, 0.5);
    // Fields set one after another all hold (an FMU sets its parameters so).
    let both = changed.with_value("bodies[1].mass", 4.0).unwrap();
    let values: Vec<f64> = both
        .parameter_values()
        .unwrap()
        .iter()
        .map(|p| p.2)
        .collect();
    assert_eq!(values, [0.5, 4.0]);
    assert_eq!(both.file.bodies[1].mass, Some(4.0));
    let bad = text.replace("effects[0].coefficient", "effects[3].coefficient");
    let e = parse(&bad).compile().err().unwrap();
    assert_eq!(e.path.to_string(), "parameters[0].path");
    assert!(e.message.contains("element [3]"), "{e}");
    assert!(e.location.is_some(), "located in the text");
    let twice = text.replace("name = \"m\"", "name = \"c\"");
    let e = parse(&twice).compile().err().unwrap();
    assert!(e.message.contains("used twice"), "{e}");
}
