//! An input that jumps: the adaptive run's steps land on the jump (`AdaptiveOptions::breakpoints`
//! from the signals), so the error estimate never straddles it. A step across it is not the
//! smooth expansion the extrapolation's estimate assumes: on the damped four-bar with a motor
//! switched on at t = 0.5, the error was 530 × tol at 1e-6 and 6.1e4 × tol at 1e-10, each
//! reported as met.

use crate::scene_text::{parse, run_scene};

/// The four-bar (`scenes/four_bar.toml`) over 1 s, damped, its motor switched from 0 to 3 N m
/// at t = 0.5, with `integrator` as given.
fn switched_four_bar(integrator: &str) -> String {
    let text = include_str!("../../scenes/four_bar.toml")
        .replace(
            "signal = { type = \"constant\", value = 3.0 }",
            "signal = { type = \"step\", at = 0.5, before = 0.0, after = 3.0 }",
        )
        .replace(
            "[[inputs]]",
            "[[effects]]\ntype = \"damping\"\ncoefficient = 0.3\n\n[[inputs]]",
        );
    let head = text.split("[integrator]").next().unwrap();
    format!("{head}[integrator]\nt_end = 1.0\n{integrator}\n")
}

#[test]
fn an_adaptive_run_lands_on_an_input_s_jump() {
    // The reference lands on the jump (5000 steps of 1e-4 to it).
    let reference = run_scene(&parse(&switched_four_bar("dt = 1e-4\norder = 12")));
    assert!(reference.error.is_none(), "{:?}", reference.error);
    for tol in [1e-6, 1e-10] {
        // One report at the end, and reports at the jump: the same steps, the same state to
        // rounding (the two land on 0.5 by different sums).
        let once = run_scene(&parse(&switched_four_bar(&format!(
            "dt = 1.0\ntol = {tol}"
        ))));
        let at_jump = run_scene(&parse(&switched_four_bar(&format!(
            "dt = 0.5\ntol = {tol}"
        ))));
        assert!(once.error.is_none(), "{:?}", once.error);
        let apart = once
            .x
            .iter()
            .zip(&at_jump.x)
            .map(|(u, v)| (u - v).abs())
            .fold(0.0, f64::max);
        assert!(apart <= 1e-13, "tol {tol:e}: {apart:e} apart");
        let (a, b) = (
            once.adaptive.as_ref().unwrap(),
            at_jump.adaptive.as_ref().unwrap(),
        );
        assert_eq!((a.accepted, a.base_steps), (b.accepted, b.base_steps));
        let err = once
            .x
            .iter()
            .zip(&reference.x)
            .map(|(u, v)| (u - v).abs())
            .fold(0.0, f64::max);
        eprintln!(
            "switched four-bar at tol {tol:e}: error {err:.2e} ({:.1} × tol), {} steps, {} base steps",
            err / tol,
            a.accepted,
            a.base_steps
        );
        // A local error per step at the tolerance, weighted by |x| ≲ 5, over ~16 steps: a
        // global error of tens of tol (the constant-torque four-bar errs 5–31 × tol), far from
        // the hundreds and tens of thousands a step across the jump gave.
        assert!(err <= 100.0 * tol, "tol {tol:e}: error {err:e}");
    }
}
