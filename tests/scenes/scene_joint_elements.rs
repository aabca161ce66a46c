//! Force elements on joints in scene files: a torsion spring on a hinge rings as its closed
//! form under every scheme at the scheme's order (its gradient and Hessian on the directors in
//! closed form), with the energy each scheme promises.

use crate::common::fitted_order;
use lieflow::scene::{Scene, run};

/// A disc (1 kg, r = 0.2, h = 0.05: `J = 0.02`) on a hinge about its own axis `z` through its
/// centre, a torsion spring `k = 0.5` (`Ω = 5`), started at rest angle with `θ' = 1`:
/// `θ(t) = sin(Ωt)/Ω`, `θ'(t) = cos(Ωt)`.
fn oscillator(dt: f64, t_end: f64, scheme: &str) -> String {
    format!(
        r#"
version = 1
dim = 3
[[bodies]]
name = "disc"
mass = 1.0
inertia = {{ shape = "cylinder", radius = 0.2, height = 0.05 }}
position = [0, 0, 0]
angular_velocity = [0, 0, 1]
[[constraints]]
type = "hinge"
bodies = ["disc"]
anchor = [0, 0, 0]
axis = [0, 0, 1]
[[effects]]
type = "torsion-spring"
bodies = ["disc"]
axis = [0, 0, 1]
stiffness = 0.5
[[outputs]]
quantity = "angular-velocity"
body = "disc"
component = 2
[[outputs]]
quantity = "orientation"
body = "disc"
component = 3
[integrator]
dt = {dt}
t_end = {t_end}
{scheme}
"#
    )
}

#[test]
fn a_torsion_spring_on_a_hinge_rings_at_each_scheme_s_order() {
    let (w, t_end) = (5.0f64, 1.0);
    let theta = (w * t_end).sin() / w;
    let rate = (w * t_end).cos();
    let cases = [
        ("", 2.0),
        ("order = 4", 4.0),
        ("scheme = \"yoshida6\"", 6.0),
        ("scheme = \"extrapolation\"\norder = 4", 4.0),
        ("scheme = \"petrov-galerkin\"", 4.0),
        ("scheme = \"midpoint\"", 2.0),
        ("scheme = \"discrete-gradient\"", 2.0),
    ];
    for (scheme, order) in cases {
        let hs = [0.04, 0.02, 0.01, 0.005];
        let mut errs = Vec::new();
        for &h in &hs {
            let scene = Scene::from_toml(&oscillator(h, t_end, scheme), "torsion.toml").unwrap();
            let mut c = scene.compile().unwrap_or_else(|e| panic!("{e}"));
            let mut out = Vec::new();
            let s = run(c.simulation.as_mut(), &c.plan, &mut |s| {
                out = s.outputs.to_vec()
            });
            assert!(s.error.is_none(), "{scheme}: {:?}", s.error);
            // Every row (six of the directors, five of the hinge) at the level of its Newton
            // solve's tolerance: the projections' 16 ε (a few roundings above it), the
            // implicit schemes' stage solves 1e-13 (as for point scenes).
            let rows = if scheme.contains("petrov")
                || scheme.contains("midpoint")
                || scheme.contains("gradient")
            {
                1e-13
            } else {
                64.0 * f64::EPSILON
            };
            assert!(s.max_abs_g.unwrap() < rows, "{scheme}: {:?}", s.max_abs_g);
            // The quaternion of a turn by θ about z is (cos θ/2, 0, 0, sin θ/2).
            errs.push(
                (out[0] - rate)
                    .abs()
                    .max((out[1] - (0.5 * theta).sin()).abs()),
            );
        }
        let p = fitted_order(&hs, &errs, 1e-12);
        eprintln!("torsion oscillator, '{scheme}': errors {errs:?}, order {p:.3}");
        assert!(
            (p - order).abs() < 0.3,
            "'{scheme}': order {p}, want {order}"
        );
    }
}

