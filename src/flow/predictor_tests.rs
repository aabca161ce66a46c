//! The predictor on sequences whose backward differences are known: exact on polynomials of
//! degree below [`MAX_POINTS`], the highest degree on a slow rotation, the lowest on one the
//! steps barely resolve.

use super::{MAX_POINTS, Predictor};

/// Records `f(0), …, f(steps − 1)` and returns the prediction of `f(steps)`.
fn run(steps: usize, f: impl Fn(f64) -> [f64; 2]) -> (Predictor<f64>, [f64; 2]) {
    let mut p = Predictor::new(2);
    for n in 0..steps {
        p.record(&f(n as f64));
    }
    let mut z = [f64::NAN; 2];
    p.predict(&mut z);
    (p, z)
}

#[test]
fn extrapolates_polynomials_exactly() {
    // Integer coefficients and arguments: every value and difference is exact in f64, so the
    // differences of order above the degree are exactly zero and the prediction is exact.
    for degree in 0..MAX_POINTS {
        let f = |n: f64| {
            let (mut a, mut b) = (0.0, 0.0);
            for k in 0..=degree {
                a += (k as f64 + 1.0) * n.powi(k as i32);
                b -= (2 * k + 3) as f64 * n.powi(k as i32);
            }
            [a, b]
        };
        for steps in degree + 2..14 {
            let (p, z) = run(steps, f);
            assert_eq!(z, f(steps as f64), "degree {degree}, {steps} steps");
            // Once an error above the degree is measured (zero): the lowest degree that is
            // exact (the lower one on a tie).
            if steps > degree + 2 {
                assert_eq!(p.points, degree + 1, "degree {degree}, {steps} steps");
            }
        }
    }
}

#[test]
fn picks_the_degree_the_rotation_allows() {
    // z_n = (cos ωn, sin ωn): ‖∇ᵖ z‖_∞ lies between r/√2 and r, r = |2 sin(ω/2)|ᵖ, so the
    // errors fall with p when 2 sin(ω/2) < 1/√2 (ω = 0.1: 0.1) and rise when it is above √2
    // (ω = 3: 1.995).
    let rotation = |w: f64| move |n: f64| [(w * n).cos(), (w * n).sin()];
    for steps in MAX_POINTS + 1..20 {
        let (slow, z) = run(steps, rotation(0.1));
        assert_eq!(slow.points, MAX_POINTS);
        let exact = rotation(0.1)(steps as f64);
        // The error of degree 5: r = 0.1⁶ (less than 2 sin(0.05) each time), and rounding.
        for (a, b) in z.iter().zip(exact) {
            assert!((a - b).abs() <= 1e-6 + 64.0 * f64::EPSILON, "{a} {b}");
        }
        let (fast, z) = run(steps, rotation(3.0));
        assert_eq!(fast.points, 1);
        assert_eq!(z, rotation(3.0)((steps - 1) as f64));
    }
}

#[test]
fn warms_up_through_the_points_it_has() {
    // z_n = (n², 3 − 2n²): no prediction after one solution (the caller's start stands), the
    // linear extrapolation after two, the quadratic (exact) after three, where the errors fell
    // with the degree (|∇z| = 3 ≥ |∇²z| = 2 at the third).
    let f = |n: f64| [n * n, 3.0 - 2.0 * n * n];
    let (p, z) = run(1, f);
    assert_eq!(p.points, 0);
    assert!(z.iter().all(|v| v.is_nan()));
    let (p, z) = run(2, f);
    assert_eq!(p.points, 2);
    assert_eq!(z, [2.0, -1.0]);
    let (p, z) = run(3, f);
    assert_eq!(p.points, 3);
    assert_eq!(z, f(3.0));
}

#[test]
fn forgets() {
    let (mut p, _) = run(5, |n| [n, -n]);
    p.forget();
    assert_eq!(p.points, 0);
    let mut z = [7.0, 8.0];
    p.predict(&mut z);
    assert_eq!(z, [7.0, 8.0]);
    p.record(&[1.0, 2.0]);
    p.record(&[2.0, 4.0]);
    p.predict(&mut z);
    assert_eq!(z, [3.0, 6.0]);
}

#[test]
fn never_extrapolates_through_an_overflow() {
    // The second entry's first difference overflows: every error from it on is not finite,
    // and the prediction is the last solution.
    let (p, z) = run(MAX_POINTS + 2, |n| {
        [
            n,
            if (n as usize).is_multiple_of(2) {
                f64::MAX
            } else {
                -f64::MAX
            },
        ]
    });
    assert_eq!(p.points, 1);
    assert_eq!(z, [(MAX_POINTS + 1) as f64, -f64::MAX]);
}
