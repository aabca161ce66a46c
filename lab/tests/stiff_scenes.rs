//! Stiffness through scenes: damping with `c h / m` up to 1e6 and springs
//! with `k / m` up to 1e8. The exact damping flow makes any damping stable inside the projected
//! step (it only takes positive sub-steps; with gravity the two are one exact damped fall); stiff springs need an A-stable scheme (the implicit midpoint
//! rule, the discrete gradient), and the explicit splitting fails with a typed error or a
//! finite, reported state — never a panic.

use lieflow::scene::{Scene, run};
use lieflow_lab::stress::{damped_chain_scene, stiff_spring_among_pins_scene, stiff_spring_scene};

fn scene(text: &str) -> Scene {
    Scene::from_toml(text, "stiff.toml").unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn damping_up_to_c_h_over_m_1e6_stays_stable_and_dissipative() {
    for c in [1e2, 1e4, 1e6, 1e8] {
        for scheme in ["auto", "discrete-gradient"] {
            let s = run_to_end(&damped_chain_scene(c, scheme));
            assert_eq!(s.error, None, "c = {c:e}, {scheme}");
            assert!(s.x.iter().all(|v| v.is_finite()));
            // The discrete gradient's energy never increases from one step to the next (a few
            // ulps of |H| ≈ 20). The projection around the exact damped fall can only by the
            // kinetic energy of its first half-step impulse, less what the fall removes (the
            // fall is dissipative for H, the closing projection removes kinetic energy); held
            // to the bound of the splitting with gravity as a kick, N m (g h/2)²/2 = 3.6e-3.
            let bound = if scheme == "auto" {
                3.0 * (9.81f64 * 0.01 / 2.0).powi(2) / 2.0
            } else {
                1e-12
            };
            assert!(
                s.max_energy_increase.unwrap() <= bound,
                "c = {c:e}, {scheme}: {:?}",
                s.max_energy_increase
            );
            // Over the run the energy decreases, up to that slack: an overdamped chain barely
            // falls in 1 s (ΔV ~ m g² T / c).
            let slack = if scheme == "auto" { bound } else { 0.0 };
            assert!(s.energy_final.unwrap() <= s.energy_initial.unwrap() + slack);
            // Overdamped, the multipliers grow with c (a constraint force must move positions
            // against the damping): g is met to the rounding of that force, ~1e-13 at c = 1e4.
            assert!(
                s.max_abs_g.unwrap() < 1e-12,
                "c = {c:e}, {scheme}: {:?}",
                s.max_abs_g
            );
            // Overdamped: after 1 s the momenta are at most the terminal m g / c (times the
            // chain's geometry); the damped fall ends each step there (its half-step impulse
            // decays by e^{−c h/m}), with no closing kick to add m g h/2.
            let p_max = s.x[6..].iter().fold(0.0f64, |a, v| a.max(v.abs()));
            assert!(p_max < 100.0 / c, "c = {c:e}, {scheme}: |p| = {p_max:e}");
        }
    }
}

fn run_to_end(text: &str) -> lieflow::scene::RunSummary {
    let mut c = scene(text).compile().unwrap_or_else(|e| panic!("{e}"));
    run(c.simulation.as_mut(), &c.plan, &mut |_| {})
}

#[test]
fn stiff_springs_need_an_a_stable_scheme_and_the_explicit_one_fails_cleanly() {
    // The implicit midpoint rule and the discrete gradient (A-stable) conserve the energy to
    // their Newton tolerance up to ω h = 100 (k = 1e8); Störmer–Verlet only where ω h < 2
    // (k = 1e4: ω h = 1), up to its O(h²) oscillation.
    for k in [1e6, 1e8] {
        for scheme in ["midpoint", "discrete-gradient"] {
            let s = run_to_end(&stiff_spring_scene(k, scheme));
            assert_eq!(s.error, None, "k = {k:e}, {scheme}");
            let e0 = s.energy_initial.unwrap();
            assert!(
                s.max_abs_energy_error.unwrap() <= 1e-6 * e0,
                "k = {k:e}, {scheme}: energy error {:?} of {e0:e}",
                s.max_abs_energy_error
            );
        }
    }
    for scheme in ["midpoint", "discrete-gradient", "auto"] {
        let s = run_to_end(&stiff_spring_scene(1e4, scheme));
        assert_eq!(s.error, None, "{scheme}");
        let e0 = s.energy_initial.unwrap();
        let tol = if scheme == "auto" { 0.5 } else { 1e-6 };
        assert!(
            s.max_abs_energy_error.unwrap() <= tol * e0,
            "{scheme}: energy error {:?} of {e0:e}",
            s.max_abs_energy_error
        );
        assert!(s.max_abs_g.unwrap() < 1e-12);
    }
    // Störmer–Verlet inside the projection is stable only for ω h < 2: at k = 1e6 and 1e8
    // (ω h = 10, 100) it blows up, which the run reports — a typed error, or an energy far
    // above its start — with a finite last state, never a panic.
    for k in [1e6, 1e8] {
        let s = run_to_end(&stiff_spring_scene(k, "auto"));
        assert!(s.x.iter().all(|v| v.is_finite()));
        let blown =
            s.error.is_some() || s.max_abs_energy_error.unwrap() > s.energy_initial.unwrap();
        assert!(
            blown,
            "k = {k:e}: the explicit splitting should not pass for stable"
        );
    }
}

/// With more than four constraints the midpoint scheme solves the increment and `λ_k` as one
/// Newton system too (its general path), so `g` stays at the rounding of the positions and the
/// energy at the solve's tolerance up to `ω h = 100`. Nested solves (an implicit midpoint solve
/// inside every residual of `λ_k`) stalled on these scenes from `k = 1e6` on: `g` of a stiff
/// inner solution rounds at `ε |h| k |x|`, far above the multiplier solve's tolerance.
#[test]
fn stiff_springs_with_more_than_four_constraints() {
    for k in [1e4, 1e6, 1e8] {
        // The spring among three pinned bodies (8 constraints): the motion is radial, the
        // energy quadratic along it, so the midpoint rule conserves it to the solve's tolerance.
        let s = run_to_end(&stiff_spring_among_pins_scene(k, "midpoint"));
        assert_eq!(s.error, None, "k = {k:e}");
        let e0 = s.energy_initial.unwrap();
        assert!(
            s.max_abs_energy_error.unwrap() <= 1e-6 * e0,
            "k = {k:e}: energy error {:?} of {e0:e}",
            s.max_abs_energy_error
        );
        assert!(s.max_abs_g.unwrap() < 1e-12, "k = {k:e}: {:?}", s.max_abs_g);
    }
}
