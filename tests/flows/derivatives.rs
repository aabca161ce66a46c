//! Model-provided derivatives: each built-in `hessian_apply` / `derivative_apply_add` against
//! central differences, and the implicit flows with closed-form Newton matrices against the
//! finite-difference fallback (same trajectory, fewer residual evaluations).

use lieflow::flow::{DiscreteGradient, ImplicitMidpoint};
use lieflow::models::{DampedPendulum, RigidBody, SpringChain};
use lieflow::nonlinear::NewtonOptions;
use lieflow::prelude::*;
use lieflow::system::LiePoissonSo3;
use nalgebra::SVector;

/// Hides a Hamiltonian's Hessian: the flows must fall back to finite differences.
#[derive(Clone, Copy)]
struct NoHessian<H>(H);

impl<V: Vector, H: Hamiltonian<V>> Hamiltonian<V> for NoHessian<H> {
    fn energy(&self, x: &V) -> V::Real {
        self.0.energy(x)
    }
    fn gradient(&self, x: &V, out: &mut V) {
        self.0.gradient(x, out)
    }
}

/// Central-difference check of `∇²H v` (error O(δ²) + O(ε/δ); δ = 1e-5 gives ~1e-10).
fn check_hessian<const N: usize>(h: &impl Hamiltonian<SVector<f64, N>>, x: SVector<f64, N>) {
    type W<const N: usize> = SVector<f64, N>;
    for j in 0..N {
        let v = W::<N>::from_fn(|i, _| if i == j { 1.0 } else { 0.0 });
        let mut hv = W::<N>::zeros();
        assert!(h.hessian_apply(&x, &v, &mut hv));
        let d = 1e-5;
        let (mut gp, mut gm) = (W::<N>::zeros(), W::<N>::zeros());
        h.gradient(&(x + v * d), &mut gp);
        h.gradient(&(x - v * d), &mut gm);
        let fd = (gp - gm) / (2.0 * d);
        assert!(
            (fd - hv).amax() <= 1e-8 * (1.0 + hv.amax()),
            "column {j}: {hv} vs {fd}"
        );
    }
}

#[test]
fn built_in_hessians_match_central_differences() {
    check_hessian(&RigidBody::<f64>::gni(), SVector::from([0.3, -0.8, 0.5]));
    check_hessian(
        &DampedPendulum::try_new(0.3).unwrap(),
        SVector::from([0.6, -0.8, 0.2, 0.15]),
    );
    check_hessian(
        &SpringChain::try_new(3, 2.0, 0.5).unwrap(),
        SVector::from([0.1, -0.4, 0.3, 0.7, 0.2, -0.5]),
    );
}

#[test]
fn lie_poisson_derivative_matches_central_differences() {
    type V = SVector<f64, 3>;
    let (y, u, w) = (
        V::new(0.3, -0.8, 0.5),
        V::new(0.2, 0.1, -0.7),
        V::new(-0.4, 0.9, 0.3),
    );
    let mut dm = V::zeros();
    assert!(LiePoissonSo3.derivative_apply_add(&y, &u, &w, 1.0, &mut dm));
    let d = 1e-6;
    let (mut mp, mut mm) = (V::zeros(), V::zeros());
    LiePoissonSo3.apply(&(y + u * d), &w, &mut mp);
    LiePoissonSo3.apply(&(y - u * d), &w, &mut mm);
    assert!((dm - (mp - mm) / (2.0 * d)).amax() <= 1e-9);
    // A constant M has derivative zero, and says so.
    type V4 = SVector<f64, 4>;
    let mut out = V4::zeros();
    let u4 = V4::new(1.0, 2.0, 3.0, 4.0);
    assert!(Canonical.derivative_apply_add(&u4, &u4, &u4, 1.0, &mut out));
    assert_eq!(out, V4::zeros());
}

/// The rigid body by the implicit midpoint rule: closed-form Newton matrices (Hessian of H and
/// derivative of the Lie–Poisson M) against the finite-difference fallback.
#[test]
fn closed_form_jacobians_agree_with_the_fallback_and_save_evaluations() {
    type V = SVector<f64, 3>;
    let b = RigidBody::<f64>::gni();
    let y0: V = RigidBody::gni_initial_state();
    let mut exact =
        ImplicitMidpoint::<V, _, _>::try_new(b.structure(), b, &y0, NewtonOptions::default())
            .unwrap();
    let mut fd = ImplicitMidpoint::<V, _, _>::try_new(
        b.structure(),
        NoHessian(b),
        &y0,
        NewtonOptions::default(),
    )
    .unwrap();
    let (mut y1, mut y2) = (y0, y0);
    for _ in 0..1000 {
        exact.step(0.1, &mut y1).unwrap();
        fd.step(0.1, &mut y2).unwrap();
    }
    let d = (y1 - y2).amax();
    let (se, sf) = (exact.stats(), fd.stats());
    println!("closed form: {se:?}\nfinite differences: {sf:?}\ndifference {d:.2e}");
    // Both solve to Newton's tolerance and polish to round-off; the trajectories agree up to
    // the accumulated round-off of 1000 steps.
    assert!(d <= 1e-12, "{d:e}");
    assert!(se.residual_evaluations < sf.residual_evaluations);
}

/// The discrete gradient on the stiff chain with the closed-form (midpoint) Jacobian: exact for
/// a quadratic H, so the same trajectory as the fallback.
#[test]
fn discrete_gradient_with_closed_form_jacobian_on_a_quadratic_model() {
    type V = SVector<f64, 6>;
    let m = SpringChain::try_new(3, 1.0, 1e6).unwrap();
    let x0: V = m.stretched(1.0);
    let mut a =
        DiscreteGradient::<V, _, _>::try_new(m.structure(), m, &x0, NewtonOptions::default())
            .unwrap();
    let mut b = DiscreteGradient::<V, _, _>::try_new(
        m.structure(),
        NoHessian(m),
        &x0,
        NewtonOptions::default(),
    )
    .unwrap();
    let (mut x, mut y) = (x0, x0);
    let mut e = m.energy(&x);
    for _ in 0..100 {
        a.step(0.1, &mut x).unwrap();
        b.step(0.1, &mut y).unwrap();
        let e1 = m.energy(&x);
        assert!(e1 <= e * (1.0 + 4.0 * f64::EPSILON));
        e = e1;
    }
    println!("closed form {:?}\nfallback {:?}", a.stats(), b.stats());
    assert!((x - y).amax() <= 1e-12, "{:e}", (x - y).amax());
}
