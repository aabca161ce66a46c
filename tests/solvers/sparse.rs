//! The sparse backend: agreement with the dense LU, the recorded assembly pattern, typed
//! singularity errors, automatic backend choice, and Newton with grouped (colored) differences.

use faer::Col;
use lieflow::LinearSolveError;
use lieflow::linalg::{
    AutoLu, DenseLu, LinearSolver, Sink, SolverChoice, SolverKind, SparseLu, Structure,
};
use lieflow::nonlinear::{Newton, NewtonOptions, NonlinearProblem, NonlinearSolver};
use lieflow::prelude::StepError;

/// A non-symmetric sparse test matrix: a diagonally dominant tridiagonal band plus a long-range
/// entry per row, with a deterministic pseudo-random perturbation `s`.
fn entries(k: usize, s: f64) -> Vec<(usize, usize, f64)> {
    let mut e = Vec::new();
    for i in 0..k {
        let w = ((i * 7919) % 13) as f64 / 13.0;
        e.push((i, i, 4.0 + w + s));
        if i > 0 {
            e.push((i, i - 1, -1.0 - 0.3 * w));
        }
        if i + 1 < k {
            e.push((i, i + 1, -1.2 + s * w));
        }
        e.push((i, (i * 31 + 5) % k, 0.25 * w));
    }
    e
}

fn assemble<S: LinearSolver<f64>>(lin: &mut S, e: &[(usize, usize, f64)]) {
    lin.clear();
    for &(r, c, v) in e {
        lin.add(r, c, v);
    }
}

#[test]
fn sparse_and_dense_lu_agree_and_refactor_with_new_values() {
    let k = 300;
    let mut sparse = SparseLu::<f64>::with_dim(k).unwrap();
    let mut dense = DenseLu::<f64>::with_dim(k).unwrap();
    for s in [0.0, 0.5, -0.3] {
        let e = entries(k, s);
        assemble(&mut sparse, &e);
        assemble(&mut dense, &e);
        sparse.factor().unwrap();
        dense.factor().unwrap();
        let b: Vec<f64> = (0..k).map(|i| (i as f64 * 0.37).sin()).collect();
        let (mut xs, mut xd) = (b.clone(), b.clone());
        sparse.solve_in_place(&mut xs).unwrap();
        dense.solve_in_place(&mut xd).unwrap();
        let diff = xs
            .iter()
            .zip(&xd)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        // Both backward stable; the matrix is well conditioned (diagonally dominant), so the
        // solutions agree to a small multiple of ε.
        assert!(
            diff <= 1e-13,
            "s = {s}: sparse and dense differ by {diff:e}"
        );
        // The residual of the sparse solution.
        let mut res = b.clone();
        for &(r, c, v) in &e {
            res[r] -= v * xs[c];
        }
        let r = res.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(r <= 1e-14, "residual {r:e}");
    }
    // Duplicates are summed into one stored entry.
    assert_eq!(
        sparse.nnz(),
        Some({
            let mut p: Vec<_> = entries(k, 0.0).iter().map(|&(r, c, _)| (r, c)).collect();
            p.sort_unstable();
            p.dedup();
            p.len()
        })
    );
}

/// Records the pattern of a 50 × 50 matrix, factors it, then assembles it again with an entry
/// outside the pattern (a debug build stops there, at the assertion).
fn assemble_outside_the_pattern() -> SparseLu<f64> {
    let k = 50;
    let mut lin = SparseLu::<f64>::with_dim(k).unwrap();
    let mut e = entries(k, 0.0);
    assemble(&mut lin, &e);
    lin.factor().unwrap();
    assert!(!e.iter().any(|&(r, c, _)| (r, c) == (0, 40)));
    e[3] = (0, 40, 1.0);
    assemble(&mut lin, &e);
    lin
}

/// The pattern's entries in another order (a Jacobian summed by its problem once, grouped by
/// colours another time) land where they belong: the same solution to rounding (the sums of
/// repeated entries may be taken in another order).
#[test]
fn the_pattern_in_another_order_solves_the_same_system() {
    let k = 50;
    let e = entries(k, 0.0);
    let mut lin = SparseLu::<f64>::with_dim(k).unwrap();
    assemble(&mut lin, &e);
    lin.factor().unwrap();
    let rhs: Vec<f64> = (0..k).map(|i| (i as f64 * 0.37).sin()).collect();
    let mut x = rhs.clone();
    lin.solve_in_place(&mut x).unwrap();
    let mut reversed = e.clone();
    reversed.reverse();
    assemble(&mut lin, &reversed);
    lin.factor().unwrap();
    let mut y = rhs.clone();
    lin.solve_in_place(&mut y).unwrap();
    let diff = x
        .iter()
        .zip(&y)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(diff <= 64.0 * f64::EPSILON, "{diff:e}");
    // And back in the recorded order.
    assemble(&mut lin, &e);
    lin.factor().unwrap();
}

