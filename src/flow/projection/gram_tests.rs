//! The sums of [`Gram`] against `G(y) W⁻¹ G(x)ᵀ` formed densely from products with `G`, on the
//! rows of two bodies on a hinge (quadratic rows sharing directors, a centre row, a body's
//! rows sharing nothing with the other's).

use super::{Gram, Right};
use crate::linalg::Triplets;
use crate::rigid::BodyRef;
use crate::rigid::{Hinge, Inertia, Multibody, RigidBody};
use crate::system::HolonomicConstraint;
use faer::Col;

fn model() -> Multibody {
    let mut model = Multibody::new([0.0, 0.0, -9.81]);
    let inertia = Inertia::solid_box(1.0, [1.0, 0.1, 0.2]).unwrap();
    let a = model
        .add_rigid(RigidBody::at_rest(1.0, inertia, [0.5, 0.0, 0.0]))
        .unwrap();
    let b = model
        .add_rigid(RigidBody::at_rest(2.0, inertia, [1.5, 0.0, 0.0]))
        .unwrap();
    model
        .add_joint(&Hinge {
            a: BodyRef::Body(b),
            anchor_a: [-0.5, 0.0, 0.0],
            axis_a: [0.0, 1.0, 0.0],
            b: BodyRef::Body(a),
            anchor_b: [0.5, 0.0, 0.0],
            axis_b: [0.0, 1.0, 0.0],
        })
        .unwrap();
    model
}

/// The model, its initial state `x` and another configuration `y`: every director perturbed
/// (the rows need not hold for the sums).
fn points() -> (Multibody, Col<f64>, Col<f64>) {
    let model = model();
    let x: Col<f64> = model.initial_state();
    let y = Col::<f64>::from_fn(x.nrows(), |i| x[i] + 0.01 * ((i * 7 % 11) as f64 - 5.0));
    (model, x, y)
}

/// `G(a) diag(w) G(b)ᵀ`, column by column from `G(b)ᵀ e_j` and products with `G(a)`.
fn dense(
    c: &impl HolonomicConstraint<Col<f64>>,
    a: &Col<f64>,
    b: &Col<f64>,
    w: &[f64],
) -> Vec<Vec<f64>> {
    let (m, n) = (HolonomicConstraint::<Col<f64>>::dim(c), a.nrows());
    let mut out = vec![vec![0.0; m]; m];
    for j in 0..m {
        let mut e = vec![0.0; m];
        e[j] = 1.0;
        let mut gt = Col::<f64>::zeros(n);
        c.jacobian_transpose_apply(b, &e, &mut gt);
        for (i, wi) in w.iter().enumerate() {
            gt[i] *= wi;
        }
        for i in w.len()..n {
            gt[i] = 0.0;
        }
        let mut col = vec![0.0; m];
        c.jacobian_apply(a, &gt, &mut col);
        for i in 0..m {
            out[i][j] = col[i];
        }
    }
    out
}

#[test]
fn the_sums_are_the_products_with_g() {
    let (model, x, y) = points();
    let nq = x.nrows() / 2;
    let w: Vec<f64> = (0..nq).map(|i| 0.5 + (i % 5) as f64).collect();
    let c = model.quadratic_rows::<f64>();
    let mut gram = Gram::new(&c, &x, nq).expect("the rows list their entries");
    assert!(gram.fill(&c, &y, true, &w) && gram.fill(&c, &x, false, &w));
    for (right, b) in [(Right::AtX, &x), (Right::AtY, &y)] {
        let mut sums = Triplets::default();
        gram.add_to(-0.5, right, &mut sums);
        let m = HolonomicConstraint::<Col<f64>>::dim(&c);
        let mut got = vec![vec![0.0; m]; m];
        for (i, j, v) in sums.entries {
            got[i][j] += v;
        }
        let want = dense(&c, &y, b, &w);
        let scale = want.iter().flatten().fold(0.0f64, |s, v| s.max(v.abs()));
        for i in 0..m {
            for j in 0..m {
                let d = (got[i][j] + 0.5 * want[i][j]).abs();
                assert!(
                    d <= 16.0 * f64::EPSILON * scale,
                    "{right:?} ({i}, {j}): {d:e}"
                );
            }
        }
    }
}

