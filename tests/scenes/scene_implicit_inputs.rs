//! Scene inputs under the implicit schemes: Petrov–Galerkin, the discrete gradient and the
//! midpoint rule take `B u` in their residuals at their orders, the energy-consistent ones with
//! budgets exact to round-off, on a driven pendulum and on a six-link chain (more constraints
//! than the midpoint rule's small path).

use crate::scene_ports::{SINE, driven, parse};
use lieflow::scene::run;

#[test]
fn the_implicit_schemes_are_driven_by_the_inputs_and_book_their_work() {
    // The implicit schemes take the inputs in their residuals: each run agrees with an order-8
    // extrapolated splitting to its own error (order 4 for Petrov–Galerkin, 2 for the discrete
    // gradient and the midpoint rule), and the budgets of the energy-consistent ones close to
    // the Newton tolerance (a scheme that ignored the torque ends ~0.1 away, `supplied 0`).
    let with = |scheme: &str, dt: f64, signal: &str| {
        let text = driven(dt, 5.0, 0.3, signal)
            .replace("[integrator]", &format!("[integrator]\n{scheme}"));
        let mut c = parse(&text).compile().unwrap_or_else(|e| panic!("{e}"));
        let s = run(c.simulation.as_mut(), &c.plan, &mut |_| {});
        assert!(s.error.is_none(), "{scheme}: {:?}", s.error);
        s
    };
    let reference = with("scheme = \"extrapolation\"\norder = 8", 1e-3, SINE);
    let distance = |a: &[f64], b: &[f64]| {
        a.iter()
            .zip(b)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max)
    };
    // (scheme, its error bound at dt = 0.01: C h^p with C from the pendulum's scales, and
    // whether its energy account is exact).
    for (scheme, bound, exact) in [
        ("scheme = \"petrov-galerkin\"\norder = 4", 1e-6, true),
        ("scheme = \"discrete-gradient\"", 1e-2, true),
        ("scheme = \"midpoint\"", 1e-2, false),
    ] {
        let s = with(scheme, 1e-2, SINE);
        let unforced = with(scheme, 1e-2, r#"{ type = "constant", value = 0.0 }"#);
        let err = distance(&s.x, &reference.x);
        let supplied = s.supplied.unwrap();
        eprintln!(
            "{scheme:?} at dt = 0.01 against the reference: {err:e}; balance error {:e}, supplied {supplied} (reference {})",
            s.max_energy_balance_error.unwrap(),
            reference.supplied.unwrap()
        );
        assert!(err < bound, "{scheme}: {err:e}");
        assert!(distance(&unforced.x, &reference.x) > 1e-2, "{scheme}");
        assert!((supplied - reference.supplied.unwrap()).abs() < 100.0 * bound);
        if exact {
            // |H| ≈ 8 and a few hundred steps: the rounding of the sum of the steps' balances.
            assert!(s.max_energy_balance_error.unwrap() < 1e-11, "{scheme}");
        }
        assert!(s.max_abs_g.unwrap() < 1e-14, "{scheme}");
    }
    // Halving the step divides the order-2 schemes' errors by about four.
    for scheme in ["scheme = \"discrete-gradient\"", "scheme = \"midpoint\""] {
        let (coarse, fine) = (
            distance(&with(scheme, 1e-2, SINE).x, &reference.x),
            distance(&with(scheme, 5e-3, SINE).x, &reference.x),
        );
        let p = (coarse / fine).log2();
        eprintln!("{scheme:?}: {coarse:e} at 0.01, {fine:e} at 0.005, order {p:.3}");
        assert!((p - 2.0).abs() < 0.3, "{scheme}: {p}");
    }
}

#[test]
fn a_forced_chain_of_six_links_runs_under_the_implicit_schemes() {
    // Six rods: more constraints than the midpoint rule's small path (four), so its joint
    // solve runs on the positions and multipliers with the momenta eliminated; a horizontal
    // force on the last bob. The implicit schemes agree with an order-8 splitting to their
    // order-2 error and keep the rods at round-off.
    let mut text = String::from("version = 1\ndim = 2\n");
    for i in 0..6 {
        text += &format!(
            "[[bodies]]\nname = \"b{i}\"\nmass = 1.0\nposition = [{}, 0.0]\n",
            0.5 * (i + 1) as f64
        );
    }
    text += "[[constraints]]\ntype = \"rod\"\nbodies = [\"b0\"]\npoint = [0.0, 0.0]\n";
    for i in 1..6 {
        text += &format!(
            "[[constraints]]\ntype = \"rod\"\nbodies = [\"b{}\", \"b{i}\"]\n",
            i - 1
        );
    }
    text += r#"
[[effects]]
type = "gravity"
g = [0.0, -9.81]
[[inputs]]
type = "force"
name = "push"
bodies = ["b5"]
direction = [1.0, 0.0]
signal = { type = "sine", amplitude = 3.0, omega = 2.0 }
[integrator]
dt = DT
t_end = 1.0
"#;
    let with = |scheme: &str, dt: f64| {
        let text = text
            .replace("DT", &dt.to_string())
            .replace("[integrator]", &format!("[integrator]\n{scheme}"));
        let mut c = parse(&text).compile().unwrap_or_else(|e| panic!("{e}"));
        let s = run(c.simulation.as_mut(), &c.plan, &mut |_| {});
        assert!(s.error.is_none(), "{scheme}: {:?}", s.error);
        s
    };
    let reference = with("scheme = \"extrapolation\"\norder = 8", 1e-3);
    for scheme in ["scheme = \"midpoint\"", "scheme = \"discrete-gradient\""] {
        let errs: Vec<f64> = [2e-3, 1e-3]
            .iter()
            .map(|&dt| {
                let s = with(scheme, dt);
                assert!(
                    s.max_abs_g.unwrap() < 1e-13,
                    "{scheme}: {:e}",
                    s.max_abs_g.unwrap()
                );
                assert!(
                    s.supplied.unwrap().abs() > 0.1,
                    "{scheme}: the force did work"
                );
                s.x.iter()
                    .zip(&reference.x)
                    .map(|(a, b)| (a - b).abs())
                    .fold(0.0, f64::max)
            })
            .collect();
        let p = (errs[0] / errs[1]).log2();
        eprintln!("six-link chain, {scheme:?}: errors {errs:?}, order {p:.3}");
        assert!((p - 2.0).abs() < 0.3, "{scheme}: {p}");
    }
}
