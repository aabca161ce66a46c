//! A spring along a slider's axis (`slider-spring`): two boxes on a slider along a tilted axis,
//! the spring between them, oscillate along it as two masses on a spring — at the reduced
//! mass's frequency, at each scheme's order. The displacement is quadratic in the slots (the
//! gap between the anchors times the axis the first body carries), so its gradient reaches the
//! directors: were those terms wrong the bodies would be twisted and the rows would fight it.

use crate::common::fitted_order;
use crate::scene_text::boxes_on_a_slider;
use lieflow::scene::{Scene, run};

/// Boxes of 1 and 2 kg, the second 0.5 m along `u = (1, 1, 0)/√2` from the first, a slider
/// between them along `u`, a spring `k = 3` at rest where they start; the second moves away
/// at 0.3 m/s. The gap along `u` is `d(t) = (0.3/ω) sin ωt`, `ω = √(k/μ)`, `μ = 2/3`.
fn pair(dt: f64, t_end: f64, scheme: &str) -> String {
    boxes_on_a_slider(
        0.3,
        r#"[[effects]]
type = "slider-spring"
bodies = ["a", "b"]
axis = [1, 1, 0]
stiffness = 3.0
[[outputs]]
quantity = "position"
body = "b"
component = 0
[[outputs]]
quantity = "position"
body = "b"
component = 1
[[outputs]]
quantity = "position"
body = "a"
component = 0
[[outputs]]
quantity = "position"
body = "a"
component = 1"#,
        dt,
        t_end,
        scheme,
    )
}

#[test]
fn two_boxes_on_a_sprung_slider_oscillate_as_two_masses_on_a_spring() {
    let t_end = 1.0;
    let w = (3.0f64 / (2.0 / 3.0)).sqrt();
    let want = 0.3 / w * (w * t_end).sin();
    let u = std::f64::consts::FRAC_1_SQRT_2;
    for (scheme, order) in [
        ("", 2.0),
        ("order = 4", 4.0),
        ("scheme = \"midpoint\"", 2.0),
    ] {
        let hs = [0.04, 0.02, 0.01, 0.005];
        let mut errs = Vec::new();
        for &h in &hs {
            let text = pair(h, t_end, scheme);
            let mut c = Scene::from_toml(&text, "slider.toml")
                .unwrap()
                .compile()
                .unwrap_or_else(|e| panic!("{e}"));
            let mut out = Vec::new();
            let s = run(c.simulation.as_mut(), &c.plan, &mut |s| {
                out = s.outputs.to_vec()
            });
            assert!(s.error.is_none(), "{scheme}: {:?}", s.error);
            let rows = if scheme.contains("midpoint") {
                1e-13
            } else {
                64.0 * f64::EPSILON
            };
            assert!(s.max_abs_g.unwrap() < rows, "{scheme}: {:?}", s.max_abs_g);
            let gap = u * ((out[0] - out[2]) + (out[1] - out[3])) - 0.5;
            errs.push((gap - want).abs());
        }
        let p = fitted_order(&hs, &errs, 1e-12);
        eprintln!("sprung slider, '{scheme}': errors {errs:?}, order {p:.3}");
        assert!(
            (p - order).abs() < 0.3,
            "'{scheme}': order {p}, want {order}"
        );
    }
}

/// The sprung pair with a damper on the slider, `c = 0.2` N s/m: the gap obeys
/// `μ d'' = −k d − c d'` (ζ = c/(2√(kμ)) ≈ 0.07), from `d = 0`, `d' = −0.3` (the first body from
/// the second): `d = −(0.3/ω_d) e^{−ζωt} sin ω_d t`. Strang at order 2 and extrapolation at
/// order 4 (every sub-step forward); the energy never rises, and the ledger's dissipation closes
/// the energy budget to the scheme's order. Along `∇d` itself — which turns the first body's
/// axis, a direction the slider forbids — the step would drop to order 1.
#[test]
fn a_slider_damper_rings_down_as_its_closed_form_and_books_what_it_takes() {
    let (k, mu, c, t_end) = (3.0f64, 2.0 / 3.0, 0.2, 2.0);
    let w0 = (k / mu).sqrt();
    let zeta = c / (2.0 * (k * mu).sqrt());
    let wd = w0 * (1.0 - zeta * zeta).sqrt();
    let want = -0.3 / wd * (-zeta * w0 * t_end).exp() * (wd * t_end).sin();
    let damper = format!(
        "[[effects]]\ntype = \"slider-damper\"\nbodies = [\"a\", \"b\"]\naxis = [1, 1, 0]\ncoefficient = {c}\n[[constraints]]\ntype = \"slider\"\nname = \"rail\"\nbodies = [\"a\", \"b\"]\naxis = [1, 1, 0]\n[[outputs]]\nquantity = \"joint-position\"\nconstraint = \"rail\"\n"
    );
    for (scheme, order) in [("", 2.0), ("scheme = \"extrapolation\"\norder = 4", 4.0)] {
        let hs = [0.04, 0.02, 0.01, 0.005];
        let (mut errs, mut budgets) = (Vec::new(), Vec::new());
        for &h in &hs {
            // The pair's own slider is replaced by the named one (the same rows).
            let text = pair(h, t_end, scheme).replacen(
                "[[constraints]]\ntype = \"slider\"\nbodies = [\"a\", \"b\"]\naxis = [1, 1, 0]\n",
                &damper,
                1,
            );
            let mut sim = Scene::from_toml(&text, "damped_slider.toml")
                .unwrap()
                .compile()
                .unwrap_or_else(|e| panic!("{e}"));
            let kinds: Vec<&str> = sim.assembly.effects.iter().map(|e| e.1.as_str()).collect();
            assert_eq!(kinds, ["kinetic", "slider-spring", "slider-damper"]);
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
            assert!(s.max_abs_g.unwrap() <= 64.0 * f64::EPSILON);
            errs.push((out[0] - want).abs()); // the joint-position, declared first
            budgets.push(s.max_energy_balance_error.unwrap());
        }
        let p = fitted_order(&hs, &errs, 1e-12);
        eprintln!(
            "damped slider, '{scheme}': errors {errs:?}, order {p:.3}; budget errors {budgets:?}"
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
