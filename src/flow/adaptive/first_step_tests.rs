//! The starting step: Hairer, Nørsett & Wanner's formula with the derivatives of the flow, and
//! nothing of the run changed by the probes.

use super::*;
use crate::error::StepError;

type X = nalgebra::SVector<f64, 2>;

/// The exact flow of `x' = −x`, remembering how many steps it took (its "warm start"), failing
/// (as a Newton solve would) on steps longer than `longest`.
#[derive(Debug)]
struct Decay {
    taken: f64,
    longest: f64,
}

impl Flow<X> for Decay {
    fn step(&mut self, h: f64, x: &mut X) -> Result<(), StepError> {
        if h.abs() > self.longest {
            return Err(StepError::NonFinite { component: 0 });
        }
        *x *= (-h).exp();
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

/// The estimate's inputs.
fn start<'a>(
    tolerances: &'a Tolerances<f64>,
    order: u32,
    ledger: &'a Ledger<f64>,
    sign: f64,
    span: f64,
    x: &'a X,
) -> Start<'a, X> {
    Start {
        tolerances,
        order,
        ledger,
        sign,
        span,
        x,
    }
}

fn decay(longest: f64) -> Decay {
    Decay {
        taken: 7.0,
        longest,
    }
}

#[test]
fn the_estimate_is_the_textbook_step_with_the_exact_derivatives() {
    // x = (1, 2), rtol 0, atol 1e-6: d₀ = ‖x‖ = √(5/2)·10⁶, and for x' = −x, d₁ = d₂ = d₀
    // exactly; h₀ = 0.01 d₀/d₁ = 0.01, so h = min(100 h₀, (0.01/d₀)^{1/p}) = min(1,
    // (0.01/d₀)^{1/p}). The difference quotients at h₀ err by O(h₀) relative: h within 1%.
    let tol = Tolerances::new(0.0, 1e-6).unwrap();
    let x = X::new(1.0, 2.0);
    let d0 = (2.5f64).sqrt() * 1e6;
    for p in [2u32, 4, 8, 12, 40] {
        let mut base = decay(f64::INFINITY);
        let (h, steps) = estimate(&mut base, &start(&tol, p, &Ledger::at(0.0), 1.0, 1.0, &x));
        let want = (0.01 / d0).powf(1.0 / f64::from(p)).min(1.0);
        let h = h.unwrap();
        assert!((h / want - 1.0).abs() < 0.01, "p {p}: {h} against {want}");
        assert_eq!(steps, 3);
        // Backwards the same step.
        let (hb, _) = estimate(&mut base, &start(&tol, p, &Ledger::at(0.0), -1.0, 1.0, &x));
        let hb = hb.unwrap();
        assert!((hb / want - 1.0).abs() < 0.011, "p {p} backwards: {hb}");
    }
    // Never beyond the span.
    let mut base = decay(f64::INFINITY);
    let (h, _) = estimate(&mut base, &start(&tol, 30, &Ledger::at(0.0), 1.0, 0.05, &x));
    assert_eq!(h, Some(0.05));
}

#[test]
fn the_probes_leave_the_state_and_the_memory_as_they_were() {
    let tol = Tolerances::new(1e-8, 1e-8).unwrap();
    let x = X::new(1.0, 2.0);
    let mut base = decay(f64::INFINITY);
    let (h, _) = estimate(&mut base, &start(&tol, 8, &Ledger::at(3.0), 1.0, 10.0, &x));
    assert!(h.is_some());
    assert_eq!(base.taken, 7.0);
    assert_eq!(x, X::new(1.0, 2.0));
}

#[test]
fn a_probe_that_fails_is_retried_shorter_and_a_flow_that_always_fails_gives_none() {
    let tol = Tolerances::new(0.0, 1e-6).unwrap();
    let x = X::new(1.0, 2.0);
    // Span 1000: the probe of 1 and of 0.1 fail, 0.01 is taken; h₀ = 0.01 as above.
    let mut base = decay(0.05);
    let (h, steps) = estimate(
        &mut base,
        &start(&tol, 4, &Ledger::at(0.0), 1.0, 1000.0, &x),
    );
    assert_eq!(steps, 5);
    let want = (0.01 / ((2.5f64).sqrt() * 1e6)).powf(0.25);
    assert!((h.unwrap() / want - 1.0).abs() < 0.01);
    assert_eq!(base.taken, 7.0);
    let mut never = decay(0.0);
    let (h, steps) = estimate(&mut never, &start(&tol, 4, &Ledger::at(0.0), 1.0, 1.0, &x));
    assert_eq!((h, steps), (None, 3));
    assert_eq!(never.taken, 7.0);
}
