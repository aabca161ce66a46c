//! The band LU against the dense LU on matrices that need row interchanges, and its typed
//! errors: a singular matrix names its pivot, an entry outside the band or the matrix is
//! reported, a solve before a factorization is `NotFactored`.

use lieflow::error::LinearSolveError;
use lieflow::linalg::{
    AutoLu, BandedLu, DenseLu, LinearSolver, Sink, SolverChoice, SolverKind, Structure,
};

/// A deterministic pseudo-random value in [-1, 1).
fn noise(i: usize, j: usize) -> f64 {
    let h =
        (i as u64).wrapping_mul(6364136223846793005) ^ (j as u64).wrapping_mul(1442695040888963407);
    let h = h ^ (h >> 29);
    (h % 2001) as f64 / 1000.0 - 1.0
}

/// A band matrix with a small diagonal (so partial pivoting must swap rows), as a closure.
fn entry(kl: usize, ku: usize) -> impl Fn(usize, usize) -> f64 {
    move |i, j| {
        if i > j + kl || j > i + ku {
            0.0
        } else if i == j {
            0.01 * noise(i, j)
        } else {
            noise(i, j)
        }
    }
}

/// `max |uᵢ − vᵢ|`: how far two solvers' solutions differ.
fn max_abs_diff(u: &[f64], v: &[f64]) -> f64 {
    u.iter()
        .zip(v)
        .fold(0.0f64, |m, (u, v)| m.max((u - v).abs()))
}

#[test]
fn banded_lu_matches_dense_lu() {
    for &(k, kl, ku) in &[
        (1, 0, 0),
        (2, 1, 1),
        (7, 1, 1),
        (1000, 1, 1),
        (50, 2, 1),
        (200, 1, 3),
        (300, 4, 4),
        (9, 8, 8),
    ] {
        let a = entry(kl, ku);
        let mut banded = BandedLu::<f64>::new(k, kl, ku);
        let mut dense = DenseLu::<f64>::with_dim(k).unwrap();
        for solver in [&mut banded as &mut dyn Sink<f64>, &mut dense] {
            for j in 0..k {
                for i in 0..k {
                    let v = a(i, j);
                    if v != 0.0 {
                        solver.add(i, j, v);
                    }
                }
            }
        }
        banded.factor().unwrap();
        dense.factor().unwrap();
        let b: Vec<f64> = (0..k).map(|i| noise(i, 7 * k)).collect();
        let (mut xb, mut xd) = (b.clone(), b.clone());
        banded.solve_in_place(&mut xb).unwrap();
        dense.solve_in_place(&mut xd).unwrap();
        // Residual of the band solution, relative to ‖A‖‖x‖ + ‖b‖: backward stable LU gives
        // a few k ε.
        let (mut res, mut norm_a, mut norm_x) = (0.0f64, 0.0f64, 0.0f64);
        for i in 0..k {
            let row: f64 = (0..k).map(|j| a(i, j) * xb[j]).sum();
            res = res.max((row - b[i]).abs());
            norm_a = norm_a.max((0..k).map(|j| a(i, j).abs()).sum());
            norm_x = norm_x.max(xb[i].abs());
        }
        let scale = norm_a * norm_x + 1.0;
        assert!(
            res <= 16.0 * k as f64 * f64::EPSILON * scale,
            "k {k}: residual {res:e}"
        );
        let diff = max_abs_diff(&xb, &xd);
        assert!(
            diff <= 1e-9 * (1.0 + norm_x),
            "k {k}: band and dense differ by {diff:e}"
        );
        // Refactoring after clear reuses the storage and gives the same answer.
        banded.clear();
        for j in 0..k {
            for i in 0..k {
                let v = a(i, j);
                if v != 0.0 {
                    banded.add(i, j, v);
                }
            }
        }
        banded.factor().unwrap();
        let mut again = b.clone();
        banded.solve_in_place(&mut again).unwrap();
        assert_eq!(again, xb);
    }
}

#[test]
fn banded_lu_errors_are_typed() {
    let mut lu = BandedLu::<f64>::new(4, 1, 1);
    let mut b = [1.0; 4];
    assert_eq!(
        lu.solve_in_place(&mut b),
        Err(LinearSolveError::NotFactored)
    );
    // Singular: the third row is twice the second.
    for (i, j, v) in [
        (0, 0, 1.0),
        (0, 1, 1.0),
        (1, 0, 0.0),
        (1, 1, 1.0),
        (1, 2, 1.0),
    ] {
        lu.add(i, j, v);
    }
    for (i, j, v) in [
        (2, 1, 2.0),
        (2, 2, 2.0),
        (2, 3, 0.0),
        (3, 2, 1.0),
        (3, 3, 1.0),
    ] {
        lu.add(i, j, v);
    }
    assert!(
        matches!(lu.factor(), Err(LinearSolveError::Singular { .. })),
        "a singular band matrix"
    );
    lu.clear();
    lu.add(0, 2, 1.0);
    assert_eq!(
        lu.factor(),
        Err(LinearSolveError::PatternIncomplete { row: 0, column: 2 })
    );
    lu.clear();
    lu.add(4, 0, 1.0);
    assert!(matches!(
        lu.factor(),
        Err(LinearSolveError::OutOfBounds { row: 4, .. })
    ));
    lu.clear();
    lu.add(0, 0, f64::NAN);
    assert!(matches!(
        lu.factor(),
        Err(LinearSolveError::NonFinite { row: 0, col: 0 })
    ));
}

