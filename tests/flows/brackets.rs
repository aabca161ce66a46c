//! The pseudo-Poisson brackets against closed forms, and the case each model falls in.

use crate::common;

use common::{V3, V4, gradient_sphere};
use lieflow::models::{SphericalPendulum, paper};
use lieflow::ops;
use lieflow::prelude::*;
use lieflow::system::{Brackets, bracket};
use nalgebra::SVector;

#[test]
fn paper_example_is_degenerate_with_the_closed_form_multiplier() {
    let sys = paper::system();
    let b = Brackets::new(&sys);
    // A point on the manifold g = 0, phi = 0.
    let th: f64 = 0.7;
    let w = -0.3;
    let x = V4::new(th.cos(), th.sin(), -th.sin() * w, th.cos() * w);
    assert_eq!(b.g_g(&x), vec![0.0]);
    let phi = b.g_h(&x)[0];
    assert!(
        phi.abs() < 1e-16,
        "phi = x1 x3 + x2 x4 = 0 on the manifold, got {phi:e}"
    );
    assert_eq!(b.case(&x, 1e-8, 1e-8), Ok(Case::Degenerate));
    // <phi,g> = -(x1^2 + 2 x2^2), <phi,H> = x3^2 + x4^2, mu = (x3^2 + x4^2)/(x1^2 + 2 x2^2).
    let pg = b.phi_g(&x)[0];
    let ph = b.phi_h(&x)[0];
    let expect_pg = -(x[0] * x[0] + 2.0 * x[1] * x[1]);
    let expect_ph = x[2] * x[2] + x[3] * x[3];
    // Central differences with step eps^(1/3): accurate to ~eps^(2/3) ~ 4e-11 relative.
    assert!((pg - expect_pg).abs() < 1e-9, "{pg} vs {expect_pg}");
    assert!((ph - expect_ph).abs() < 1e-9, "{ph} vs {expect_ph}");
    let mu = b.modified_multiplier(&x, Case::Degenerate).unwrap()[0];
    let expect_mu = expect_ph / (x[0] * x[0] + 2.0 * x[1] * x[1]);
    assert!(
        (mu - expect_mu).abs() < 1e-9 * expect_mu.abs().max(1.0),
        "{mu} vs {expect_mu}"
    );
}

#[test]
fn gradient_flow_on_a_sphere_is_non_degenerate() {
    let sys = gradient_sphere::system();
    let b = Brackets::new(&sys);
    let x: V3 = gradient_sphere::x0();
    assert_eq!(b.case(&x, 1e-8, 1e-8), Ok(gradient_sphere::case()));
    // <g,g> = G(-I)G^T = -|x|^2; <g,H> = -x.gradH; mu = -<g,g>^{-1}<g,H> = -x.gradH/|x|^2.
    let gg = b.g_g(&x)[0];
    assert!((gg + x.norm_squared()).abs() < 1e-15);
    let mut grad = V3::zeros();
    sys.hamiltonian.gradient(&x, &mut grad);
    let mu = b.modified_multiplier(&x, Case::NonDegenerate).unwrap()[0];
    let expect = -x.dot(&grad) / x.norm_squared();
    assert!((mu - expect).abs() < 1e-14, "{mu} vs {expect}");
    // With this mu the modified vector field M(gradH + G^T mu) is tangent to the sphere.
    let v = -(grad + x * mu);
    assert!(x.dot(&v).abs() < 1e-14);
}

#[test]
fn the_bracket_is_antisymmetric_for_a_skew_structure() {
    type V6 = SVector<f64, 6>;
    let model = SphericalPendulum::try_new(2.0, 1.5, 9.81).unwrap();
    let sys = model.system();
    let x: V6 = V6::new(0.3, -0.4, -1.2, 0.7, 0.1, -0.2);
    let dg = |x: &V6, v: &V6, out: &mut [f64]| sys.constraint.jacobian_apply(x, v, out);
    let dgt = |x: &V6, mu: &[f64], out: &mut V6| {
        ops::fill_zero(out.as_mut_slice());
        sys.constraint.jacobian_transpose_apply_add(x, mu, 1.0, out);
    };
    let dh = |x: &V6, v: &V6, out: &mut [f64]| {
        let mut g = V6::zeros();
        sys.hamiltonian.gradient(x, &mut g);
        out[0] = g.dot(v);
    };
    let dht = |x: &V6, mu: &[f64], out: &mut V6| {
        sys.hamiltonian.gradient(x, out);
        *out *= mu[0];
    };
    let gh = bracket(&sys.structure, &x, 1, dg, 1, dht)[0];
    let hg = bracket(&sys.structure, &x, 1, dh, 1, dgt)[0];
    assert!((gh + hg).abs() < 1e-15, "<g,H> = {gh}, <H,g> = {hg}");
    // <g,H> = q.p/m for the canonical structure.
    let expect = (x[0] * x[3] + x[1] * x[4] + x[2] * x[5]) / model.mass;
    assert!((gh - expect).abs() < 1e-15);
}
