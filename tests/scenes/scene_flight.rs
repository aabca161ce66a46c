//! A scene's free flight with uniform gravity joined to it: exact for any step (free fall,
//! damped fall, each side of the switch between the series and the closed form), its booked
//! dissipation equal to the energy lost, and its tangent map the derivative of the flow.

#![allow(clippy::needless_range_loop)] // Coordinates indexed across several arrays.

use faer::Col;
use lieflow::Flow;
use lieflow::scene::FreeFlight;

use crate::scene_text;

use scene_text::{parse, run_scene};

const EPS: f64 = f64::EPSILON;

/// One body of mass `m` falling under `g` with damping `c` from `(q0, v0)`, for `t_end` in steps
/// of `dt`.
fn fall(c: f64, dt: f64, t_end: f64) -> String {
    format!(
        r#"
        version = 1
        dim = 3
        [[bodies]]
        name = "stone"
        mass = 2.0
        position = [0.5, 1.0, -0.25]
        velocity = [1.0, 2.0, 3.0]
        [[effects]]
        type = "gravity"
        g = [0.3, -9.81, 1.0]
        [[effects]]
        type = "damping"
        coefficient = {c}
        [integrator]
        dt = {dt}
        t_end = {t_end}
        "#
    )
}

/// The closed form: `v(t) = e^{−γt} v₀ + φ g`, `q(t) = q₀ + φ v₀ + ψ g` with `γ = c/m`,
/// `φ = (1 − e^{−γt})/γ`, `ψ = (γt − 1 + e^{−γt})/γ²`; `φ = t`, `ψ = t²/2` at `γ = 0`.
fn closed_form(c: f64, t: f64) -> [f64; 6] {
    let (q0, v0, g) = ([0.5, 1.0, -0.25], [1.0, 2.0, 3.0], [0.3, -9.81, 1.0]);
    let gamma = c / 2.0;
    let (decay, phi, psi) = if gamma == 0.0 {
        (1.0, t, 0.5 * t * t)
    } else {
        let x = gamma * t;
        (
            (-x).exp(),
            -(-x).exp_m1() / gamma,
            (x + (-x).exp_m1()) / (gamma * gamma),
        )
    };
    let mut out = [0.0; 6];
    for k in 0..3 {
        out[k] = q0[k] + phi * v0[k] + psi * g[k];
        // The scene's state holds momenta p = m v.
        out[3 + k] = 2.0 * (decay * v0[k] + phi * g[k]);
    }
    out
}

/// Free fall and damped fall are reproduced by any step size to the round-off of the steps
/// taken: one step of 3.7 (`γt = 0.555`, the closed forms), 10 of 0.37 (`γt = 0.0555`, the
/// series) and 1000 of 3.7e-3; and the energy booked as dissipated is the energy lost.
#[test]
fn the_damped_fall_is_exact_for_any_step() {
    for c in [0.0, 0.3] {
        let want = closed_form(c, 3.7);
        let scale = want.iter().fold(1.0f64, |a, b| a.max(b.abs()));
        for (dt, steps) in [(3.7, 1.0), (0.37, 10.0), (3.7e-3, 1000.0)] {
            let scene = parse(&fall(c, dt, 3.7));
            let scheme = scene.compile().unwrap().assembly.scheme;
            assert_eq!(scheme, "free flight under gravity (exact)");
            let s = run_scene(&scene);
            assert_eq!(s.steps as f64, steps);
            // Each step rounds each coordinate at a few ε of its size.
            let tol = 16.0 * steps * EPS * scale;
            for k in 0..6 {
                let err = (s.x[k] - want[k]).abs();
                assert!(err <= tol, "c {c}, dt {dt}, x[{k}]: {err:e} > {tol:e}");
            }
            // H(x_n) − H(x_0) + D_n = 0 up to the rounding of H and of the summed D (without
            // damping the summary reports |H − H₀|).
            let h_scale = s
                .energy_initial
                .unwrap()
                .abs()
                .max(s.energy_final.unwrap().abs());
            let balance = s
                .max_energy_balance_error
                .or(s.max_abs_energy_error)
                .unwrap();
            assert!(
                balance <= 16.0 * steps * EPS * h_scale,
                "c {c}, dt {dt}: {balance:e}"
            );
            if c == 0.0 {
                assert!(s.dissipated.unwrap_or(0.0) == 0.0);
            } else {
                assert!(s.dissipated.unwrap() > 0.0);
            }
        }
    }
}

