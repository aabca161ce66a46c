//! Newton on small problems with known roots: every Jacobian policy converges, a residual whose
//! round-off floor lies above `ftol` still converges, and failure is reported with numbers.

use lieflow::error::{NewtonError, StepError};
use lieflow::nonlinear::{
    JacobianUpdate, Newton, NewtonOptions, NonlinearProblem, NonlinearSolver,
};
use nalgebra::SVector;

/// `F(z) = s (z₁² + z₂² − 4, z₁ − z₂)`: root `(√2, √2)`; `s` scales the round-off floor.
struct Circle {
    s: f64,
}

impl NonlinearProblem<f64> for Circle {
    type Error = StepError;
    fn dim(&self) -> usize {
        2
    }
    fn residual(&mut self, z: &[f64], f: &mut [f64]) -> Result<(), StepError> {
        f[0] = self.s * (z[0] * z[0] + z[1] * z[1] - 4.0);
        f[1] = self.s * (z[0] - z[1]);
        Ok(())
    }
}

type V = SVector<f64, 4>;

fn solve(policy: JacobianUpdate, s: f64) -> (Vec<f64>, lieflow::nonlinear::SolveReport<f64>) {
    let mut newton: Newton<V> =
        Newton::new(2, NewtonOptions::default().with_jacobian(policy)).unwrap();
    let mut z = [1.0, 2.0];
    let report = newton.solve(&mut Circle { s }, &mut z).unwrap();
    (z.to_vec(), report)
}

#[test]
fn every_policy_finds_the_root_to_round_off() {
    let r = 2f64.sqrt();
    for policy in [
        JacobianUpdate::EveryIteration,
        JacobianUpdate::OncePerSolve,
        JacobianUpdate::Reuse,
    ] {
        let (z, report) = solve(policy, 1.0);
        assert!(
            (z[0] - r).abs() < 4e-16 && (z[1] - r).abs() < 4e-16,
            "{policy:?}: {z:?}"
        );
        // Round-off floor of z₁² + z₂² − 4 at the root: one ulp of 4, i.e. 4ε.
        assert!(
            report.residual <= 4.0 * f64::EPSILON,
            "{policy:?}: {report:?}"
        );
        assert!(report.iterations <= 25);
    }
    // Full Newton converges quadratically: few iterations from (1, 2).
    assert!(solve(JacobianUpdate::EveryIteration, 1.0).1.iterations <= 6);
}

#[test]
fn a_residual_with_a_round_off_floor_above_ftol_converges() {
    // With s = 10 the round-off floor of F near the root is s · ulp(4) = 40 ε ≈ 8.9e-15: above
    // ftol = 2ε, below the 100 ftol up to which Newton recognizes a floor.
    let (z, report) = solve(JacobianUpdate::Reuse, 10.0);
    assert!((z[0] - 2f64.sqrt()).abs() < 1e-15, "{z:?}");
    assert!(report.residual <= 40.0 * f64::EPSILON, "{report:?}");
}

#[test]
fn a_kept_jacobian_that_reaches_the_floor_is_not_rebuilt() {
    // The second solve starts next to the root with the first solve's Jacobian: its updates
    // fall to the round-off of z while the residual sits at its floor (40 ε, above ftol), which
    // is convergence; rebuilding the Jacobian there (one factorization) would learn nothing.
    let mut newton: Newton<V> = Newton::new(
        2,
        NewtonOptions::default().with_jacobian(JacobianUpdate::Reuse),
    )
    .unwrap();
    let mut z = [1.0, 2.0];
    newton.solve(&mut Circle { s: 10.0 }, &mut z).unwrap();
    let mut z = [z[0] + 1e-7, z[1] - 2e-7];
    let report = newton.solve(&mut Circle { s: 10.0 }, &mut z).unwrap();
    assert_eq!(report.factorizations, 0, "{report:?}");
    assert!((z[0] - 2f64.sqrt()).abs() < 1e-15, "{z:?}");
    assert!(report.residual <= 40.0 * f64::EPSILON, "{report:?}");
}

#[test]
fn a_floor_far_above_ftol_is_reported_not_hidden() {
    // s = 1e4: floor 4e4 ε ≈ 8.9e-12 = 4e4 ftol. ftol is absolute; Newton must say it did not
    // reach it rather than accept the floor silently.
    let mut newton: Newton<V> = Newton::new(2, NewtonOptions::default()).unwrap();
    let mut z = [1.0, 2.0];
    match newton.solve(&mut Circle { s: 1e4 }, &mut z) {
        Err(NewtonError::NotConverged { residual, .. }) => {
            assert!(
                residual > 2.0 * f64::EPSILON && residual < 1e-10,
                "{residual:e}"
            )
        }
        other => panic!("unexpected {other:?}"),
    }
    // With ftol scaled to the residual's units it converges.
    let mut newton: Newton<V> = Newton::new(
        2,
        NewtonOptions::default().with_ftol(1e4 * 8.0 * f64::EPSILON),
    )
    .unwrap();
    let mut z = [1.0, 2.0];
    newton.solve(&mut Circle { s: 1e4 }, &mut z).unwrap();
    assert!((z[0] - 2f64.sqrt()).abs() < 1e-15);
}

