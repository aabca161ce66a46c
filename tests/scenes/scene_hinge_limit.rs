//! A hinge's stops as one-sided springs (`hinge-limit`) against the closed form of the contact
//! they state: a disc turning at `ω₀` meets a stop, overshoots it by `ω₀ √(J/k)`, turns back
//! after a quarter of the stop's period `2π √(J/k)` and leaves at `−ω₀` (restitution 1), the
//! energy it lent the stop returned; the bounces repeat at the period `2 (θ_max − θ_min)/ω₀ +
//! 2π √(J/k)`. Bad stops are refused where they are written.

use lieflow::scene::{Scene, run};

/// A disc (1 kg, r = 0.1, height 0.02: `J = m r²/2 = 0.005`) on a hinge about `z` through its
/// centre, turning at `ω₀ = 2`, stops at ±30° of stiffness `k = 50` (`√(J/k) = 0.01` s); no
/// gravity.
fn disc(limit: &str) -> String {
    format!(
        r#"
version = 1
dim = 3
[[bodies]]
name = "disc"
mass = 1.0
inertia = {{ shape = "cylinder", radius = 0.1, height = 0.02 }}
position = [0, 0, 0]
angular_velocity = [0, 0, 2]
[[constraints]]
type = "hinge"
bodies = ["disc"]
anchor = [0, 0, 0]
axis = [0, 0, 1]
[[effects]]
type = "hinge-limit"
bodies = ["disc"]
axis = [0, 0, 1]
{limit}
[[outputs]]
quantity = "angular-velocity"
body = "disc"
component = 2
[[outputs]]
quantity = "orientation"
body = "disc"
component = 3
[integrator]
dt = 1e-4
t_end = 1.0
"#
    )
}

/// The first time after `after` that the rate changes sign (linear interpolation).
fn zero_crossing(samples: &[(f64, f64, f64)], after: f64) -> f64 {
    samples
        .windows(2)
        .find(|w| w[0].0 >= after && w[0].1.signum() != w[1].1.signum())
        .map(|w| w[0].0 + (w[1].0 - w[0].0) * w[0].1 / (w[0].1 - w[1].1))
        .expect("the rate changes sign")
}

#[test]
fn a_disc_bounces_between_its_stops_as_the_contact_law_says() {
    let (j, k, w0, stop) = (0.005f64, 50.0f64, 2.0f64, 30f64.to_radians());
    let tau = (j / k).sqrt();
    let text = disc("stiffness = 50.0\nmin_deg = -30.0\nmax_deg = 30.0");
    let mut c = Scene::from_toml(&text, "limit.toml")
        .unwrap()
        .compile()
        .unwrap_or_else(|e| panic!("{e}"));
    // (t, θ', θ) at every step; the quaternion of a turn by θ about z is (cos θ/2, 0, 0, sin θ/2).
    let mut samples = Vec::new();
    let s = run(c.simulation.as_mut(), &c.plan, &mut |s| {
        samples.push((s.t, s.outputs[0], 2.0 * s.outputs[1].asin()))
    });
    assert!(s.error.is_none(), "{:?}", s.error);
    assert!(
        s.max_abs_g.unwrap() < 64.0 * f64::EPSILON,
        "{:?}",
        s.max_abs_g
    );
    // The overshoot: the stop's spring takes the kinetic energy, ½ J ω₀² = ½ k δ².
    let peak = samples.iter().map(|s| s.2).fold(f64::MIN, f64::max);
    let overshoot = w0 * tau;
    eprintln!(
        "peak {peak:.6} rad, stop + overshoot {:.6}",
        stop + overshoot
    );
    assert!((peak - stop - overshoot).abs() < 0.01 * overshoot, "{peak}");
    // Turned back a quarter of the stop's period after meeting it; back again half a bounce
    // period later (the travel between the stops plus half a period in each).
    let first = zero_crossing(&samples, 0.0);
    let want = stop / w0 + 0.5 * std::f64::consts::PI * tau;
    let second = zero_crossing(&samples, first + 0.01);
    let half_period = 2.0 * stop / w0 + std::f64::consts::PI * tau;
    eprintln!(
        "turns at {first:.6} (closed form {want:.6}), {second:.6} ({:.6})",
        want + half_period
    );
    // The crossings to the step (interpolated within one), the contact's phase error far below.
    assert!((first - want).abs() < 1e-4, "{first} against {want}");
    assert!((second - want - half_period).abs() < 1e-4, "{second}");
    // The energy through two contacts: Störmer–Verlet on the stop's oscillator conserves
    // ½p² + ½Ω²q²(1 − (hΩ)²/4), so H strays from it by up to (hΩ)²/4 of the energy held in
    // the stop (Ω = 1/√(J/k) = 100, h = 1e-4), with half again for the steps that straddle a
    // stop.
    let e0 = 0.5 * j * w0 * w0;
    let bound = (1e-4 / tau).powi(2) / 4.0;
    let worst = s.max_abs_energy_error.unwrap();
    eprintln!("energy {e0}, largest error {worst:e}");
    assert!(worst <= 1.5 * bound * e0, "{worst:e}");
    // Between the stops it turns at −ω₀: the stop gave back what it took, to the energy's
    // error (the rate's relative error half the energy's).
    let between = samples
        .iter()
        .find(|s| s.0 >= first + 0.25)
        .expect("a sample between the stops");
    assert!(
        (between.1 + w0).abs() <= 1.5 * 0.5 * bound * w0,
        "{}",
        between.1
    );
}

#[test]
fn impossible_stops_are_refused_where_they_are_written() {
    for (limit, field, says) in [
        (
            "stiffness = 50.0\nmin_deg = 20.0\nmax_deg = 10.0",
            "max_deg",
            "above the lower",
        ),
        (
            "stiffness = 50.0\nmax_deg = 190.0",
            "max_deg",
            "(-180, 180)",
        ),
        ("stiffness = 50.0", "effects[0]", "needs a stop"),
        ("stiffness = 0.0\nmax_deg = 10.0", "stiffness", "positive"),
    ] {
        let err = Scene::from_toml(&disc(limit), "limit.toml")
            .unwrap()
            .compile()
            .err()
            .unwrap_or_else(|| panic!("{limit}: accepted"));
        let text = err.to_string();
        assert!(
            text.contains(field) && text.contains(says),
            "{limit}: {text}"
        );
    }
}