#[test]
fn a_hinge_motor_spins_a_disc_up_with_its_exact_torque_and_power() {
    // The disc on its hinge (J = 0.02), a constant torque τ = 0.1 from rest: the hinge's
    // forces have no moment about its axis and the motor's kick adds exactly τ h of angular
    // momentum a step, so θ' = τ t / J at every step to round-off under the splitting; the
    // supplied work τ θ is booked and H balances it.
    let (tau, j, t_end) = (0.1, 0.02, 2.0);
    let text = oscillator(0.01, t_end, "")
        .replace("angular_velocity = [0, 0, 1]", "angular_velocity = [0, 0, 0]")
        .replace(
            "[[effects]]\ntype = \"torsion-spring\"\nbodies = [\"disc\"]\naxis = [0, 0, 1]\nstiffness = 0.5\n",
            &format!(
                "[[inputs]]\ntype = \"hinge-torque\"\nname = \"motor\"\nbodies = [\"disc\"]\naxis = [0, 0, 1]\nsignal = {{ type = \"constant\", value = {tau} }}\n[[outputs]]\nquantity = \"port-output\"\ninput = \"motor\"\n"
            ),
        );
    assert!(text.contains("hinge-torque"), "{text}");
    let mut c = Scene::from_toml(&text, "motor.toml")
        .unwrap()
        .compile()
        .unwrap_or_else(|e| panic!("{e}"));
    let mut worst = 0.0f64;
    let s = run(c.simulation.as_mut(), &c.plan, &mut |s| {
        let want = tau * s.t / j;
        // Outputs: the port output θ', ω_z, the quaternion's z.
        worst = worst
            .max((s.outputs[0] - want).abs())
            .max((s.outputs[1] - want).abs());
    });
    assert!(s.error.is_none(), "{:?}", s.error);
    assert!(worst < 1e-12, "θ' off τt/J by {worst:e}");
    let omega = tau * t_end / j;
    let kinetic = 0.5 * j * omega * omega;
    assert!(
        (s.supplied.unwrap() - kinetic).abs() < 1e-9 * kinetic,
        "{:?}",
        s.supplied
    );
    assert!(
        s.max_energy_balance_error.unwrap() < 1e-12 * kinetic,
        "{:?}",
        s.max_energy_balance_error
    );
}

/// The disc on its hinge with the torsion spring and a hinge damper `c` (`ζ = c/(2 J Ω)`).
fn damped_oscillator(dt: f64, t_end: f64, c: f64, scheme: &str) -> String {
    oscillator(dt, t_end, scheme).replacen(
        "[[outputs]]",
        &format!(
            "[[effects]]\ntype = \"hinge-damper\"\nbodies = [\"disc\"]\naxis = [0, 0, 1]\ncoefficient = {c}\n[[outputs]]"
        ),
        1,
    )
}

