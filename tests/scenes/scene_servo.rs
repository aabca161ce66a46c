//! A position servo on a hinge (`hinge-servo`): a disc (`J = 0.005`) driven to a reference of
//! 0.5 rad with `k_p = 2`, `k_d = 0.02` moves as `J θ'' = k_p (θ_r − θ) − k_d θ'` —
//! `θ = θ_r (1 − e^{−ζΩt}(cos ω_d t + (ζΩ/ω_d) sin ω_d t))`, `Ω = √(k_p/J) = 20`, `ζ = 0.1` — at
//! the splitting's order, and its books close: the energy's change is the servo's work (booked
//! as supplied) less what its damper took.

use crate::common::fitted_order;
use lieflow::scene::{Scene, run};

fn servo(dt: f64, t_end: f64, scheme: &str) -> String {
    format!(
        r#"
version = 1
dim = 3
[[bodies]]
name = "disc"
mass = 1.0
inertia = {{ shape = "cylinder", radius = 0.1, height = 0.02 }}
position = [0, 0, 0]
[[constraints]]
type = "hinge"
name = "axle"
bodies = ["disc"]
anchor = [0, 0, 0]
axis = [0, 0, 1]
[[inputs]]
type = "hinge-servo"
name = "servo"
bodies = ["disc"]
axis = [0, 0, 1]
stiffness = 2.0
damping = 0.02
signal = {{ type = "constant", value = 0.5 }}
[[outputs]]
quantity = "joint-position"
constraint = "axle"
[integrator]
dt = {dt}
t_end = {t_end}
{scheme}
"#
    )
}

#[test]
fn a_hinge_servo_moves_the_disc_to_its_reference_as_a_damped_oscillator() {
    let (j, kp, kd, theta_r, t_end) = (0.005f64, 2.0f64, 0.02f64, 0.5f64, 0.5f64);
    let w0 = (kp / j).sqrt();
    let zeta = kd / (2.0 * j * w0);
    let wd = w0 * (1.0 - zeta * zeta).sqrt();
    let want = theta_r
        * (1.0
            - (-zeta * w0 * t_end).exp()
                * ((wd * t_end).cos() + zeta * w0 / wd * (wd * t_end).sin()));
    for (scheme, order) in [("", 2.0), ("scheme = \"extrapolation\"\norder = 4", 4.0)] {
        let hs = [0.01, 0.005, 0.0025, 0.00125];
        let (mut errs, mut budgets) = (Vec::new(), Vec::new());
        for &h in &hs {
            let mut c = Scene::from_toml(&servo(h, t_end, scheme), "servo.toml")
                .unwrap()
                .compile()
                .unwrap_or_else(|e| panic!("{e}"));
            let kinds: Vec<&str> = c.assembly.effects.iter().map(|e| e.1.as_str()).collect();
            assert_eq!(kinds, ["kinetic", "torsion-spring", "hinge-damper"]);
            let mut out = Vec::new();
            let s = run(c.simulation.as_mut(), &c.plan, &mut |s| {
                out = s.outputs.to_vec()
            });
            assert!(s.error.is_none(), "{scheme}: {:?}", s.error);
            assert!(s.supplied.unwrap() > 0.0 && s.dissipated.unwrap() > 0.0);
            errs.push((out[0] - want).abs());
            budgets.push(s.max_energy_balance_error.unwrap());
        }
        let p = fitted_order(&hs, &errs, 1e-12);
        eprintln!("servo '{scheme}': errors {errs:?}, order {p:.3}; budget errors {budgets:?}");
        assert!(
            (p - order).abs() < 0.3,
            "'{scheme}': order {p}, want {order}"
        );
        // The energy account closes to the scheme's error: at order 2 it falls as h².
        let pb = fitted_order(&hs, &budgets, 1e-15);
        assert!(pb > 1.7, "budget order {pb}");
    }
}