#[test]
#[cfg(not(debug_assertions))]
fn an_entry_outside_the_pattern_is_a_typed_error() {
    let mut lin = assemble_outside_the_pattern();
    let err = lin.factor().unwrap_err();
    assert!(
        matches!(
            err,
            LinearSolveError::PatternChanged {
                entry: 3,
                got: Some((0, 40)),
                ..
            }
        ),
        "{err}"
    );
    // An assembly that stops early is caught too.
    let e = entries(50, 0.0);
    assemble(&mut lin, &e[..e.len() - 1]);
    assert!(matches!(
        lin.factor(),
        Err(LinearSolveError::PatternChanged { got: None, .. })
    ));
    // The original order works again.
    assemble(&mut lin, &e);
    lin.factor().unwrap();
}

#[test]
#[cfg(debug_assertions)]
#[should_panic(expected = "changed its pattern")]
fn an_entry_outside_the_pattern_trips_the_debug_assertion() {
    assemble_outside_the_pattern();
}

#[test]
fn singular_matrices_are_typed_errors_naming_the_column() {
    let k = 100;
    // Column 40 equals column 39: numerically singular (a redundant unknown).
    let mut e: Vec<(usize, usize, f64)> = Vec::new();
    for i in 0..k {
        e.push((i, i, 3.0 + (i % 5) as f64));
        if i > 0 {
            e.push((i, i - 1, 1.0));
        }
    }
    let col39: Vec<(usize, f64)> = e.iter().filter(|t| t.1 == 39).map(|t| (t.0, t.2)).collect();
    e.retain(|t| t.1 != 40);
    for (r, v) in col39 {
        e.push((r, 40, v));
    }
    e.push((40, 40, 0.0)); // keep the diagonal structurally present
    let mut lin = SparseLu::<f64>::with_dim(k).unwrap();
    assemble(&mut lin, &e);
    match lin.factor() {
        Err(LinearSolveError::Singular { pivot, ratio, .. }) => {
            assert!(pivot == 39 || pivot == 40, "named column {pivot}");
            assert!(ratio <= 1e-14);
        }
        other => panic!("expected a singular matrix error, got {other:?}"),
    }
    // A column without entries: structurally singular.
    let mut lin = SparseLu::<f64>::with_dim(3).unwrap();
    for (r, c) in [(0, 0), (1, 0), (2, 2), (1, 2)] {
        lin.add(r, c, 1.0);
    }
    assert!(matches!(
        lin.factor(),
        Err(LinearSolveError::StructurallySingular { .. })
    ));
    // Entries outside the matrix and non-finite values are typed too.
    let mut lin = SparseLu::<f64>::with_dim(3).unwrap();
    lin.add(3, 0, 1.0);
    assert!(matches!(
        lin.factor(),
        Err(LinearSolveError::OutOfBounds { row: 3, .. })
    ));
    let mut lin = SparseLu::<f64>::with_dim(2).unwrap();
    for (r, c, v) in [(0, 0, 1.0), (1, 1, f64::NAN)] {
        lin.add(r, c, v);
    }
    assert!(matches!(
        lin.factor(),
        Err(LinearSolveError::NonFinite { row: 1, col: 1 })
    ));
    let mut lin = DenseLu::<f64>::with_dim(2).unwrap();
    lin.add(0, 5, 1.0);
    assert!(matches!(
        lin.factor(),
        Err(LinearSolveError::OutOfBounds { col: 5, .. })
    ));
}

#[test]
fn auto_choice_follows_size_and_sparsity_and_can_be_forced() {
    let auto = |k, s| {
        AutoLu::<f64>::with_structure(k, s, SolverChoice::Auto)
            .unwrap()
            .kind()
    };
    assert_eq!(auto(3, Structure::Dense), SolverKind::Stack);
    assert_eq!(auto(50, Structure::Sparse { nnz: 148 }), SolverKind::Dense);
    assert_eq!(
        auto(1000, Structure::Sparse { nnz: 2998 }),
        SolverKind::Sparse
    );
    assert_eq!(auto(1000, Structure::Dense), SolverKind::Dense);
    assert_eq!(
        auto(1000, Structure::Sparse { nnz: 200_000 }),
        SolverKind::Dense
    );
    let forced =
        AutoLu::<f64>::with_structure(5, Structure::Dense, SolverChoice::Force(SolverKind::Sparse))
            .unwrap();
    assert_eq!(forced.kind(), SolverKind::Sparse);
    assert!(matches!(
        AutoLu::<f64>::with_structure(20, Structure::Dense, SolverChoice::Force(SolverKind::Stack)),
        Err(LinearSolveError::TooLarge { .. })
    ));
}

