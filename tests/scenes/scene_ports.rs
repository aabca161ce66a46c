//! Scene ports: inputs enter the splitting at its order with an exact energy budget, held
//! inputs are set by the embedder, events are located, checkpoints continue bit for bit, and
//! bad port declarations are located errors.

use lieflow::scene::{Scene, SceneErrorKind, run};

pub(crate) fn parse(text: &str) -> Scene {
    Scene::from_toml(text, "ports.toml").unwrap_or_else(|e| panic!("{e}"))
}

/// A damped pendulum driven by a torque about its pivot.
pub(crate) fn driven(dt: f64, t_end: f64, damping: f64, signal: &str) -> String {
    format!(
        r#"
version = 1
dim = 2
[[bodies]]
name = "bob"
mass = 1.0
position = [0.6, -0.8]
[[constraints]]
type = "rod"
bodies = ["bob"]
point = [0.0, 0.0]
[[effects]]
type = "gravity"
g = [0.0, -9.81]
[[effects]]
type = "damping"
coefficient = {damping}
[[inputs]]
type = "torque"
name = "motor"
body = "bob"
pivot = [0.0, 0.0]
signal = {signal}
[[outputs]]
quantity = "power"
input = "motor"
[[outputs]]
quantity = "supplied"
[integrator]
dt = {dt}
t_end = {t_end}
"#
    )
}

pub(crate) const SINE: &str = r#"{ type = "sine", amplitude = 2.0, omega = 3.0 }"#;

#[test]
fn a_driven_damped_pendulum_closes_its_energy_budget_at_order_two() {
    let mut errs = vec![];
    for dt in [4e-3, 2e-3, 1e-3, 5e-4] {
        let mut c = parse(&driven(dt, 5.0, 0.3, SINE)).compile().unwrap();
        let s = run(c.simulation.as_mut(), &c.plan, &mut |_| {});
        assert!(s.error.is_none());
        assert!(s.max_abs_g.unwrap() < 1e-14);
        assert!(s.supplied.unwrap().abs() > 0.1 && s.dissipated.unwrap() > 0.1);
        errs.push(s.max_energy_balance_error.unwrap());
    }
    for w in errs.windows(2) {
        let ratio = w[0] / w[1];
        assert!(
            (3.5..4.5).contains(&ratio),
            "halving dt divides the budget error by {ratio}: {errs:?}"
        );
    }
}

#[test]
fn the_supplied_energy_is_the_integral_of_the_ports_power() {
    // ∫ y u dt by the trapezoidal rule over the outputs agrees with the flow's exact account
    // to the quadrature's O(h²).
    let mut c = parse(&driven(1e-3, 3.0, 0.3, SINE)).compile().unwrap();
    let mut power = vec![];
    let mut supplied = 0.0;
    let s = run(c.simulation.as_mut(), &c.plan, &mut |s| {
        power.push(s.outputs[0]);
        supplied = s.outputs[1];
    });
    let trapezoid: f64 = power.windows(2).map(|w| 0.5 * (w[0] + w[1]) * 1e-3).sum();
    assert!(
        (trapezoid - supplied).abs() < 1e-5,
        "{trapezoid} vs {supplied}"
    );
    assert_eq!(s.supplied, Some(supplied));
}

