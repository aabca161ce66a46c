//! The controllers a scene's tolerance can choose besides the adaptive extrapolation: step
//! doubling of a named fixed-order scheme (the Petrov–Galerkin scheme's error follows the
//! tolerance at its order, its energy balance exact) and reversible steps along a density
//! (Kepler at e = 0.9 over 100 orbits without energy drift, far below a fixed step of the same
//! work); and what they cannot go with, refused where it is written.

use crate::common::log_slope as slope;
use crate::scene_text::{damped_pendulum as pendulum, parse, run_scene};
use lieflow::scene::SceneErrorKind;

#[test]
fn a_named_scheme_under_a_tolerance_keeps_its_order_and_its_energy_balance() {
    // The Petrov–Galerkin scheme of order 2 reporting every 0.5 s over 10 s, its steps chosen
    // by step doubling; the reference is the fixed extrapolation of order 12 at dt = 2e-3.
    // The error per unit step is controlled, so the error follows the tolerance (slope 1)
    // within the span's factor; every step is a step of the scheme, so its discrete energy
    // balance holds to round-off and no dissipation is negative.
    let reference = run_scene(&parse(&pendulum(2e-3, "order = 12")));
    let tols = [1e-4, 1e-6, 1e-8];
    let mut errs = Vec::new();
    for &tol in &tols {
        let s = run_scene(&parse(&pendulum(
            0.5,
            &format!("scheme = \"petrov-galerkin\"\norder = 2\ntol = {tol}"),
        )));
        assert!(s.error.is_none(), "{:?}", s.error);
        let a = s.adaptive.as_ref().expect("the controller's report");
        let err = (0..4)
            .map(|k| (s.x[k] - reference.x[k]).abs())
            .fold(0.0, f64::max);
        let balance = s.max_energy_balance_error.unwrap();
        eprintln!(
            "Petrov–Galerkin 2, tol {tol:e}: error {err:.3e} ({:.2} tol), {} accepted, {} rejected, \
             steps {:?} … {:?}, energy balance {balance:.1e}, increase {:?}",
            err / tol,
            a.accepted,
            a.rejected,
            a.smallest_step,
            a.largest_step,
            s.max_energy_increase
        );
        assert_eq!(a.orders, vec![[2, a.accepted]]);
        // Each step's balance to a few ε of |H| ≤ 2, summed over the steps.
        let bound = a.accepted as f64 * 16.0 * f64::EPSILON;
        assert!(balance <= bound, "balance {balance:e} > {bound:e}");
        assert!(s.max_energy_increase.unwrap() <= bound);
        assert!(s.max_abs_g.unwrap() <= 64.0 * f64::EPSILON);
        errs.push(err);
    }
    let p = slope(&tols, &errs);
    eprintln!("slope {p:.3}");
    assert!((0.8..=1.2).contains(&p), "slope {p}");
    for (&tol, &e) in tols.iter().zip(&errs) {
        // Per unit step: ≤ 5 tol per unit time (max norm against the weighted RMS) over 10 s.
        assert!(e <= 50.0 * tol, "tol {tol:e}: {e:e}");
    }
}

/// The relative orbit's period.
fn period() -> f64 {
    2.0 * std::f64::consts::PI / 1.001f64.sqrt()
}

/// scenes/kepler.toml over `orbits` periods with `integrator` lines (`dt` among them) in place
/// of its own.
fn kepler(orbits: f64, integrator: &str) -> lieflow::scene::RunSummary {
    let text = include_str!("../../scenes/kepler.toml");
    let head = text.split("[integrator]").next().unwrap();
    let text = format!(
        "{head}[integrator]\n{integrator}\nt_end = {}\n",
        orbits * period()
    );
    let s = run_scene(&parse(&text));
    assert!(s.error.is_none(), "{:?}", s.error);
    s
}

