//! Step-size control of fixed-order schemes (`lieflow::flow::StepDoubling`): the achieved
//! error follows the tolerance; the Petrov–Galerkin scheme keeps its exact discrete energy
//! balance under variable steps (dissipation never negative, the constraints at round-off); a
//! composition of order 4 is controlled at its order; a rejected step leaves nothing behind; a
//! continuation from saved memory is bit-identical; an exact flow is refused; a tolerance near
//! the round-off is met to rounding, not refused; no step crosses a breakpoint.

use crate::common::log_slope as slope;
use lieflow::flow::{
    AdaptiveOptions, Flow, FlowExt, Ledger, PetrovGalerkin, StepDoubling, Tolerances, from_fn,
};
use lieflow::models::DampedPendulum;
use lieflow::prelude::*;
use nalgebra::SVector;

type V = SVector<f64, 4>;
const THETA0: f64 = std::f64::consts::FRAC_PI_2;
const T_END: f64 = 10.0;

fn options(tol: f64) -> AdaptiveOptions<f64> {
    AdaptiveOptions::new(Tolerances::new(tol, tol).unwrap())
}

fn error(x: &V, r: &[f64; 4]) -> f64 {
    (0..4).map(|i| (x[i] - r[i]).abs()).fold(0.0, f64::max)
}

#[test]
fn petrov_galerkin_keeps_its_energy_balance_under_variable_steps() {
    let m = DampedPendulum::try_new(0.5).unwrap();
    let x0: V = m.state(THETA0, 0.0);
    let r = m.reference(THETA0, 0.0, T_END, 2e-4);
    let tols = [1e-4, 1e-6, 1e-8, 1e-10];
    let mut errs = Vec::new();
    for &tol in &tols {
        let pg: PetrovGalerkin<V, _> =
            PetrovGalerkin::try_new(m.system(), &x0, 2, ProjectionOptions::default()).unwrap();
        let mut flow = StepDoubling::try_new(pg, (), options(tol)).unwrap();
        let (mut x, mut ledger) = (x0, Ledger::at(0.0));
        let (mut worst, mut max_g, mut max_phi, mut steps) = (0.0f64, 0.0f64, 0.0f64, 0u64);
        let mut booked = 0.0f64;
        while ledger.t < T_END {
            let before = m.energy(&x) + ledger.dissipated;
            let d0 = ledger.dissipated;
            let left = T_END - ledger.t;
            flow.step_own(&mut ledger, left, &mut x).unwrap().unwrap();
            steps += 1;
            // The discrete balance H_{n+1} − H_n = −D_n, D_n ≥ 0, step by step (|H| ≤ 1.5).
            worst = worst.max((m.energy(&x) + ledger.dissipated - before).abs());
            assert!(ledger.dissipated - d0 >= -4.0 * f64::EPSILON, "tol {tol:e}");
            booked = ledger.dissipated;
            max_g = max_g.max((0.5 * (x[0] * x[0] + x[1] * x[1] - 1.0)).abs());
            max_phi = max_phi.max(m.hidden_constraint(&x).abs());
        }
        let s = flow.adaptive_stats().unwrap();
        let e = error(&x, &r);
        eprintln!(
            "Petrov–Galerkin 2 at tol {tol:.0e}: error {e:.2e} ({:.2} × tol), {steps} steps ({} rejected), \
             h {:.1e} … {:.1e}, step balance ≤ {worst:.1e}, booked {booked:.6}, |g| {max_g:.1e}, |φ| {max_phi:.1e}",
            e / tol,
            s.rejected,
            s.smallest,
            s.largest
        );
        assert_eq!(s.accepted, steps);
        assert!(
            worst <= 16.0 * f64::EPSILON,
            "tol {tol:e}: balance {worst:e}"
        );
        assert!(max_g <= 8.0 * f64::EPSILON, "{max_g:e}");
        assert!(max_phi <= 16.0 * f64::EPSILON, "{max_phi:e}");
        errs.push(e);
    }
    let p = slope(&tols, &errs);
    eprintln!("error against tolerance: slope {p:.3}");
    // The error per unit step at the tolerance: the global error follows the tolerance
    // (slope 1). Bound: a step's max-norm error is at most 2 × its weighted RMS (4 components)
    // × the weight atol + rtol |x| ≤ 2.5 tol, so ≤ 5 tol h; summed over T = 10 on this damped
    // (non-expanding) motion, ≤ 50 tol.
    assert!((0.8..=1.2).contains(&p), "slope {p}");
    for (&tol, &e) in tols.iter().zip(&errs) {
        assert!(e <= 5.0 * T_END * tol, "tol {tol:e}: error {e:e}");
    }
}

