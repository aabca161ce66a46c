//! A rejected macro step leaves nothing behind: the state, the ledger and the base flow's
//! memory bit for bit.

use super::*;
use crate::flow::Tolerances;

type X = nalgebra::SVector<f64, 2>;

/// Störmer–Verlet for `x'' = −x` on `(q, p)` (symmetric, order 2), remembering how many steps
/// it took (its "warm start").
#[derive(Debug, Default)]
struct Verlet {
    taken: f64,
}

impl Flow<X> for Verlet {
    fn step(&mut self, h: f64, x: &mut X) -> Result<(), StepError> {
        x[1] -= 0.5 * h * x[0];
        x[0] += h * x[1];
        x[1] -= 0.5 * h * x[0];
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

fn flow(tol: f64) -> AdaptiveExtrapolation<X, Verlet, ()> {
    let options = AdaptiveOptions::new(Tolerances::new(tol, tol).unwrap());
    AdaptiveExtrapolation::try_new(Verlet::default(), (), options).unwrap()
}

#[test]
fn a_rejected_macro_step_restores_state_ledger_and_memory() {
    let mut f = flow(1e-12);
    let mut x = X::new(1.0, 0.0);
    f.prepare(&x);
    let mut ledger = Ledger::at(2.0);
    // A macro step of 10 (a period and a half) cannot meet 1e-12 in a few rows.
    let outcome = f.attempt_table(&mut ledger, 10.0, &mut x).unwrap();
    assert!(matches!(outcome, Outcome::Rejected(h) if h < 9.0));
    assert_eq!(x, X::new(1.0, 0.0));
    assert_eq!(ledger, Ledger::at(2.0));
    assert_eq!(f.base().taken, 0.0);
    assert_eq!(f.adaptive_stats().unwrap().rejected, 1);
    assert!(f.adaptive_stats().unwrap().base_steps > 0);
}

#[test]
fn an_accepted_macro_step_is_the_extrapolated_table_s_diagonal() {
    // Two rows (order 4): (4 T₂ − T₁)/3 with T₁ = S_H, T₂ = S_{H/2}².
    let mut f = flow(1e-3);
    f.kc = 2;
    let mut x = X::new(1.0, 0.0);
    f.prepare(&x);
    let mut l = Ledger::at(0.0);
    let h = 0.1;
    let outcome = f.attempt_table(&mut l, h, &mut x).unwrap();
    assert!(matches!(outcome, Outcome::Accepted));
    let mut v = Verlet::default();
    let mut t1 = X::new(1.0, 0.0);
    v.step(h, &mut t1).unwrap();
    let mut t2 = X::new(1.0, 0.0);
    v.step(h / 2.0, &mut t2).unwrap();
    v.step(h / 2.0, &mut t2).unwrap();
    for k in 0..2 {
        let want = (4.0 * t2[k] - t1[k]) / 3.0;
        assert!(
            (x[k] - want).abs() <= 4.0 * f64::EPSILON,
            "{} vs {want}",
            x[k]
        );
    }
    assert_eq!(l.t, h);
    assert_eq!(f.adaptive_stats().unwrap().orders[2], 1);
}

#[test]
fn a_run_backwards_retraces_the_run_forwards() {
    // The controller works in step lengths: the same tolerance backwards (negative steps, every
    // sub-step negative) returns to the start to the tolerance's accuracy, and the step sizes it
    // reports are lengths.
    let mut f = flow(1e-11);
    let start = X::new(1.0, 0.0);
    let mut x = start;
    f.step(3.0, &mut x).unwrap();
    let there = x;
    assert!((there[0] - 3.0f64.cos()).abs() < 1e-9, "{}", there[0]);
    f.step(-3.0, &mut x).unwrap();
    assert!((x - start).amax() < 1e-9, "{x:?}");
    let s = f.adaptive_stats().unwrap();
    assert!(s.smallest > 0.0 && s.largest >= s.smallest, "{s:?}");
    assert!(f.next_step().is_some_and(|h| h > 0.0));
}

#[test]
fn steps_resolve_the_time_asked_for() {
    // Without `resolve` the oscillator at 1e-6 takes steps of about 0.5 or more; with
    // `resolve = 0.01` every step is at most k·0.01 for the column k it aimed at, and is
    // accepted at row k − 1 at the earliest: at most (rows + 1)·0.01 for the most rows it was
    // accepted at — the first one too (its estimate capped), backwards alike.
    let mut free = flow(1e-6);
    let mut x = X::new(1.0, 0.0);
    free.step(2.0, &mut x).unwrap();
    assert!(free.adaptive_stats().unwrap().largest > 0.3);
    let mut options = AdaptiveOptions::new(Tolerances::new(1e-6, 1e-6).unwrap());
    options.resolve = Some(0.01);
    let mut f = AdaptiveExtrapolation::try_new(Verlet::default(), (), options).unwrap();
    let mut y = X::new(1.0, 0.0);
    f.step(2.0, &mut y).unwrap();
    f.step(-1.0, &mut y).unwrap();
    let s = f.adaptive_stats().unwrap();
    let most_rows = (1..=MAX_ROWS).rev().find(|&k| s.orders[k] > 0).unwrap();
    assert!(
        s.largest <= (most_rows + 1) as f64 * 0.01 * (1.0 + 1e-12),
        "{s:?}"
    );
    assert!((y[0] - 1f64.cos()).abs() < 1e-5, "{y:?}");
    // A time to resolve is positive and finite.
    for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        let mut options = AdaptiveOptions::new(Tolerances::new(1e-6, 1e-6).unwrap());
        options.resolve = Some(bad);
        assert!(AdaptiveExtrapolation::try_new(Verlet::default(), (), options).is_err());
    }
}
