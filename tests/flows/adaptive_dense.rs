//! Dense output of the adaptive extrapolation (`AdaptiveOptions::dense_output`): the
//! polynomial of each accepted step between its ends, against the damped pendulum's reference.

use crate::adaptive::{Adaptive, THETA0, V, adaptive_with, continued_twice, model};
use crate::common::log_slope as slope;
use lieflow::flow::{AdaptiveOptions, Flow, Ledger, Tolerances};
use lieflow::prelude::*;

/// The damped pendulum's adaptive extrapolation at `tol` with dense output.
fn dense(tol: f64) -> (Adaptive, V) {
    let mut options = AdaptiveOptions::new(Tolerances::new(tol, tol).unwrap());
    options.dense_output = true;
    adaptive_with(options)
}

/// `|g|` and `|φ|` of the pendulum's state.
fn residuals(x: &V) -> (f64, f64) {
    (
        (0.5 * (x[0] * x[0] + x[1] * x[1] - 1.0)).abs(),
        (x[0] * x[2] + x[1] * x[3]).abs(),
    )
}

#[test]
fn the_interpolant_follows_the_tolerance_between_the_steps() {
    // θ₀ = π/2, c = 0.1, over 10 s in the flow's own steps; at forty times off the steps'
    // ends the dense output (the polynomial, no partial step: the base steps do not move)
    // against the angle equation by RK4 at 1e-4. The controller holds the polynomial's
    // estimated error to 1 in the weighted RMS norm (rtol = atol = tol, |x| ≤ 1.5: at most
    // 2·2.5 tol in the max-norm) and the ends' error is below tol: every dense error within
    // 10 tol, above tol/100, at a log–log slope within 0.8 … 1.2 (measured: 1.2 … 2.4 tol,
    // slope 1.02); each dense state projected, its rows at the Newton floor.
    let t_end = 10.0;
    let m = model();
    // Forty times off any step's end, and the reference there.
    let queries: Vec<f64> = (0..40).map(|i| 0.25 * i as f64 + 0.1234).collect();
    let wants: Vec<[f64; 4]> = queries
        .iter()
        .map(|&t| m.reference(THETA0, 0.0, t, 1e-4))
        .collect();
    let end = m.reference(THETA0, 0.0, t_end, 1e-4);
    let tols = [1e-4, 1e-6, 1e-8, 1e-10, 1e-12];
    let mut errs = Vec::new();
    for &tol in &tols {
        let (flow, x0) = dense(tol);
        let mut stepper = Stepper::new(flow, x0, 0.0, 1.0).unwrap();
        let (mut q, mut worst, mut worst_g) = (0, 0.0f64, 0.0f64);
        while stepper.step_own(t_end).unwrap().is_some() {
            let t = stepper.time();
            while q < queries.len() && queries[q] <= t {
                let before = stepper.flow().adaptive_stats().unwrap().base_steps;
                let mut out = x0;
                let l = stepper.dense(queries[q], &mut out).unwrap();
                assert_eq!(l.t, queries[q]);
                assert_eq!(
                    stepper.flow().adaptive_stats().unwrap().base_steps,
                    before,
                    "no partial step"
                );
                let e = (0..4)
                    .map(|k| (out[k] - wants[q][k]).abs())
                    .fold(0.0, f64::max);
                worst = worst.max(e);
                let (g, phi) = residuals(&out);
                worst_g = worst_g.max(g).max(phi);
                q += 1;
            }
        }
        assert_eq!(q, queries.len());
        let x = *stepper.state();
        let at_end = (0..4).map(|k| (x[k] - end[k]).abs()).fold(0.0, f64::max);
        let s = stepper.flow().adaptive_stats().unwrap();
        eprintln!(
            "tol {tol:e}: dense error {worst:.3e} ({:.2} tol), at the end {at_end:.3e}, |g| {worst_g:.1e}, {} accepted, {} base steps, orders {:?}",
            worst / tol,
            s.accepted,
            s.base_steps,
            s.orders
        );
        assert!(
            worst <= 10.0 * tol && worst >= tol / 100.0,
            "tol {tol:e}: {worst:e}"
        );
        assert!(at_end <= tol, "tol {tol:e}: {at_end:e}");
        assert!(worst_g <= 200.0 * f64::EPSILON, "{worst_g:e}");
        errs.push(worst);
    }
    let p = slope(&tols, &errs);
    eprintln!("dense error against tolerance: slope {p:.3}");
    assert!((0.8..=1.2).contains(&p), "slope {p}");
}

#[test]
fn reading_the_interpolant_leaves_the_run_as_it_was_and_a_continuation_is_bit_identical() {
    // The same run with and without dense output read after every step: the steps' ends
    // agree to the projection's Newton tolerance (reading projects the dense state, and
    // the projection's kept matrices are rebuilt at the next step). A checkpoint after 3 s —
    // the flow's memory, the polynomial not in it — continues bit for bit, and its
    // continuation's first dense output comes from a partial step (nothing to interpolate
    // until a step is taken), the later ones from the polynomial.
    let t_end = 10.0;
    let run = |read: bool| {
        let (flow, x0) = dense(1e-9);
        let mut stepper = Stepper::new(flow, x0, 0.0, 1.0).unwrap();
        while stepper.step_own(t_end).unwrap().is_some() {
            if read {
                let t = 0.5 * (stepper.previous_time() + stepper.time());
                let mut out = x0;
                stepper.dense(t, &mut out).unwrap();
            }
        }
        *stepper.state()
    };
    let (a, b) = (run(true), run(false));
    let gap = (0..4).map(|k| (a[k] - b[k]).abs()).fold(0.0, f64::max);
    eprintln!("read against not read: {gap:e}");
    assert!(gap <= 1e-13, "{gap:e}");

    let (mut flow, x) = dense(1e-9);
    let ((a, la), (b, lb)) = continued_twice(&mut flow, x, |flow, saved| {
        let (mut probe, mut at) = (*saved, Ledger::at(3.5));
        assert!(flow.interpolate(&mut at, &mut probe).is_none());
    });
    assert_eq!(a, b);
    assert_eq!(la, lb);
    let mut probe = a;
    let mut at = Ledger::at(6.99);
    assert!(flow.interpolate(&mut at, &mut probe).unwrap().is_ok());
    let (g, phi) = residuals(&probe);
    assert!(g.max(phi) <= 200.0 * f64::EPSILON, "{g:e} {phi:e}");
}