#[test]
fn a_tolerance_near_the_round_off_is_met_to_rounding_not_refused() {
    // At rtol = atol = 1e-13 the error per unit step asks a step of length H for an error
    // below 1e-13 H, less than rounding gives once H ≲ 2e-3 (ε |x| ≈ 2e-16): the estimate of
    // such a step is its round-off, which per unit step grows as 1/H, so halving never ended
    // (StepSizeTooSmall). Below four times the state's round-off the span is held there.
    let m = DampedPendulum::try_new(0.5).unwrap();
    let x0: V = m.state(THETA0, 0.0);
    let t_end = 0.5;
    let r = m.reference(THETA0, 0.0, t_end, 2e-4);
    let tol = 1e-13;
    let pg: PetrovGalerkin<V, _> =
        PetrovGalerkin::try_new(m.system(), &x0, 2, ProjectionOptions::default()).unwrap();
    let mut flow = StepDoubling::try_new(pg, (), options(tol)).unwrap();
    let mut x = x0;
    flow.step(t_end, &mut x).unwrap();
    let s = flow.adaptive_stats().unwrap();
    let e = error(&x, &r);
    // Each accepted step's weighted error ≤ max(H, 4ρ), ρ = ε ‖x‖ ≤ ε / rtol; a max-norm error
    // ≤ 2 × the weighted RMS (4 components) × the weight ≤ 2.5 tol (as above): the sum over
    // the steps ≤ 5 tol (T + 4 N ε / tol). The reference (RK4 at 2e-4) is good to ~1e-15.
    let n = s.accepted as f64;
    let bound = 5.0 * tol * (t_end + 4.0 * n * f64::EPSILON / tol);
    eprintln!(
        "Petrov–Galerkin 2 at tol {tol:.0e}: error {e:.2e} (bound {bound:.1e}), {} steps, h {:.1e} … {:.1e}",
        s.accepted, s.smallest, s.largest
    );
    assert!(e <= bound, "error {e:e} above {bound:e}");
}

#[test]
fn a_composition_of_order_four_is_controlled_at_its_order() {
    // The undamped pendulum: the triple jump of the projected Strang step.
    let m = DampedPendulum::try_new(0.0).unwrap();
    let x0: V = m.state(THETA0, 0.0);
    let r = m.reference(THETA0, 0.0, T_END, 2e-4);
    let run = |tol: f64| {
        let base = m
            .free_flow()
            .and_then(|f| f.projected(m.system(), &x0, ProjectionOptions::default()))
            .unwrap()
            .triple_jump();
        let mut flow = StepDoubling::try_new(base, (), options(tol)).unwrap();
        let mut x = x0;
        flow.step(T_END, &mut x).unwrap();
        let s = flow.adaptive_stats().unwrap();
        (error(&x, &r), s.accepted, s.orders[2])
    };
    let tols = [1e-5, 1e-7, 1e-9];
    let runs: Vec<_> = tols.iter().map(|&t| run(t)).collect();
    for (tol, (e, n, at4)) in tols.iter().zip(&runs) {
        eprintln!("triple jump at tol {tol:.0e}: error {e:.2e}, {n} steps ({at4} at order 4)");
        assert_eq!(n, at4);
    }
    // Error per unit step O(H^p): steps ∝ tol^{−1/p} at order p = 4, so 100× tighter is
    // 100^{1/4} = 3.16× the steps (up to the PI controller's margin, 1.3 either way).
    for w in runs.windows(2) {
        let ratio = w[1].1 as f64 / w[0].1 as f64;
        assert!(
            (3.16 / 1.3..=3.16 * 1.3).contains(&ratio),
            "steps ratio {ratio}"
        );
    }
    let errs: Vec<f64> = runs.iter().map(|r| r.0).collect();
    let p = slope(&tols, &errs);
    eprintln!("slope {p:.3}");
    assert!((0.8..=1.2).contains(&p), "slope {p}");
}

/// Störmer–Verlet for `x'' = −x` in the first two components, counting its steps (memory).
#[derive(Default)]
struct Counted {
    taken: f64,
}

impl Flow<V> for Counted {
    fn step(&mut self, h: f64, x: &mut V) -> Result<(), StepError> {
        x[2] -= 0.5 * h * x[0];
        x[0] += h * x[2];
        x[2] -= 0.5 * h * x[0];
        self.taken += 1.0;
        Ok(())
    }
    fn order(&self) -> u32 {
        2
    }
    fn is_symmetric(&self) -> bool {
        true
    }
    fn save_memory(&mut self, out: &mut Vec<f64>) {
        out.push(self.taken);
    }
    fn restore_memory(&mut self, from: &mut &[f64]) {
        self.taken = from[0];
        *from = &from[1..];
    }
}