#[test]
fn a_hinge_damper_rings_down_as_its_closed_form_and_books_what_it_takes() {
    // J θ'' = −k θ − c θ' with J = 0.02, k = 0.5, c = 0.01 (Ω = 5, ζ = 0.05), θ'(0) = 1:
    // θ' = e^{−ζΩt} (cos ω_d t − (ζΩ/ω_d) sin ω_d t). Strang at order 2 and extrapolation at
    // order 4 (every sub-step forward); the energy never rises and the ledger's dissipation
    // closes the budget to the scheme's order.
    let (j, k, c, t_end) = (0.02f64, 0.5, 0.01, 2.0);
    let w0 = (k / j).sqrt();
    let zeta = c / (2.0 * j * w0);
    let wd = w0 * (1.0 - zeta * zeta).sqrt();
    let decay = (-zeta * w0 * t_end).exp();
    let rate = decay * ((wd * t_end).cos() - zeta * w0 / wd * (wd * t_end).sin());
    for (scheme, order) in [("", 2.0), ("scheme = \"extrapolation\"\norder = 4", 4.0)] {
        let hs = [0.04, 0.02, 0.01, 0.005];
        let (mut errs, mut budgets) = (Vec::new(), Vec::new());
        for &h in &hs {
            let text = damped_oscillator(h, t_end, c, scheme);
            let mut sim = Scene::from_toml(&text, "damped.toml")
                .unwrap()
                .compile()
                .unwrap_or_else(|e| panic!("{e}"));
            let mut out = Vec::new();
            let s = run(sim.simulation.as_mut(), &sim.plan, &mut |s| {
                out = s.outputs.to_vec()
            });
            assert!(s.error.is_none(), "{scheme}: {:?}", s.error);
            assert!(
                s.max_energy_increase.unwrap() <= 0.0,
                "{scheme}: energy rose {:?}",
                s.max_energy_increase
            );
            assert!(s.dissipated.unwrap() > 0.0);
            errs.push((out[0] - rate).abs());
            budgets.push(s.max_energy_balance_error.unwrap());
        }
        let p = fitted_order(&hs, &errs, 1e-12);
        eprintln!(
            "damped torsion oscillator, '{scheme}': errors {errs:?}, order {p:.3}; budget errors {budgets:?}"
        );
        assert!(
            (p - order).abs() < 0.3,
            "'{scheme}': order {p}, want {order}"
        );
        if scheme.is_empty() {
            let pb = fitted_order(&hs, &budgets, 1e-14);
            assert!((pb - 2.0).abs() < 0.3, "budget order {pb}");
        }
    }
}

#[test]
fn a_hinge_damper_off_the_bar_s_centre_keeps_order_two() {
    // METHOD §8's trap: a bar on a hinge 0.15 m above its centre, under gravity, a damper
    // c = 0.05 on the hinge. A damper along ∇θ itself would fight the hinge's rows and drop the
    // step to order 1; along the consistent direction it keeps order 2 (against the same scene
    // at h/16 extrapolated to order 6).
    let bar = |h: f64, scheme: &str| {
        format!(
            r#"
version = 1
dim = 3
[[bodies]]
name = "bar"
mass = 1.0
inertia = {{ shape = "box", size = [0.05, 0.05, 1.0] }}
position = [0.0, 0.0, -0.15]
orientation = {{ axis = [0, 1, 0], angle_deg = 0 }}
velocity = [-0.45, 0.0, 0.0]
angular_velocity = [0, 3, 0]
[[constraints]]
type = "hinge"
bodies = ["bar"]
anchor = [0, 0, 0]
axis = [0, 1, 0]
[[effects]]
type = "gravity"
g = [0, 0, -9.81]
[[effects]]
type = "hinge-damper"
bodies = ["bar"]
axis = [0, 1, 0]
coefficient = 0.05
[integrator]
dt = {h}
t_end = 1.0
{scheme}
"#
        )
    };
    let final_state = |text: &str| {
        let mut c = Scene::from_toml(text, "trap.toml")
            .unwrap()
            .compile()
            .unwrap_or_else(|e| panic!("{e}"));
        let s = run(c.simulation.as_mut(), &c.plan, &mut |_| {});
        assert!(s.error.is_none(), "{:?}", s.error);
        s.x
    };
    let reference = final_state(&bar(0.04 / 16.0, "scheme = \"extrapolation\"\norder = 6"));
    let hs = [0.04, 0.02, 0.01, 0.005];
    let errs: Vec<f64> = hs
        .iter()
        .map(|&h| {
            let x = final_state(&bar(h, ""));
            (0..3)
                .map(|k| (x[k] - reference[k]).abs())
                .fold(0.0, f64::max)
        })
        .collect();
    let p = fitted_order(&hs, &errs, 1e-11);
    eprintln!("damper off the bar's centre: errors {errs:?}, order {p:.3}");
    assert!((p - 2.0).abs() < 0.3, "{p}");
}

#[test]
fn the_implicit_schemes_refuse_hinge_dampers_by_name() {
    for scheme in ["petrov-galerkin", "midpoint", "discrete-gradient"] {
        let text = damped_oscillator(0.01, 0.1, 0.01, &format!("scheme = \"{scheme}\""));
        let e = Scene::from_toml(&text, "d.toml")
            .unwrap()
            .compile()
            .expect_err("refused");
        let shown = e.to_string();
        assert!(
            shown.contains("integrator.scheme") && shown.contains("hinge or slider dampers"),
            "{shown}"
        );
    }
}

