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