#[test]
fn a_rejected_step_leaves_nothing_behind_and_a_continuation_is_bit_identical() {
    let x0 = V::new(1.0, 0.0, 0.0, 0.0);
    // A first step far too long: rejected, then taken shorter.
    let mut opts = options(1e-8);
    opts.first_step = Some(2.0);
    let mut a = StepDoubling::try_new(Counted::default(), (), opts).unwrap();
    let (mut xa, mut la) = (x0, Ledger::at(0.0));
    let ha = a.step_own(&mut la, 10.0, &mut xa).unwrap().unwrap();
    let sa = a.adaptive_stats().unwrap();
    assert!(sa.rejected >= 1 && sa.accepted == 1, "{sa:?}");
    // The same step asked for first: the same bits, and the base flow's memory counts only
    // the accepted step's three sub-steps (the rejected attempts were undone).
    let mut opts = options(1e-8);
    opts.first_step = Some(ha);
    let mut b = StepDoubling::try_new(Counted::default(), (), opts).unwrap();
    let (mut xb, mut lb) = (x0, Ledger::at(0.0));
    let hb = b.step_own(&mut lb, 10.0, &mut xb).unwrap().unwrap();
    assert_eq!((ha, xa), (hb, xb));
    assert_eq!(a.base().taken, 2.0, "the kept halves only");
    assert_eq!(b.base().taken, 2.0);
    // A continuation from saved memory.
    let mut memory = Vec::new();
    a.save_memory(&mut memory);
    let (xs, ls) = (xa, la);
    for _ in 0..25 {
        a.step_own(&mut la, 10.0, &mut xa).unwrap().unwrap();
    }
    let mut c = StepDoubling::try_new(Counted::default(), (), options(1e-8)).unwrap();
    c.restore_memory(&mut memory.as_slice());
    let (mut xc, mut lc) = (xs, ls);
    for _ in 0..25 {
        c.step_own(&mut lc, 10.0, &mut xc).unwrap().unwrap();
    }
    assert_eq!((xa, la.t), (xc, lc.t));
}

#[test]
fn an_exact_flow_is_refused() {
    let exact = from_fn(|h: f64, x: &mut V| x[0] += h);
    let e = match StepDoubling::try_new(exact, (), options(1e-6)) {
        Ok(_) => panic!("accepted"),
        Err(e) => e.to_string(),
    };
    assert!(e.contains("exact flow needs no step control"), "{e}");
}

/// The ends of the steps a step-doubled Störmer–Verlet takes from `from` to `to` with
/// `breakpoints`, each checked not to cross 0.3 or 0.7.
fn step_ends(breakpoints: Vec<f64>, from: f64, to: f64) -> Vec<f64> {
    let mut opts = options(1e-8);
    opts.breakpoints = breakpoints;
    let mut flow = StepDoubling::try_new(Counted::default(), (), opts).unwrap();
    let (mut x, mut ledger) = (V::new(1.0, 0.0, 0.0, 0.0), Ledger::at(from));
    let mut ends = Vec::new();
    while (to - ledger.t).abs() > 1e-14 {
        let before = ledger.t;
        let left = to - before;
        flow.step_own(&mut ledger, left, &mut x).unwrap().unwrap();
        let (lo, hi) = (before.min(ledger.t), before.max(ledger.t));
        for b in [0.3, 0.7] {
            assert!(
                !(lo < b - 1e-15 && hi > b + 1e-15),
                "a step from {before} to {} crosses {b}",
                ledger.t
            );
        }
        ends.push(ledger.t);
    }
    ends
}

#[test]
fn no_step_crosses_a_breakpoint() {
    // Breakpoints given in any order, some outside the run: every one inside it is a step's
    // end, to rounding, forward and backward.
    for ends in [
        step_ends(vec![0.7, 0.3, 5.0, -1.0], 0.0, 1.0),
        step_ends(vec![0.3, 0.7], 1.0, 0.0),
    ] {
        for b in [0.3, 0.7] {
            assert!(
                ends.iter().any(|&t| (t - b).abs() <= 4.0 * f64::EPSILON),
                "{b} not landed on: {ends:?}"
            );
        }
    }
    let mut bad = options(1e-8);
    bad.breakpoints = vec![f64::NAN];
    assert!(StepDoubling::try_new(Counted::default(), (), bad).is_err());
}
