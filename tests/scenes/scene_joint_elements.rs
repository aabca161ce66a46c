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