#[test]
fn a_problem_without_root_fails_with_numbers() {
    struct NoRoot;
    impl NonlinearProblem<f64> for NoRoot {
        type Error = StepError;
        fn dim(&self) -> usize {
            1
        }
        fn residual(&mut self, z: &[f64], f: &mut [f64]) -> Result<(), StepError> {
            f[0] = z[0] * z[0] + 1.0;
            Ok(())
        }
    }
    let mut newton: Newton<V> = Newton::new(1, NewtonOptions::default()).unwrap();
    let mut z = [0.5];
    match newton.solve(&mut NoRoot, &mut z) {
        Err(NewtonError::NotConverged {
            iterations,
            residual,
        }) => {
            assert_eq!(iterations, 25);
            assert!(residual >= 1.0);
        }
        Err(NewtonError::Linear(_)) => {} // a zero derivative at z = 0 is also a clean failure
        other => panic!("unexpected {other:?}"),
    }
}

/// `F(z) = (s (z₁ + z₂ − 2), z₁ + 2 z₂ − 3)`, root `(1, 1)`: with `s = 1e18` the rows differ by
/// eighteen orders, so the Newton matrix's second pivot is `1e-18` of the first — below the
/// singularity threshold `k ε` — unless its rows are equilibrated.
struct Lopsided;

impl NonlinearProblem<f64> for Lopsided {
    type Error = StepError;
    fn dim(&self) -> usize {
        2
    }
    fn residual(&mut self, z: &[f64], f: &mut [f64]) -> Result<(), StepError> {
        f[0] = 1e18 * (z[0] + z[1] - 2.0);
        f[1] = z[0] + 2.0 * z[1] - 3.0;
        Ok(())
    }
    fn jacobian_column(&mut self, _z: &[f64], j: usize, col: &mut [f64]) -> bool {
        col[0] = 1e18;
        col[1] = if j == 0 { 1.0 } else { 2.0 };
        true
    }
}

#[test]
fn equilibrated_rows_keep_a_lopsided_system_regular() {
    // Row 1's residual rounds at 1e18 ε ≈ 2e2: converge on the update instead.
    let mut options = NewtonOptions::default();
    options.rtol = 1e-12;
    let mut plain: Newton<V> = Newton::new(2, options).unwrap();
    let mut z = [0.0, 0.0];
    let e = plain.solve(&mut Lopsided, &mut z).unwrap_err();
    assert!(format!("{e}").contains("singular"), "{e}");
    options.equilibrate = true;
    let mut scaled: Newton<V> = Newton::new(2, options).unwrap();
    let mut z = [0.0, 0.0];
    scaled.solve(&mut Lopsided, &mut z).unwrap();
    assert!(
        (z[0] - 1.0).abs() < 1e-12 && (z[1] - 1.0).abs() < 1e-12,
        "{z:?}"
    );
}

/// Twelve independent cubics `a_i (z_i³ + z_i − c_i)`, a diagonal Jacobian.
struct Independent {
    a: Vec<f64>,
    c: Vec<f64>,
}

impl NonlinearProblem<f64> for Independent {
    type Error = StepError;
    fn dim(&self) -> usize {
        self.a.len()
    }
    fn residual(&mut self, z: &[f64], f: &mut [f64]) -> Result<(), StepError> {
        for i in 0..self.a.len() {
            f[i] = self.a[i] * (z[i] * z[i] * z[i] + z[i] - self.c[i]);
        }
        Ok(())
    }
}

#[test]
fn a_diagonal_kept_jacobian_takes_secant_updates() {
    use faer::Col;
    let k = 12;
    let pattern: Vec<(usize, usize)> = (0..k).map(|i| (i, i)).collect();
    let run = |broyden: bool| {
        let mut options = NewtonOptions::default();
        options.broyden = broyden;
        let mut newton: Newton<Col<f64>> =
            Newton::with_pattern(k, options, Some(&pattern)).unwrap();
        let mut z = vec![1.0; k];
        let (mut iterations, mut solutions) = (0, Vec::new());
        // A sequence of solves whose roots move, each from the last root, as a time stepper
        // calls it: the Jacobian is kept between them.
        for step in 0..40 {
            let t = step as f64 * 0.05;
            let mut p = Independent {
                a: (0..k).map(|i| 1.0 + i as f64).collect(),
                c: (0..k).map(|i| 2.0 + (t + 0.3 * i as f64).sin()).collect(),
            };
            let report = newton.solve(&mut p, &mut z).unwrap();
            iterations += report.iterations;
            let mut f = vec![0.0; k];
            p.residual(&z, &mut f).unwrap();
            assert!(f.iter().all(|v| v.abs() <= 1e-13), "{f:?}");
            solutions.push(z.clone());
        }
        (iterations, solutions)
    };
    let (with, a) = run(true);
    let (without, b) = run(false);
    // The same roots; the secant slopes make the kept matrix converge in fewer iterations.
    for (x, y) in a.iter().zip(&b) {
        for (u, v) in x.iter().zip(y) {
            assert!((u - v).abs() <= 1e-13, "{u} vs {v}");
        }
    }
    assert!(
        with < without,
        "{with} iterations with secant updates, {without} without"
    );
}