#[test]
fn a_joint_reports_the_force_and_torque_it_exerts() {
    // A disc (2 kg) on a hinge about z through its centre, under gravity, twisted about x by a
    // held motor τ = 0.3 that the hinge resists: at rest, the hinge carries the weight,
    // (0, 0, m g), and the opposite of the twist, (−τ, 0, 0), about the disc's centre — read
    // from the step's multipliers to round-off.
    let text = r#"
version = 1
dim = 3
[[bodies]]
name = "disc"
mass = 2.0
inertia = { shape = "cylinder", radius = 0.2, height = 0.05 }
position = [0, 0, 0]
[[constraints]]
type = "hinge"
name = "axle"
bodies = ["disc"]
anchor = [0, 0, 0]
axis = [0, 0, 1]
[[effects]]
type = "gravity"
g = [0, 0, -9.81]
[[inputs]]
type = "hinge-torque"
name = "twist"
bodies = ["disc"]
axis = [1, 0, 0]
signal = { type = "constant", value = 0.3 }
[[outputs]]
quantity = "joint-force"
constraint = "axle"
component = 2
[[outputs]]
quantity = "joint-torque"
constraint = "axle"
component = 0
[[outputs]]
quantity = "joint-torque"
constraint = "axle"
component = 1
[[outputs]]
quantity = "joint-force"
constraint = "axle"
component = 0
[integrator]
dt = 0.01
t_end = 1.0
"#;
    let mut c = Scene::from_toml(text, "reaction.toml")
        .unwrap()
        .compile()
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(
        c.simulation.output_names(),
        [
            "force_axle.z",
            "torque_axle.x",
            "torque_axle.y",
            "force_axle.x"
        ]
    );
    let mut samples = 0;
    let s = run(c.simulation.as_mut(), &c.plan, &mut |s| {
        if s.step == 0 {
            return;
        }
        samples += 1;
        let o = s.outputs;
        assert!((o[0] - 2.0 * 9.81).abs() < 1e-12, "{o:?}");
        assert!(
            (o[1] + 0.3).abs() < 1e-12 && o[2].abs() < 1e-12 && o[3].abs() < 1e-12,
            "{o:?}"
        );
    });
    assert!(s.error.is_none() && samples == 100, "{:?}", s.error);
}

#[test]
fn a_torsion_spring_rests_away_from_its_half_turn_cusp() {
    // The disc from rest, its spring's rest 170° away: it swings through θ = ±180° (where the
    // hinge angle wraps) to 340° and back; the stretch θ − θ₀ is taken within half a turn of
    // the rest, so the energy stays continuous and the splitting keeps it to O(h²).
    let text = oscillator(1e-3, 3.0, "")
        .replace(
            "angular_velocity = [0, 0, 1]",
            "angular_velocity = [0, 0, 0]",
        )
        .replace(
            "stiffness = 0.5\n",
            "stiffness = 0.5\nrest_angle_deg = 170\n",
        );
    assert!(text.contains("rest_angle_deg"), "{text}");
    let mut c = Scene::from_toml(&text, "wrap.toml")
        .unwrap()
        .compile()
        .unwrap_or_else(|e| panic!("{e}"));
    let s = run(c.simulation.as_mut(), &c.plan, &mut |_| {});
    assert!(s.error.is_none(), "{:?}", s.error);
    let h0 = s.energy_initial.unwrap();
    // H₀ = ½ k (170°)².
    assert!(
        (h0 - 0.25 * 170f64.to_radians().powi(2)).abs() < 1e-12,
        "{h0}"
    );
    assert!(
        s.max_abs_energy_error.unwrap() < 1e-4 * h0,
        "{:?}",
        s.max_abs_energy_error
    );
}
