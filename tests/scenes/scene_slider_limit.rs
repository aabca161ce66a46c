//! A slider's stops as one-sided springs (`slider-limit`) against the closed form of their
//! contact law: a box sliding at `v₀` meets a stop, overshoots it by `v₀ √(m/k)`, turns back a
//! quarter of the stop's period `2π √(m/k)` after meeting it and leaves at `−v₀`.

use lieflow::scene::{Scene, run};

/// A box (1 kg) on a slider to the world along x, sliding at `v₀ = 0.5` m/s, stops at ±0.1 m of
/// stiffness `k = 100` N/m (`√(m/k) = 0.1` s); no gravity.
fn sliding(limit: &str) -> String {
    format!(
        r#"
version = 1
dim = 3
[[bodies]]
name = "box"
mass = 1.0
inertia = {{ shape = "box", size = [0.2, 0.1, 0.1] }}
position = [0, 0, 0]
velocity = [0.5, 0, 0]
[[constraints]]
type = "slider"
name = "rail"
bodies = ["box"]
axis = [1, 0, 0]
[[effects]]
type = "slider-limit"
bodies = ["box"]
axis = [1, 0, 0]
{limit}
[[outputs]]
quantity = "joint-position"
constraint = "rail"
[[outputs]]
quantity = "joint-velocity"
constraint = "rail"
[integrator]
dt = 1e-3
t_end = 1.0
"#
    )
}

#[test]
fn a_box_bounces_off_its_slider_stop_as_the_contact_law_says() {
    let (m, k, v0, stop) = (1.0f64, 100.0f64, 0.5f64, 0.1f64);
    let tau = (m / k).sqrt();
    let mut c = Scene::from_toml(
        &sliding("stiffness = 100.0\nmin = -0.1\nmax = 0.1"),
        "s.toml",
    )
    .unwrap()
    .compile()
    .unwrap_or_else(|e| panic!("{e}"));
    let mut samples = Vec::new();
    let s = run(c.simulation.as_mut(), &c.plan, &mut |s| {
        samples.push((s.t, s.outputs[0], s.outputs[1]))
    });
    assert!(s.error.is_none(), "{:?}", s.error);
    assert!(
        s.max_abs_g.unwrap() < 64.0 * f64::EPSILON,
        "{:?}",
        s.max_abs_g
    );
    // ½ m v₀² = ½ k δ².
    let peak = samples.iter().map(|s| s.1).fold(f64::MIN, f64::max);
    eprintln!("peak {peak:.6} m, stop + overshoot {:.6}", stop + v0 * tau);
    assert!((peak - stop - v0 * tau).abs() < 0.01 * v0 * tau, "{peak}");
    // Turned back a quarter period after meeting the stop (to the sampling step).
    let turn = samples
        .windows(2)
        .find(|w| w[0].2 > 0.0 && w[1].2 <= 0.0)
        .map(|w| w[0].0 + (w[1].0 - w[0].0) * w[0].2 / (w[0].2 - w[1].2))
        .expect("it turns back");
    let want = stop / v0 + 0.5 * std::f64::consts::PI * tau;
    eprintln!("turns at {turn:.6} s (closed form {want:.6})");
    assert!((turn - want).abs() < 1e-3, "{turn} against {want}");
    // Between the stops again it slides back at −v₀, to the energy's error through the contact,
    // (hΩ)²/4 of what the stop held (Ω = √(k/m) = 10, h = 1e-3), the rate's half that.
    let back = samples
        .iter()
        .find(|s| s.0 >= want + 0.25)
        .expect("a sample after the bounce");
    let bound = 1.5 * 0.5 * (1e-3 / tau).powi(2) / 4.0 * v0;
    assert!((back.2 + v0).abs() <= bound, "{} against {bound:e}", back.2);
    assert!(back.1.abs() < stop, "between the stops: {}", back.1);
}

#[test]
fn impossible_slider_stops_are_refused_where_they_are_written() {
    for (limit, field, says) in [
        (
            "stiffness = 100.0\nmin = 0.2\nmax = 0.1",
            "max",
            "above the lower",
        ),
        ("stiffness = 100.0", "effects[0]", "needs a stop"),
        ("stiffness = -1.0\nmax = 0.1", "stiffness", "positive"),
    ] {
        let e = Scene::from_toml(&sliding(limit), "s.toml")
            .unwrap()
            .compile()
            .err()
            .unwrap_or_else(|| panic!("{limit}: accepted"));
        let shown = e.to_string();
        assert!(shown.contains(field) && shown.contains(says), "{shown}");
    }
}