/// At `γt = 1e-12` the closed form of `ψ` would cancel to nothing; the series gives
/// `ψ = t²/2 − γ t³/6 + O(γ² t⁴)`.
#[test]
fn a_weakly_damped_fall_keeps_its_digits() {
    let (c, t) = (2e-12, 1.0);
    let s = run_scene(&parse(&fall(c, t, t)));
    let gamma = c / 2.0;
    let psi = 0.5 * t * t - gamma * t * t * t / 6.0;
    let phi = t - 0.5 * gamma * t * t;
    let want = 1.0 + phi * 2.0 + psi * -9.81;
    assert!(
        (s.x[1] - want).abs() <= 8.0 * EPS * 10.0,
        "{:e}",
        s.x[1] - want
    );
    // The energy the damping removed: ≈ γ m ∫|v|² = c ∫|v|², v ≈ v₀ + g s.
    let (v0, g) = ([1.0, 2.0, 3.0], [0.3, -9.81, 1.0]);
    let int_v2: f64 = (0..3)
        .map(|k| v0[k] * v0[k] * t + v0[k] * g[k] * t * t + g[k] * g[k] * t * t * t / 3.0)
        .sum();
    let d = s.dissipated.unwrap();
    assert!(
        (d - c * int_v2).abs() <= 1e-9 * c * int_v2,
        "{d:e} vs {:e}",
        c * int_v2
    );
}

/// Two bodies (a damped fall, a free fall): the flight's tangent map equals its derivative,
/// which for an affine flow the central difference gives to round-off; the same for a body
/// turning in a magnetic field (no gravity joined there).
#[test]
fn the_free_flight_tangent_is_its_derivative() {
    let falling = r#"
        version = 1
        dim = 3
        [[bodies]]
        name = "a"
        mass = 2.0
        position = [0.5, 1.0, -0.25]
        velocity = [1.0, 2.0, 3.0]
        [[bodies]]
        name = "b"
        mass = 0.5
        position = [0.0, 0.0, 0.0]
        velocity = [-1.0, 0.5, 0.0]
        [[effects]]
        type = "gravity"
        g = [0.0, -9.81, 0.0]
        [[effects]]
        type = "damping"
        coefficient = 0.7
        bodies = ["a"]
        [integrator]
        dt = 0.1
        t_end = 1.0
        "#;
    let turning = falling.replace(
        "type = \"gravity\"\n        g = [0.0, -9.81, 0.0]",
        "type = \"magnetic\"\n        field = [0.2, 0.1, 1.3]",
    );
    let turning = turning.replace("mass = 2.0", "mass = 2.0\n        charge = 1.5");
    for text in [falling.to_owned(), turning] {
        let compiled = parse(&text).compile().unwrap_or_else(|e| panic!("{e}"));
        let model = compiled.model.expect("a scene model");
        let mut flow = FreeFlight::new(model);
        let x = Col::<f64>::from_fn(12, |i| 0.3 + 0.1 * i as f64);
        let v = Col::<f64>::from_fn(12, |i| ((i * 7 % 5) as f64) - 2.0);
        let mut out = Col::<f64>::zeros(12);
        assert!(
            !Flow::<Col<f64>>::tangent_apply(&mut flow, &v, &mut out),
            "no tangent before a step"
        );
        let h = 0.25;
        let mut y = x.clone();
        flow.step(h, &mut y).unwrap();
        assert!(flow.tangent_apply(&v, &mut out));
        let delta = 1e-2;
        let (mut plus, mut minus) = (x.clone(), x.clone());
        for i in 0..12 {
            plus[i] += delta * v[i];
            minus[i] -= delta * v[i];
        }
        flow.step(h, &mut plus).unwrap();
        flow.step(h, &mut minus).unwrap();
        for i in 0..12 {
            let fd = (plus[i] - minus[i]) / (2.0 * delta);
            // Affine flow: no truncation error, the difference rounds at ~4 ε |Φ| / δ.
            assert!((fd - out[i]).abs() <= 1e-11, "{i}: {fd} vs {}", out[i]);
        }
    }
}

/// The kick with its gradient kept for the last positions gives, bit for bit, the kick of the
/// positions it is called at: reused when only momenta changed (a projection's half-steps),
/// recomputed when positions moved.
#[test]
fn the_kept_kick_gradient_is_the_gradient_at_the_positions() {
    let compiled = parse(include_str!("../../scenes/shell_damped.toml"))
        .compile()
        .unwrap_or_else(|e| panic!("{e}"));
    let model = compiled.model.expect("a scene model");
    let n = model.state_len();
    let mut cache = lieflow::scene::KickCache::default();
    let mut scratch = vec![0.0; n / 2];
    let base: Vec<f64> = (0..n).map(|i| (0.37 * i as f64).sin()).collect();
    let mut momenta_moved = base.clone();
    momenta_moved[n - 1] += 0.25;
    let mut positions_moved = momenta_moved.clone();
    positions_moved[0] += 1e-3;
    for x0 in [&base, &momenta_moved, &positions_moved, &base] {
        let (mut kept, mut fresh) = (x0.clone(), x0.clone());
        model.kick_cached(0.1, &mut kept, &mut cache);
        model.kick(0.1, &mut fresh, &mut scratch);
        assert_eq!(kept, fresh);
    }
}