/// The stack solver's dense storage receives the same sums as a sink of entries, and the
/// passes over the values give `Gᵀa` and `G W⁻¹ p` as the constraint's own products do.
#[test]
fn the_dense_sums_and_the_passes_over_g_agree_with_the_constraint() {
    use crate::linalg::{LinearSolver, StackLu};
    let (model, x, y) = points();
    let (n, nq) = (x.nrows(), x.nrows() / 2);
    let w: Vec<f64> = (0..nq).map(|i| 0.5 + (i % 5) as f64).collect();
    let c = model.quadratic_rows::<f64>();
    let m = HolonomicConstraint::<Col<f64>>::dim(&c);
    let mut gram = Gram::new(&c, &x, nq).expect("the rows list their entries");
    assert!(gram.fill(&c, &y, true, &w) && gram.fill(&c, &x, false, &w));
    for right in [Right::AtX, Right::AtY] {
        let mut triplets = Triplets::default();
        gram.add_to(-0.5, right, &mut triplets);
        let mut want = vec![vec![0.0; m]; m];
        for (i, j, v) in triplets.entries {
            want[i][j] += v;
        }
        let mut lu = StackLu::<f64, 24>::with_dim(m).unwrap();
        lu.clear();
        gram.add_to(-0.5, right, &mut lu);
        for (j, want_col) in (0..m).map(|j| (j, want.iter().map(move |r| r[j]))) {
            let col = lu.column_mut(j).unwrap().to_vec();
            for (i, (got, want)) in col.iter().zip(want_col).enumerate() {
                assert!(
                    (got - want).abs() <= 4.0 * f64::EPSILON * want.abs().max(1.0),
                    "{right:?} ({i}, {j}): {got} against {want}"
                );
            }
        }
    }
    // Gᵀa at x and at y, and G(y) W⁻¹ p.
    let a: Vec<f64> = (0..m).map(|r| 1.0 + 0.3 * r as f64).collect();
    for (at, point) in [(Right::AtX, &x), (Right::AtY, &y)] {
        let mut got = vec![0.25; nq];
        gram.transpose_add(at, &a, -2.0, &mut got);
        let mut want = Col::<f64>::zeros(n);
        c.jacobian_transpose_apply(point, &a, &mut want);
        for i in 0..nq {
            let d = (got[i] - (0.25 - 2.0 * want[i])).abs();
            assert!(d <= 1e-14, "{at:?} column {i}: {d:e}");
        }
    }
    let p: Vec<f64> = (0..nq).map(|i| (i as f64 * 0.37).sin()).collect();
    let mut got = vec![0.0; m];
    gram.velocity(&p, &mut got);
    let v = Col::<f64>::from_fn(n, |i| if i < nq { w[i] * p[i] } else { 0.0 });
    let mut want = vec![0.0; m];
    c.jacobian_apply(&y, &v, &mut want);
    for r in 0..m {
        assert!((got[r] - want[r]).abs() <= 1e-14, "row {r}");
    }
}

/// `G(x)` is taken from the last fill at `y` when `x` has `y`'s positions (whatever its
/// momenta), and filled afresh when a position differs.
#[test]
fn g_at_x_is_reused_from_y_only_at_the_same_positions() {
    let (model, x, y) = points();
    let (n, nq) = (x.nrows(), x.nrows() / 2);
    let w = vec![1.0; nq];
    let c = model.quadratic_rows::<f64>();
    let fresh = |point: &Col<f64>| {
        let mut g = Gram::new(&c, &x, nq).unwrap();
        assert!(g.fill(&c, point, false, &w));
        g.at_x.clone()
    };
    let mut gram = Gram::new(&c, &x, nq).unwrap();
    assert!(gram.fill(&c, &y, true, &w));
    // y's positions, other momenta: the values at y.
    let same = Col::<f64>::from_fn(n, |i| if i < nq { y[i] } else { -y[i] + 1.0 });
    gram.forget_x();
    assert!(gram.fill(&c, &same, false, &w));
    assert_eq!(gram.at_x, fresh(&same));
    // One position moved: filled afresh.
    let mut moved = same.clone();
    moved[nq - 1] += 1e-3;
    gram.forget_x();
    assert!(gram.fill(&c, &moved, false, &w));
    assert_eq!(gram.at_x, fresh(&moved));
    assert_ne!(gram.at_x, fresh(&same));
}
