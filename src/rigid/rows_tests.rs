//! The flat row storage against the row's own definition: the value from its monomials equals
//! `½ qᵀ(∇g + b) + c` (a quadratic's Euler identity) and the builder's sum of terms; `G`'s
//! values, its products and the Hessian form agree with one another.

use super::{QuadraticRows, RowBuilder};
use crate::linalg::Triplets;
use crate::system::HolonomicConstraint;
use faer::Col;

/// Rows with products of distinct and equal columns, a column touched by several products
/// (more than one pair), linear terms and constants.
fn rows() -> (QuadraticRows<f64>, Vec<RowBuilder<f64>>) {
    let mut built = Vec::new();
    let mut a = RowBuilder::new();
    a.product(0, 1, 2.0)
        .product(1, 1, -0.5)
        .product(1, 3, 1.5)
        .linear(2, 0.7);
    a.constant(-1.0);
    built.push(a);
    let mut b = RowBuilder::new();
    b.linear(0, 1.0).linear(4, -2.0).constant(0.25);
    built.push(b);
    let mut c = RowBuilder::new();
    c.product(2, 2, 1.0).product(3, 4, -1.0).product(2, 4, 0.5);
    built.push(c);
    let mut rows = QuadraticRows::new(5);
    for r in &built {
        rows.push(r);
    }
    (rows, built)
}

/// The builder's row evaluated term by term.
fn direct(q: &[f64], r: &RowBuilder<f64>) -> f64 {
    let quad: f64 =
        r.a.iter()
            .map(|(&(i, j), &a)| {
                // ½ qᵀAq with A_ij = A_ji stored once for i < j, A_ii on the diagonal.
                if i == j {
                    0.5 * a * q[i] * q[i]
                } else {
                    a * q[i] * q[j]
                }
            })
            .sum();
    let lin: f64 = r.b.iter().map(|(&i, &b)| b * q[i]).sum();
    quad + lin + r.constant.unwrap_or(0.0)
}

#[test]
fn values_gradients_and_products_agree() {
    let (rows, built) = rows();
    let x = Col::<f64>::from_fn(10, |i| 0.3 + 0.7 * (i as f64 * 1.3).sin());
    let q: Vec<f64> = (0..5).map(|i| x[i]).collect();
    let mut g = vec![0.0; 3];
    rows.residual(&x, &mut g);
    let mut values = vec![0.0; rows.entry_count()];
    assert!(rows.jacobian_values(&x, &mut values));
    let mut entries = Triplets::default();
    assert!(rows.jacobian_entries(&x, &mut entries));
    let listed: Vec<f64> = entries.entries.iter().map(|e| e.2).collect();
    assert_eq!(values, listed);
    assert!(!rows.jacobian_values(&x, &mut vec![0.0; rows.entry_count() + 1]));
    for (r, row) in built.iter().enumerate() {
        // The value from its monomials, from the builder's terms, and by Euler's identity.
        let mut euler = row.constant.unwrap_or(0.0);
        for &(rr, i, d) in &entries.entries {
            if rr == r {
                let b = row.b.get(&i).copied().unwrap_or(0.0);
                euler += 0.5 * q[i] * (d + b);
            }
        }
        let want = direct(&q, row);
        assert!(
            (g[r] - want).abs() <= 1e-14,
            "row {r}: {} against {want}",
            g[r]
        );
        assert!(
            (g[r] - euler).abs() <= 1e-14,
            "row {r}: {} against {euler}",
            g[r]
        );
    }
    // ⟨G v, μ⟩ = ⟨v, Gᵀ μ⟩ on the positions, and G v = Σ values.
    let v = Col::<f64>::from_fn(10, |i| if i < 5 { 1.0 - 0.2 * i as f64 } else { 9.0 });
    let mu = [0.5, -1.5, 2.0];
    let mut gv = vec![0.0; 3];
    rows.jacobian_apply(&x, &v, &mut gv);
    let mut gt = Col::<f64>::zeros(10);
    rows.jacobian_transpose_apply(&x, &mu, &mut gt);
    let left: f64 = gv.iter().zip(&mu).map(|(a, b)| a * b).sum();
    let right: f64 = (0..5).map(|i| v[i] * gt[i]).sum();
    assert!((left - right).abs() <= 1e-14);
    for (r, &got) in gv.iter().enumerate() {
        let sum: f64 = entries
            .entries
            .iter()
            .filter(|e| e.0 == r)
            .map(|e| e.2 * v[e.1])
            .sum();
        assert!((got - sum).abs() <= 1e-14);
    }
    // The Hessian form is the second difference of g along u, v (g quadratic: exact).
    let u = Col::<f64>::from_fn(10, |i| 0.1 * (i as f64 + 1.0));
    let mut form = vec![0.0; 3];
    assert!(rows.hessian_form(&x, &u, &v, &mut form));
    let at = |s: f64, t: f64| {
        let p = Col::<f64>::from_fn(10, |i| x[i] + s * u[i] + t * v[i]);
        let mut out = vec![0.0; 3];
        rows.residual(&p, &mut out);
        out
    };
    let (pp, pm, mp, mm) = (at(1.0, 1.0), at(1.0, -1.0), at(-1.0, 1.0), at(-1.0, -1.0));
    for r in 0..3 {
        let second = (pp[r] - pm[r] - mp[r] + mm[r]) / 4.0;
        assert!(
            (form[r] - second).abs() <= 1e-13,
            "row {r}: {} against {second}",
            form[r]
        );
    }
}
