//! The pair kernel's gradient, chosen per law and per dimension, against the law's `φ'(r)/r`
//! pair by pair and against central differences of the energy.

use super::{PairLaw, Pairs};
use crate::scene::effects::PotentialOps;

fn laws() -> Vec<PairLaw> {
    vec![
        PairLaw::Log { strength: 1.3 },
        PairLaw::InversePower {
            strength: 0.7,
            power: 1.0,
        },
        PairLaw::InversePower {
            strength: -0.4,
            power: 2.0,
        },
        PairLaw::InversePower {
            strength: 0.9,
            power: 2.5,
        },
        PairLaw::LennardJones {
            epsilon: 0.8,
            sigma: 0.6,
        },
        PairLaw::Spring {
            stiffness: 3.0,
            rest: 0.0,
        },
        PairLaw::Spring {
            stiffness: 2.0,
            rest: 0.4,
        },
    ]
}

/// Five bodies in `d` dimensions, body `b` at `1.1 b` along the first axis (±0.2) and within
/// ±0.7 along the others: no two closer than 0.9 (checked below), where Lennard-Jones' third
/// derivative keeps the central differences' error `δ² |φ‴| / 6` below 1e-8 of its gradient.
fn positions(d: usize) -> Vec<f64> {
    (0..5 * d)
        .map(|i| {
            let (b, k) = (i / d, i % d);
            let wobble = (i as f64 * 0.37 + (i * i % 7) as f64 * 0.21).sin();
            if k == 0 {
                1.1 * b as f64 + 0.2 * wobble
            } else {
                0.7 * wobble
            }
        })
        .collect()
}

fn all_pairs() -> Vec<(usize, usize)> {
    (0..5)
        .flat_map(|a| (a + 1..5).map(move |b| (a, b)))
        .collect()
}

/// The gradient summed pair by pair from `φ'(r)/r = eval(r).1`, as the kernel computed it
/// before it took `r²`.
fn reference(law: PairLaw, q: &[f64], d: usize, alpha: f64) -> Vec<f64> {
    let mut out = vec![0.0; q.len()];
    for (a, b) in all_pairs() {
        let r = (0..d)
            .map(|k| (q[a * d + k] - q[b * d + k]).powi(2))
            .sum::<f64>()
            .sqrt();
        let s = alpha * law.eval(r).1;
        for k in 0..d {
            let z = s * (q[a * d + k] - q[b * d + k]);
            out[a * d + k] += z;
            out[b * d + k] -= z;
        }
    }
    out
}

/// Every law in one to four dimensions (the compiled `d = 2, 3` paths and the general one):
/// the kernel's gradient equals the per-pair formula to rounding (a few ulps of the largest
/// term: the two differ only in how `φ'(r)/r` is formed from `r²`).
#[test]
fn gradient_matches_the_per_pair_formula_in_every_dimension() {
    for d in 1..=4 {
        let q = positions(d);
        for law in laws() {
            let pairs = Pairs::new(all_pairs(), law);
            let mut out = vec![0.25; q.len()];
            pairs.gradient_add(&q, d, -1.5, &mut out);
            let want = reference(law, &q, d, -1.5);
            let scale = want.iter().fold(1.0f64, |m, v| m.max(v.abs()));
            for (i, (&o, &w)) in out.iter().zip(&want).enumerate() {
                assert!(
                    (o - 0.25 - w).abs() <= 64.0 * f64::EPSILON * scale,
                    "{law:?}, d = {d}, component {i}: {} vs {w}",
                    o - 0.25
                );
            }
        }
    }
}

/// The gradient is the derivative of the energy: central differences with `δ = 1e-5` agree
/// to `O(δ²)` (here ≤ 1e-6 relative).
#[test]
fn gradient_is_the_derivative_of_the_energy() {
    for d in 1..=4 {
        let q = positions(d);
        for (a, b) in all_pairs() {
            let r2: f64 = (0..d).map(|k| (q[a * d + k] - q[b * d + k]).powi(2)).sum();
            assert!(r2 > 0.81, "bodies {a} and {b} at {}", r2.sqrt());
        }
        for law in laws() {
            let pairs = Pairs::new(all_pairs(), law);
            let mut grad = vec![0.0; q.len()];
            pairs.gradient_add(&q, d, 1.0, &mut grad);
            let delta = 1e-5;
            for i in 0..q.len() {
                let (mut a, mut b) = (q.clone(), q.clone());
                a[i] += delta;
                b[i] -= delta;
                let fd = (pairs.energy(&a, d) - pairs.energy(&b, d)) / (2.0 * delta);
                assert!(
                    (fd - grad[i]).abs() < 1e-6 * (1.0 + grad[i].abs()),
                    "{law:?}, d = {d}, component {i}: {fd} vs {}",
                    grad[i]
                );
            }
        }
    }
}