#[test]
fn auto_picks_the_band_solver_for_narrow_bands_and_diagonals() {
    let auto = |k, structure| AutoLu::<f64>::auto_kind(k, structure);
    let band = |lower, upper| Structure::Banded {
        lower,
        upper,
        nnz: 1000 * (lower + upper + 1),
    };
    assert_eq!(auto(1000, band(1, 1)), SolverKind::Banded);
    assert_eq!(auto(1000, band(0, 0)), SolverKind::Banded);
    assert_eq!(auto(1000, band(8, 8)), SolverKind::Banded);
    // Wider bands: sparse LU (its ordering may do better than the band).
    assert_eq!(auto(1000, band(9, 1)), SolverKind::Sparse);
    // Small systems: the stack or dense solver.
    assert_eq!(auto(8, band(1, 1)), SolverKind::Stack);
    // Below 64 unknowns the band solver takes bands at most a quarter as wide as k.
    assert_eq!(auto(50, band(1, 1)), SolverKind::Banded);
    assert_eq!(auto(12, band(1, 1)), SolverKind::Banded);
    assert_eq!(auto(11, band(1, 1)), SolverKind::Stack);
    assert_eq!(auto(17, band(2, 2)), SolverKind::Dense);
    assert_eq!(auto(50, band(8, 8)), SolverKind::Dense);
    // A diagonal at any size above the stack's: k divisions, not a dense LU.
    assert_eq!(auto(10, band(0, 0)), SolverKind::Banded);
    assert_eq!(auto(9, band(0, 0)), SolverKind::Banded);
    let pattern = [(0, 0), (1, 0), (0, 1), (5, 2)];
    assert_eq!(
        Structure::of_pattern(&pattern),
        Structure::Banded {
            lower: 3,
            upper: 1,
            nnz: 4
        }
    );
    let forced =
        AutoLu::<f64>::with_structure(100, band(1, 1), SolverChoice::Force(SolverKind::Banded))
            .unwrap();
    assert_eq!(forced.kind(), SolverKind::Banded);
}

/// A chain's reduced Newton matrix `[[A, C], [G, 0]]` in block order — `n` bodies of two
/// coordinates, rod `a` between bodies `a − 1` and `a` — has a band as wide as the chain, and
/// `AutoLu` built from its pattern renumbers it into a narrow band: same solution as dense LU
/// (the `[G, 0]` rows need pivoting), and a singular matrix is a typed error.
#[test]
fn auto_renumbers_a_chain_in_block_order_into_a_band() {
    let n = 60;
    let (nq, k) = (2 * n, 3 * n);
    let mut entries: Vec<(usize, usize, f64)> = Vec::new();
    for i in 0..nq {
        entries.push((i, i, 1.0 + 0.1 * noise(i, i)));
    }
    for a in 0..n {
        for b in [a.wrapping_sub(1), a] {
            if b >= n {
                continue;
            }
            for c in 0..2 {
                let (q, row) = (2 * b + c, nq + a);
                entries.push((row, q, noise(row, q)));
                entries.push((q, row, noise(q, row)));
                // Curvature: the positions a rod couples.
                for c2 in 0..2 {
                    let other = 2 * a.wrapping_sub(1).min(a) + c2;
                    if other < nq && other != q {
                        entries.push((q, other, 0.05 * noise(q, other)));
                    }
                }
            }
        }
    }
    let pattern: Vec<(usize, usize)> = entries.iter().map(|&(r, c, _)| (r, c)).collect();
    assert!(matches!(
        Structure::of_pattern(&pattern),
        Structure::Banded { lower, .. } if lower >= n
    ));
    let mut auto = AutoLu::<f64>::with_pattern(k, &pattern, SolverChoice::Auto).unwrap();
    assert!(matches!(auto, AutoLu::Reordered(_)), "{:?}", auto.kind());
    let mut dense = DenseLu::<f64>::with_dim(k).unwrap();
    for &(r, c, v) in &entries {
        auto.add(r, c, v);
        dense.add(r, c, v);
    }
    auto.factor().unwrap();
    dense.factor().unwrap();
    let b: Vec<f64> = (0..k).map(|i| noise(i, 3 * k)).collect();
    let (mut xa, mut xd) = (b.clone(), b.clone());
    auto.solve_in_place(&mut xa).unwrap();
    dense.solve_in_place(&mut xd).unwrap();
    let scale = 1.0 + xd.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let diff = max_abs_diff(&xa, &xd);
    // Both backward stable: they agree to the conditioning times a few k ε.
    assert!(
        diff <= 1e-10 * scale,
        "renumbered band and dense differ by {diff:e}"
    );
    // A rod whose row is all zero: singular.
    auto.clear();
    for &(r, c, v) in &entries {
        auto.add(r, c, if r == nq + 7 { 0.0 } else { v });
    }
    match auto.factor() {
        Err(LinearSolveError::Singular { .. }) => {}
        other => panic!("expected a singular matrix, got {other:?}"),
    }
}