/// `F_i(z) = z_i³ + 3 z_i − (z_{i−1} + z_{i+1}) e^{z_i/10} − b_i`: a nonlinear tridiagonal system.
struct Tridiagonal {
    k: usize,
}

impl NonlinearProblem<f64> for Tridiagonal {
    type Error = StepError;
    fn dim(&self) -> usize {
        self.k
    }
    fn residual(&mut self, z: &[f64], f: &mut [f64]) -> Result<(), StepError> {
        let k = self.k;
        for i in 0..k {
            let l = if i > 0 { z[i - 1] } else { 0.0 };
            let r = if i + 1 < k { z[i + 1] } else { 0.0 };
            let b = 1.0 + (i as f64 * 0.1).sin();
            f[i] = z[i] * z[i] * z[i] + 3.0 * z[i] - (l + r) * (z[i] / 10.0).exp() - b;
        }
        Ok(())
    }
}

fn tridiagonal_pattern(k: usize) -> Vec<(usize, usize)> {
    let mut p = Vec::new();
    for i in 0..k {
        for j in i.saturating_sub(1)..(i + 2).min(k) {
            p.push((i, j));
        }
    }
    p
}

#[test]
fn newton_with_grouped_differences_matches_dense_newton() {
    let k = 400;
    let options = NewtonOptions::default();
    let mut dense: Newton<Col<f64>, DenseLu<f64>> = Newton::new(k, options).unwrap();
    let pattern = tridiagonal_pattern(k);
    let mut sparse: Newton<Col<f64>, SparseLu<f64>> =
        Newton::with_pattern(k, options, Some(&pattern)).unwrap();
    // Three groups for a tridiagonal pattern, independent of k.
    assert_eq!(sparse.evaluations_per_jacobian(), 3);
    let mut auto: Newton<Col<f64>, AutoLu<f64>> =
        Newton::with_pattern(k, options, Some(&pattern)).unwrap();
    // A tridiagonal pattern: the band solver.
    assert_eq!(auto.linear_solver().kind(), SolverKind::Banded);
    let (mut zd, mut zs, mut za) = (vec![0.0; k], vec![0.0; k], vec![0.0; k]);
    let rd = dense.solve(&mut Tridiagonal { k }, &mut zd).unwrap();
    let rs = sparse.solve(&mut Tridiagonal { k }, &mut zs).unwrap();
    let ra = auto.solve(&mut Tridiagonal { k }, &mut za).unwrap();
    assert_eq!(ra.iterations, rs.iterations);
    println!("dense {rd:?}\nsparse {rs:?}");
    let diff = zd
        .iter()
        .zip(&zs)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    assert!(diff <= 1e-14, "dense and grouped Newton differ by {diff:e}");
    // Auto picks the band solver for this tridiagonal pattern: the same iterations, the same
    // root to round-off (a different elimination order).
    let diff_auto = zs
        .iter()
        .zip(&za)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    assert!(
        diff_auto <= 1e-14,
        "sparse and banded Newton differ by {diff_auto:e}"
    );
    assert!(rs.residual <= 2.0 * f64::EPSILON * 100.0);
    // The grouped Jacobian costs 3 evaluations instead of k.
    assert!(
        rs.residual_evaluations <= rd.residual_evaluations / 20,
        "{} vs {}",
        rs.residual_evaluations,
        rd.residual_evaluations
    );
}

#[test]
fn damped_newton_recovers_where_full_steps_overshoot() {
    // F(z) = atan(z): full Newton steps from |z₀| > 1.39 diverge.
    struct Atan;
    impl NonlinearProblem<f64> for Atan {
        type Error = StepError;
        fn dim(&self) -> usize {
            1
        }
        fn residual(&mut self, z: &[f64], f: &mut [f64]) -> Result<(), StepError> {
            f[0] = z[0].atan();
            Ok(())
        }
    }
    let full = NewtonOptions::default()
        .with_max_halvings(0)
        .with_jacobian(lieflow::nonlinear::JacobianUpdate::EveryIteration);
    let mut n: Newton<Col<f64>> = Newton::new(1, full).unwrap();
    assert!(n.solve(&mut Atan, &mut [3.0]).is_err());
    let mut n: Newton<Col<f64>> = Newton::new(1, full.with_max_halvings(8)).unwrap();
    let mut z = [3.0];
    let report = n.solve(&mut Atan, &mut z).unwrap();
    assert!(z[0].abs() <= 1e-15, "{z:?}");
    assert!(report.halvings > 0);
}