#[test]
fn reversible_steps_keep_the_eccentric_orbit_s_energy_without_drift() {
    // Reversible steps along ρ = r^{−3/2} (r the sun–planet distance): the energy error over
    // 100 orbits is that over the first 10 (no drift), and far below that of Strang's fixed
    // step with as many steps.
    let reversible = format!(
        "dt = {}\ntol = 1e-6\ncontroller = \"reversible\"\ndensity = {{ distance = [\"sun\", \"planet\"], power = 1.5 }}",
        period() / 20.0
    );
    let short = kepler(10.0, &reversible);
    let long = kepler(100.0, &reversible);
    let (e10, e100) = (
        short.max_abs_energy_error.unwrap(),
        long.max_abs_energy_error.unwrap(),
    );
    let a = long.adaptive.as_ref().unwrap();
    let steps = a.accepted as f64;
    // Strang's fixed step with as many steps over the 100 orbits.
    let fixed = kepler(100.0, &format!("dt = {}", 100.0 * period() / steps));
    let ef = fixed.max_abs_energy_error.unwrap();
    eprintln!(
        "reversible: {steps} steps over 100 orbits, steps {:?} … {:?}; max |ΔH| {e10:.2e} over 10 \
         orbits, {e100:.2e} over 100; Strang with {} fixed steps: {ef:.2e}",
        a.smallest_step, a.largest_step, fixed.steps
    );
    assert!(e100 <= 1.5 * e10, "drift: {e10:e} → {e100:e}");
    assert!(ef > 10.0 * e100, "fixed {ef:e} against {e100:e}");
}

#[test]
fn what_a_controller_cannot_go_with_is_refused_where_it_is_written() {
    let kepler_text = |integrator: &str| {
        let text = include_str!("../../scenes/kepler.toml");
        let head = text.split("[integrator]").next().unwrap();
        format!("{head}[integrator]\ndt = 0.1\nt_end = 1.0\n{integrator}\n")
    };
    let density = "density = { distance = [\"sun\", \"planet\"], power = 1.5 }";
    let cases = [
        (
            pendulum(
                0.1,
                &format!("tol = 1e-6\ncontroller = \"reversible\"\n{density}"),
            ),
            SceneErrorKind::Unsupported,
            "integrator.controller",
        ),
        (
            kepler_text("tol = 1e-6\ncontroller = \"reversible\""),
            SceneErrorKind::Value,
            "integrator.controller",
        ),
        (
            kepler_text(&format!("tol = 1e-6\n{density}")),
            SceneErrorKind::Value,
            "integrator.density",
        ),
        (
            kepler_text("controller = \"reversible\""),
            SceneErrorKind::Value,
            "integrator.controller",
        ),
        (
            kepler_text(&format!(
                "tol = 1e-6\ncontroller = \"reversible\"\nscheme = \"petrov-galerkin\"\n{density}"
            )),
            SceneErrorKind::Unsupported,
            "integrator.controller",
        ),
        (
            kepler_text(
                "tol = 1e-6\ncontroller = \"reversible\"\ndensity = { distance = [\"moon\"], power = 1.5 }",
            ),
            SceneErrorKind::Reference,
            "integrator.density.distance[0]",
        ),
        (
            kepler_text(
                "tol = 1e-6\ncontroller = \"reversible\"\ndensity = { distance = [\"sun\", \"sun\"], power = 1.5 }",
            ),
            SceneErrorKind::Value,
            "integrator.density.distance",
        ),
        (
            kepler_text(
                "tol = 1e-6\ncontroller = \"reversible\"\ndensity = { distance = [\"sun\"], power = 0 }",
            ),
            SceneErrorKind::Value,
            "integrator.density.power",
        ),
        (
            pendulum(
                0.1,
                "tol = 1e-6\nscheme = \"petrov-galerkin\"\nmax_order = 8",
            ),
            SceneErrorKind::Value,
            "integrator.max_order",
        ),
        (
            pendulum(0.1, "tol = 1e-6\nscheme = \"suzuki4\""),
            SceneErrorKind::Unsupported,
            "integrator.scheme",
        ),
    ];
    for (text, kind, path) in cases {
        let e = match parse(&text).compile() {
            Ok(_) => panic!("accepted: {text}"),
            Err(e) => e,
        };
        assert_eq!((e.kind, e.path.to_string().as_str()), (kind, path), "{e}");
    }
}
