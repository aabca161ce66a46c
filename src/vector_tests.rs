//! The branch-free reductions of [`ops`](super::ops) against their plain definitions, at every
//! length and position around their blocks of four.

use super::ops;

#[test]
fn norm_inf_is_the_largest_magnitude_and_keeps_nan() {
    assert_eq!(ops::norm_inf::<f64>(&[]), 0.0);
    for len in 1..=11 {
        for at in 0..len {
            // The largest entry at every position, in the blocks and in the remainder.
            let mut x: Vec<f64> = (0..len).map(|i| 0.1 * i as f64 - 0.3).collect();
            x[at] = -7.5;
            assert_eq!(ops::norm_inf(&x), 7.5, "len {len}, at {at}");
            x[at] = f64::NEG_INFINITY;
            assert_eq!(ops::norm_inf(&x), f64::INFINITY, "len {len}, at {at}");
            x[at] = f64::NAN;
            assert!(ops::norm_inf(&x).is_nan(), "len {len}, NaN at {at}");
        }
    }
}

#[test]
fn first_non_finite_finds_the_first() {
    for len in 1..=11 {
        let mut x = vec![1.0f64; len];
        assert_eq!(ops::first_non_finite(&x), None);
        for at in (0..len).rev() {
            x[at] = if at % 2 == 0 { f64::NAN } else { f64::INFINITY };
            assert_eq!(ops::first_non_finite(&x), Some(at), "len {len}");
        }
    }
}