#[test]
fn stiff_damping_books_the_creep_the_constraints_allow() {
    // c = 1e6 on a step of 1e-3 (c h / m = 1000). The trapezoidal rule of the power gave
    // hundreds of joules here, and the flight's own account 0.031 J: the damped flight runs
    // between the projection's half-steps on momenta that cross the rod, (h F_n)²/(2m) a step
    // of the normal pull F_n = m g · n̂, which the projection takes back. Booked on the motion
    // the rod allows, the dissipated energy is the true creep, F_t² h/c per step, and equals
    // the energy lost to round-off — never decreasing.
    let text = driven(1e-3, 1.0, 1e6, r#"{ type = "constant", value = 0.0 }"#)
        .replace("quantity = \"supplied\"", "quantity = \"dissipated\"");
    let mut c = parse(&text).compile().unwrap();
    let mut dissipated = vec![];
    let s = run(c.simulation.as_mut(), &c.plan, &mut |s| {
        dissipated.push(s.outputs[1])
    });
    assert!(
        dissipated.windows(2).all(|w| w[1] >= w[0]),
        "dissipation ran backwards"
    );
    // At (0.6, −0.8): tangential pull 9.81 · 0.6 (the bob creeps by 3e-5, the corrections are
    // O(m/(c h)) = 1e-3).
    let tangential: f64 = 9.81 * 0.6;
    let creep = 1000.0 * tangential.powi(2) * 1e-3 / 1e6;
    let d = s.dissipated.unwrap();
    assert!((d / creep - 1.0).abs() < 3e-3, "{d:e} vs {creep:e}");
    let lost = s.energy_initial.unwrap() - s.energy_final.unwrap();
    assert!((lost / creep - 1.0).abs() < 3e-3, "{lost:e} vs {creep:e}");
    // |H| ≈ 7.8 and a thousand steps: the budget closes to their rounding.
    assert!(s.max_energy_balance_error.unwrap() < 1e-11);
    assert!(s.energy_balance_warning.is_none());
}

/// The budget's error is flagged when it is more than 1% of the energy exchanged: a damped
/// pendulum at a step too coarse for its energy error (`dt = 0.2`, the swing's period 2).
#[test]
fn a_budget_dominated_by_the_scheme_s_energy_error_is_flagged() {
    let text = driven(0.2, 10.0, 0.05, r#"{ type = "constant", value = 0.0 }"#);
    let mut c = parse(&text).compile().unwrap();
    let s = run(c.simulation.as_mut(), &c.plan, &mut |_| {});
    let (error, d) = (s.max_energy_balance_error.unwrap(), s.dissipated.unwrap());
    eprintln!("budget error {error:e} of {d:e} dissipated");
    assert!(error > lieflow::scene::BUDGET_WARNING_FRACTION * d);
    let warning = s.energy_balance_warning.expect("flagged");
    assert!(
        warning.contains("smaller dt") && warning.len() < 180,
        "{warning}"
    );
    // At a step that resolves it, not.
    let mut c = parse(&driven(
        1e-3,
        10.0,
        0.05,
        r#"{ type = "constant", value = 0.0 }"#,
    ))
    .compile()
    .unwrap();
    let s = run(c.simulation.as_mut(), &c.plan, &mut |_| {});
    assert!(
        s.energy_balance_warning.is_none(),
        "{:?}",
        s.energy_balance_warning
    );
}

/// A block on a floor under gravity and damping: at rest it books no dissipation at all
/// (the damper in the flight used to book `c g² h² T/12`, 0.16 here, with `H` constant), and
/// sliding it books exactly the kinetic energy the damper takes, `½ m v² (1 − e^{−2ct/m})`.
#[test]
fn a_constrained_damped_body_books_only_the_motion_its_constraints_allow() {
    let block = |velocity: f64, t_end: f64| {
        format!(
            r#"
version = 1
dim = 2
[[bodies]]
name = "block"
mass = 1.0
position = [0.0, 0.0]
velocity = [{velocity}, 0.0]
[[constraints]]
type = "plane"
bodies = ["block"]
normal = [0.0, 1.0]
[[effects]]
type = "gravity"
g = [0.0, -9.81]
[[effects]]
type = "damping"
coefficient = 2.0
[integrator]
dt = 0.01
t_end = {t_end}
"#
        )
    };
    let mut c = parse(&block(0.0, 100.0)).compile().unwrap();
    let s = run(c.simulation.as_mut(), &c.plan, &mut |_| {});
    assert_eq!(s.dissipated, Some(0.0));
    assert_eq!(s.energy_final, Some(0.0));
    assert!(s.energy_balance_warning.is_none());
    let mut c = parse(&block(3.0, 2.0)).compile().unwrap();
    let s = run(c.simulation.as_mut(), &c.plan, &mut |_| {});
    let exact = 0.5 * 9.0 * (1.0 - (-2.0f64 * 2.0 * 2.0).exp());
    let d = s.dissipated.unwrap();
    assert!((d - exact).abs() < 1e-12 * exact, "{d} vs {exact}");
    assert!(s.max_energy_balance_error.unwrap() < 1e-12);
}

#[test]
fn held_inputs_checkpoints_and_advance_to_serve_an_embedder() {
    let text = driven(1e-3, 10.0, 0.1, r#"{ type = "held", value = 0.5 }"#);
    let mut c = parse(&text).compile().unwrap();
    let sim = c.simulation.as_mut();
    assert_eq!(sim.input_names(), ["motor"]);
    // A controller at 100 Hz: u = −k ω, set between communication points.
    let controller = |sim: &mut dyn lieflow::scene::Simulation, until: f64| {
        let mut states = vec![];
        let mut t = sim.time();
        while t < until - 1e-12 {
            let x = sim.state();
            let omega = x[0] * x[3] - x[1] * x[2]; // (q × p)/m with m = 1, |q| = 1
            sim.set_input("motor", -2.0 * omega).unwrap();
            t += 0.01;
            sim.advance_to(t).unwrap();
            assert_eq!(sim.time(), t);
            states.push(sim.state().to_vec());
        }
        states
    };
    controller(sim, 0.5);
    let saved_at = sim.time();
    let checkpoint = sim.save();
    let first = controller(sim, 1.0);
    sim.restore(&checkpoint).unwrap();
    assert_eq!(sim.time(), saved_at);
    let again = controller(sim, 1.0);
    assert!(first == again, "the restored run differs");
    // Into a freshly compiled simulation of the same scene.
    let mut other = parse(&text).compile().unwrap();
    other.simulation.restore(&checkpoint).unwrap();
    assert!(controller(other.simulation.as_mut(), 1.0) == first);
    // Not into another scene of the same state size (a pendulum on a spring instead of a rod):
    // refused at restore, naming both, instead of a failed step later.
    let spring = text.replace(
        "[[constraints]]\ntype = \"rod\"\nbodies = [\"bob\"]\npoint = [0.0, 0.0]\n",
        "[[effects]]\ntype = \"spring\"\nbodies = [\"bob\"]\npoint = [0.0, 0.0]\nstiffness = 50.0\n",
    );
    assert_ne!(spring, text);
    let mut foreign = parse(&spring).compile().unwrap();
    assert_eq!(foreign.simulation.state().len(), sim.state().len());
    let e = foreign.simulation.restore(&checkpoint).unwrap_err();
    assert!(
        e.contains("saved from scene") && e.contains("not from this"),
        "{e}"
    );
    // Nor into the same scene under another scheme.
    let mut pg = parse(&text.replace("[integrator]", "[integrator]\nscheme = \"petrov-galerkin\""))
        .compile()
        .unwrap();
    assert!(pg.simulation.restore(&checkpoint).is_err());
    // The controller removes energy: the motor's supplied energy is negative.
    assert!(sim.supplied().unwrap() < 0.0);
    assert!(
        sim.set_input("nope", 1.0)
            .unwrap_err()
            .contains("no input 'nope'")
    );
}

#[test]
fn a_signal_of_time_is_not_set_by_the_embedder() {
    let mut c = parse(&driven(1e-3, 1.0, 0.1, SINE)).compile().unwrap();
    let e = c.simulation.set_input("motor", 1.0).unwrap_err();
    assert!(e.contains("only `held` inputs"), "{e}");
    assert_eq!(c.simulation.input("motor"), Some(0.0));
}

#[test]
fn an_impulse_is_reprojected_by_the_simulation() {
    let mut c = parse(&driven(1e-3, 1.0, 0.1, SINE)).compile().unwrap();
    let sim = c.simulation.as_mut();
    sim.advance_to(0.1).unwrap();
    let mut x = sim.state().to_vec();
    // Push the bob along the rod (and a little across it).
    x[2] += 0.6;
    x[3] += -0.8 + 0.1;
    let report = sim.set_state(&x, true).unwrap().unwrap();
    assert!(report.phi_before > 0.5 && report.phi_after < 1e-14);
    sim.step().unwrap();
    let mut y = sim.state().to_vec();
    y[0] *= 1.1;
    assert!(sim.set_state(&y, false).unwrap().is_none());
    assert!(
        sim.step().is_err(),
        "an off-manifold state is refused without reprojection"
    );
}

#[test]
fn a_falling_body_stops_on_the_floor_at_the_closed_form_time() {
    let text = r#"
version = 1
dim = 2
[[bodies]]
name = "ball"
mass = 2.0
position = [0.0, 2.0]
velocity = [1.0, 3.0]
[[effects]]
type = "gravity"
g = [0.0, -9.81]
[[events]]
name = "floor"
body = "ball"
plane = { normal = [0.0, 1.0] }
direction = "falling"
action = "stop"
[[events]]
name = "apex"
quantity = "velocity"
body = "ball"
component = 1
direction = "falling"
[integrator]
dt = 0.01
t_end = 10.0
"#;
    let mut c = parse(text).compile().unwrap();
    let s = run(c.simulation.as_mut(), &c.plan, &mut |_| {});
    let landing = (3.0 + (9.0f64 + 2.0 * 9.81 * 2.0).sqrt()) / 9.81;
    assert_eq!(s.stopped_by.as_deref(), Some("floor"));
    assert_eq!(s.events.len(), 2);
    assert_eq!(s.events[0].name, "apex");
    assert!((s.events[0].t - 3.0 / 9.81).abs() < 1e-12, "{:?}", s.events);
    assert!((s.t - landing).abs() < 1e-12, "{} vs {landing}", s.t);
    assert!(s.x[1].abs() < 1e-12);
}

#[test]
fn bad_port_declarations_are_located_errors() {
    let cases: &[(&str, &str, &str, SceneErrorKind)] = &[
        (
            r#"{ type = "expression", expr = "2 * sine(t)" }"#,
            "inputs[0].signal.expr",
            "column 5",
            SceneErrorKind::Value,
        ),
        (
            r#"{ type = "table", points = [[0.0, 1.0], [0.0, 2.0]] }"#,
            "inputs[0].signal.points",
            "strictly increasing",
            SceneErrorKind::Value,
        ),
        (
            r#"{ type = "table", file = "/nonexistent/u.csv" }"#,
            "inputs[0].signal.file",
            "cannot read",
            SceneErrorKind::Io,
        ),
        (
            r#"{ type = "sine", amplitude = 1.0 }"#,
            "inputs[0].signal",
            "exactly one",
            SceneErrorKind::Value,
        ),
        (
            r#"{ type = "ramp", start = 2.0, end = 1.0, to = 1.0 }"#,
            "inputs[0].signal.end",
            "not after its start",
            SceneErrorKind::Value,
        ),
    ];
    for (signal, path, message, kind) in cases {
        let e = parse(&driven(1e-3, 1.0, 0.1, signal))
            .compile()
            .unwrap_err();
        assert_eq!(e.path.to_string(), *path, "{e}");
        assert!(e.to_string().contains(message), "{e}");
        assert_eq!(e.kind, *kind, "{e}");
    }
    let base = driven(1e-3, 1.0, 0.1, SINE);
    let edits: &[(&str, &str, &str, &str)] = &[
        (
            "input = \"motor\"\n[[outputs]]",
            "input = \"pump\"\n[[outputs]]",
            "outputs[0].input",
            "names no input",
        ),
        (
            "pivot = [0.0, 0.0]\nsignal",
            "pivot = [0.0, 0.0]\npivot_body = \"bob\"\nsignal",
            "inputs[0]",
            "exactly one",
        ),
        (
            "quantity = \"supplied\"",
            "quantity = \"multiplier\"\nconstraint = 3",
            "outputs[1].constraint",
            "1 rows",
        ),
    ];
    for (from, to, path, message) in edits {
        assert!(base.contains(from), "{from}");
        let e = parse(&base.replacen(from, to, 1)).compile().unwrap_err();
        assert_eq!(e.path.to_string(), *path, "{e}");
        assert!(e.to_string().contains(message), "{e}");
    }
    // A location in the file, as for every scene error.
    let text = base.replace("omega = 3.0", "omega = 3.0, phase = \"x\"");
    let e = Scene::from_toml(&text, "ports.toml").unwrap_err();
    assert!(e.to_string().contains("ports.toml:"), "{e}");
}

#[test]
fn a_parameter_changes_between_steps_and_the_run_goes_on_from_its_state() {
    use lieflow::scene::set_parameter;
    let mut scene = parse(&driven(
        1e-3,
        4.0,
        0.5,
        r#"{ type = "constant", value = 0.0 }"#,
    ));
    let mut c = scene.compile().unwrap();
    c.simulation.advance_to(1.0).unwrap();
    let (x, t) = (c.simulation.state().to_vec(), c.simulation.time());
    let dissipated = c.simulation.dissipated().unwrap();
    assert!(dissipated > 0.1);
    // The damper switched off (effects[1] is the damping) between two steps.
    set_parameter(&mut scene, &mut c, "effects[1].coefficient", 0.0).unwrap();
    assert_eq!(c.simulation.state(), x.as_slice());
    assert_eq!(c.simulation.time(), t);
    let h1 = c.simulation.energy();
    c.simulation.advance_to(3.0).unwrap();
    // No more dissipation; H conserved to Strang's O(h²) energy error.
    assert_eq!(c.simulation.dissipated().unwrap(), dissipated);
    assert!((c.simulation.energy() - h1).abs() < 1e-4);
    // A path that names nothing, and a change of structure, leave the run as it was.
    let e = set_parameter(&mut scene, &mut c, "effects[7].coefficient", 1.0).unwrap_err();
    assert!(e.to_string().contains("element [7]"), "{e}");
    let e = set_parameter(&mut scene, &mut c, "integrator.order", 4.0).unwrap_err();
    assert!(e.to_string().contains("order"), "{e}");
    assert_eq!(c.simulation.time(), 3.0);
    c.simulation.step().unwrap();
}

/// A cart on a rail (a plane constraint, row 0) carrying a pendulum (a rod, row 1).
/// `off` names the constraints switched off, as `lieflow run --off NAME` does.
fn cart_pole(outputs: &str, off: &[&str]) -> Scene {
    let mut scene = parse(&format!(
        r#"
version = 1
dim = 2
[[bodies]]
name = "cart"
mass = 2.0
position = [0.0, 0.0]
velocity = [0.5, 0.0]
[[bodies]]
name = "bob"
mass = 0.5
position = [0.6, -0.8]
velocity = [0.5, 0.0]
[[constraints]]
name = "rail"
type = "plane"
bodies = ["cart"]
normal = [0.0, 1.0]
[[constraints]]
name = "pole"
type = "rod"
bodies = ["cart", "bob"]
[[effects]]
type = "gravity"
g = [0.0, -9.81]
{outputs}
[integrator]
dt = 0.001
t_end = 0.5
"#
    ));
    scene.file.off = off.iter().map(|s| s.to_string()).collect();
    scene
}

#[test]
fn multiplier_outputs_name_constraints_and_keep_them_when_one_is_switched_off() {
    let outputs = r#"
[[outputs]]
quantity = "multiplier"
constraint = "pole"
[[outputs]]
quantity = "multiplier"
constraint = 1
"#;
    let last = |scene: Scene| {
        let mut c = scene.compile().unwrap_or_else(|e| panic!("{e}"));
        let mut out = vec![];
        let s = run(c.simulation.as_mut(), &c.plan, &mut |s| {
            out = s.outputs.to_vec()
        });
        assert!(s.error.is_none());
        (c.assembly.outputs.clone(), out)
    };
    let (names, on) = last(cart_pole(outputs, &[]));
    assert_eq!(names, ["lambda_pole", "lambda1"]);
    assert_eq!(on[0], on[1]);
    assert!(on[0] != 0.0 && on[0].is_finite());
    // The rail switched off: row 1 is still the pole's (the assembled model's row 0), by name
    // and by the declared row alike; before, `constraint = 1` fell off the end.
    let (_, off) = last(cart_pole(outputs, &["rail"]));
    assert_eq!(off[0], off[1]);
    assert!(off[0] != 0.0 && off[0].is_finite());
    // An output on the switched-off constraint is refused, naming it, by name or by row.
    for (sel, path) in [
        ("\"rail\"", "outputs[0].constraint"),
        ("0", "outputs[0].constraint"),
    ] {
        let scene = cart_pole(
            &format!("[[outputs]]\nquantity = \"multiplier\"\nconstraint = {sel}\n"),
            &["rail"],
        );
        let e = scene.compile().unwrap_err();
        assert_eq!(e.path.to_string(), path, "{e}");
        assert!(e.to_string().contains("switched off"), "{e}");
    }
    // A name that is not a constraint's, and a row past the declared ones.
    for (sel, message) in [
        ("\"cable\"", "no constraint is named 'cable'"),
        ("2", "declares 2 rows"),
    ] {
        let scene = cart_pole(
            &format!("[[outputs]]\nquantity = \"multiplier\"\nconstraint = {sel}\n"),
            &[],
        );
        let e = scene.compile().unwrap_err();
        assert!(e.to_string().contains(message), "{e}");
    }
}

#[test]
fn constraint_forces_are_newtons_with_their_documented_signs() {
    // Three bodies at rest under gravity: one hanging from a rod (tension m g, positive), one
    // on a floor (the floor pushes up along its normal, m g), one pinned (the pin's vertical
    // force component, m g); their multipliers are λ of each internal form.
    let text = r#"
version = 1
dim = 2
[[bodies]]
name = "bob"
mass = 2.0
position = [0.0, -1.5]
[[bodies]]
name = "block"
mass = 3.0
position = [5.0, 0.0]
[[bodies]]
name = "nail"
mass = 0.5
position = [-5.0, 1.0]
[[constraints]]
name = "rod"
type = "rod"
bodies = ["bob"]
point = [0.0, 0.0]
[[constraints]]
name = "floor"
type = "plane"
bodies = ["block"]
normal = [0.0, 1.0]
[[constraints]]
name = "pin"
type = "pin"
bodies = ["nail"]
[[effects]]
type = "gravity"
g = [0.0, -9.81]
[[outputs]]
quantity = "constraint-force"
constraint = "rod"
[[outputs]]
quantity = "constraint-force"
constraint = "floor"
[[outputs]]
quantity = "constraint-force"
constraint = "pin"
component = 1
[[outputs]]
quantity = "multiplier"
constraint = "rod"
[integrator]
dt = 0.01
t_end = 0.1
"#;
    let mut c = parse(text).compile().unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(
        c.assembly.outputs,
        ["force_rod", "force_floor", "force_pin_1", "lambda_rod"]
    );
    let mut out = vec![];
    let s = run(c.simulation.as_mut(), &c.plan, &mut |s| {
        out = s.outputs.to_vec()
    });
    assert!(s.error.is_none());
    let g = 9.81;
    // At rest the step's multipliers are the static ones, to rounding.
    for (value, expected) in [(out[0], 2.0 * g), (out[1], 3.0 * g), (out[2], 0.5 * g)] {
        assert!((value - expected).abs() <= 1e-12 * expected, "{out:?}");
    }
    // g = (|d|² − L²)/2 for the rod: |∇g| = L = 1.5, so λ = T / L.
    assert!((out[3] - 2.0 * g / 1.5).abs() <= 1e-12, "{out:?}");
    // An event cannot watch a constraint force (it is not a function of the state).
    let e = parse(&text.replace(
        "[integrator]",
        "[[events]]\nname = \"slack\"\nquantity = \"constraint-force\"\n[integrator]",
    ))
    .compile()
    .unwrap_err();
    assert!(e.to_string().contains("not multipliers"), "{e}");
}

#[test]
fn an_input_too_large_for_a_finite_energy_is_named() {
    // A held torque of 1e308: finite, but its impulse over a step (1e305) squares beyond the
    // largest f64. The step fails as a Newton or NonFinite failure of the state; the summary
    // names the input instead of advising a smaller step.
    let mut c = parse(&driven(1e-3, 0.1, 0.1, r#"{ type = "held", value = 0.0 }"#))
        .compile()
        .unwrap();
    c.simulation.set_input("motor", 1e308).unwrap();
    let s = run(c.simulation.as_mut(), &c.plan, &mut |_| {});
    let e = s.error.expect("the run fails");
    assert_eq!(e.kind, "NonFiniteInput", "{e:?}");
    assert!(e.message.contains("input 'motor' = 1e308"), "{e:?}");
    assert!(e.advice.unwrap().contains("does not help"));
}