#[test]
fn scaled_update_tolerance_stops_early() {
    let k = 50;
    // Full Newton, so that an update of size δ leaves an error of order δ².
    let full =
        NewtonOptions::default().with_jacobian(lieflow::nonlinear::JacobianUpdate::EveryIteration);
    let options = full.with_update_tol(1e-6, 1e-6);
    let mut n: Newton<Col<f64>> = Newton::new(k, options).unwrap();
    let mut z = vec![0.0; k];
    let loose = n.solve(&mut Tridiagonal { k }, &mut z).unwrap();
    let mut n: Newton<Col<f64>> = Newton::new(k, full).unwrap();
    let mut zt = vec![0.0; k];
    let tight = n.solve(&mut Tridiagonal { k }, &mut zt).unwrap();
    assert!(loose.iterations < tight.iterations, "{loose:?} {tight:?}");
    // Quadratic convergence: an update below 1e-6 leaves an error of order 1e-12.
    let err = z
        .iter()
        .zip(&zt)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    assert!(err <= 1e-9, "{err:e}");
}

/// A closed-form Jacobian with an entry outside the declared pattern, in a row its column group
/// does not cover, is a typed error (grouped columns would add it to another entry). An entry in
/// a covered row cannot be told apart; Newton then converges slowly or reports NotConverged.
#[test]
fn a_closed_form_jacobian_outside_the_pattern_is_a_typed_error() {
    /// `F_i = 2 z_i + z_{i+2} − 1`: upper "skip-one" coupling.
    struct Skip;
    const K: usize = 5;
    impl NonlinearProblem<f64> for Skip {
        type Error = StepError;
        fn dim(&self) -> usize {
            K
        }
        fn residual(&mut self, z: &[f64], f: &mut [f64]) -> Result<(), StepError> {
            for i in 0..K {
                let r = if i + 2 < K { z[i + 2] } else { 0.0 };
                f[i] = 2.0 * z[i] + r - 1.0;
            }
            Ok(())
        }
        fn jacobian_group(&mut self, _z: &[f64], cols: &[usize], out: &mut [f64]) -> bool {
            out.iter_mut().for_each(|v| *v = 0.0);
            for &j in cols {
                out[j] += 2.0;
                if j >= 2 {
                    out[j - 2] += 1.0;
                }
            }
            true
        }
    }
    // Declared tridiagonal: column 2's group covers rows 1..=3, but F_0 depends on z_2.
    let mut n: Newton<Col<f64>, SparseLu<f64>> =
        Newton::with_pattern(K, NewtonOptions::default(), Some(&tridiagonal_pattern(K))).unwrap();
    let err = n.solve(&mut Skip, &mut [0.0; K]).unwrap_err();
    assert!(
        matches!(
            err,
            lieflow::NewtonError::Linear(LinearSolveError::PatternIncomplete { row: 0, .. })
        ),
        "{err}"
    );
    // With the true pattern it solves in one step.
    let pattern: Vec<(usize, usize)> = (0..K)
        .flat_map(|i| [(i, i), (i, (i + 2).min(K - 1))])
        .collect();
    let mut n: Newton<Col<f64>, SparseLu<f64>> =
        Newton::with_pattern(K, NewtonOptions::default(), Some(&pattern)).unwrap();
    let mut z = [0.0; K];
    let report = n.solve(&mut Skip, &mut z).unwrap();
    assert_eq!(report.iterations, 1);
    let mut f = [0.0; K];
    Skip.residual(&z, &mut f).unwrap();
    assert!(f.iter().all(|v| v.abs() <= 1e-15), "{f:?}");
}

/// The dense LU's solves on both sides of the size where its substitutions switch from plain
/// loops to faer's blocked kernels: a matrix with a small diagonal (every column pivots) is
/// solved to the residual of a backward-stable LU, `‖b − A x‖∞ ≤ 4 k ε ‖A‖∞ ‖x‖∞`.
#[test]
fn dense_lu_pivots_and_solves_at_every_size() {
    for k in [1, 2, 5, 40, 96, 97, 150] {
        let a = |r: usize, c: usize| {
            let v = (((r * 7919 + c * 104_729) % 1000) as f64 / 500.0) - 1.0;
            if r == c { 1e-3 * v } else { v }
        };
        let mut dense = DenseLu::<f64>::with_dim(k).unwrap();
        dense.clear();
        for r in 0..k {
            for c in 0..k {
                dense.add(r, c, a(r, c));
            }
        }
        dense.factor().unwrap();
        let b: Vec<f64> = (0..k).map(|i| (i as f64 * 0.37).cos()).collect();
        let mut x = b.clone();
        dense.solve_in_place(&mut x).unwrap();
        let norm_a = (0..k)
            .map(|r| (0..k).map(|c| a(r, c).abs()).sum::<f64>())
            .fold(0.0, f64::max);
        let norm_x = x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let res = (0..k)
            .map(|r| (b[r] - (0..k).map(|c| a(r, c) * x[c]).sum::<f64>()).abs())
            .fold(0.0, f64::max);
        let bound = 4.0 * k as f64 * f64::EPSILON * norm_a * norm_x;
        assert!(res <= bound, "k = {k}: residual {res:e} > {bound:e}");
    }
}
