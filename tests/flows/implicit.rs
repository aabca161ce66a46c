//! The implicit midpoint rule on the free rigid body (Lie–Poisson, state-dependent `M`).

use crate::common;

use common::fitted_order;
use lieflow::flow::ImplicitMidpoint;
use lieflow::models::RigidBody;
use lieflow::nonlinear::NewtonOptions;
use lieflow::prelude::*;
use nalgebra::SVector;

type V = SVector<f64, 3>;

fn body() -> RigidBody<f64> {
    RigidBody::gni()
}

fn midpoint(y0: &V) -> impl Flow<V> + use<> {
    let b = body();
    ImplicitMidpoint::<V, _, _>::try_new(b.structure(), b, y0, NewtonOptions::default()).unwrap()
}

/// RK4 on `y' = y × ∇H` with `n` steps (independent of the schemes under test).
fn reference(t: f64, n: usize) -> V {
    let i = body().inertia;
    let f = |y: &V| y.cross(&V::new(y[0] / i[0], y[1] / i[1], y[2] / i[2]));
    let dt = t / n as f64;
    let mut y: V = RigidBody::gni_initial_state();
    for _ in 0..n {
        let k1 = f(&y);
        let k2 = f(&(y + k1 * (0.5 * dt)));
        let k3 = f(&(y + k2 * (0.5 * dt)));
        let k4 = f(&(y + k3 * dt));
        y += (k1 + k2 * 2.0 + k3 * 2.0 + k4) * (dt / 6.0);
    }
    y
}

#[test]
fn casimir_and_energy_are_conserved_over_1e5_steps() {
    let mut y: V = RigidBody::gni_initial_state();
    let (c0, e0) = (RigidBody::casimir(&y), body().energy(&y));
    let mut flow = midpoint(&y);
    let (mut dc, mut de) = (0.0f64, 0.0f64);
    for _ in 0..100_000 {
        flow.step(0.1, &mut y).unwrap();
        dc = dc.max((RigidBody::casimir(&y) - c0).abs() / c0);
        de = de.max((body().energy(&y) - e0).abs() / e0);
    }
    eprintln!("rigid body, 1e5 midpoint steps: casimir rel err {dc:e}, energy rel err {de:e}");
    assert!(dc <= 1e-14, "casimir {dc:e}");
    assert!(de <= 1e-14, "energy {de:e}");
}

#[test]
fn midpoint_is_order_2_and_its_triple_jump_order_4() {
    let t_end = 10.0;
    let r = reference(t_end, 200_000);
    let run = |h: f64, compose: bool| {
        let mut y: V = RigidBody::gni_initial_state();
        let steps = (t_end / h).round() as usize;
        if compose {
            let mut f = midpoint(&y).triple_jump();
            for _ in 0..steps {
                f.step(h, &mut y).unwrap();
            }
        } else {
            let mut f = midpoint(&y);
            for _ in 0..steps {
                f.step(h, &mut y).unwrap();
            }
        }
        (y - r).amax()
    };
    let hs = [0.4, 0.2, 0.1, 0.05];
    let e2: Vec<f64> = hs.iter().map(|&h| run(h, false)).collect();
    let e4: Vec<f64> = hs.iter().map(|&h| run(h, true)).collect();
    let (p2, p4) = (fitted_order(&hs, &e2, 1e-12), fitted_order(&hs, &e4, 1e-12));
    eprintln!("midpoint errors {e2:?} order {p2:.3}; triple jump errors {e4:?} order {p4:.3}");
    assert!((p2 - 2.0).abs() <= 0.3, "midpoint order {p2}");
    assert!((p4 - 4.0).abs() <= 0.3, "triple jump order {p4}");
}

#[test]
fn midpoint_is_symmetric() {
    let y0: V = RigidBody::gni_initial_state();
    let mut f = midpoint(&y0);
    let mut y = y0;
    for _ in 0..20 {
        let start = y;
        f.step(0.1, &mut y).unwrap();
        let after = y;
        f.step(-0.1, &mut y).unwrap();
        assert!((y - start).amax() <= 1e-13, "{:e}", (y - start).amax());
        y = after;
    }
}

/// The implicit midpoint rule's tangent map from its Newton matrix, `DΦ v = 2 J⁻¹ v − v`,
/// against central differences of the flow itself. With the closed-form Newton matrix
/// (which includes `DM` for the rigid body's state-dependent `M`) the formula is exact up to
/// the matrix's age (taken at the last Newton iterate, within ~1e-8 of the solution); the
/// central difference with `ε = 1e-5` is accurate to `O(ε²) + O(u/ε)` ≈ 1e-10.
#[test]
fn midpoint_tangent_map_matches_differences() {
    let y0 = V::new(0.3, -0.8, 0.5);
    let v = V::new(0.2, 0.7, -0.4);
    let h = 0.1;
    let mut flow = midpoint(&y0);
    let mut y = y0;
    flow.step(h, &mut y).unwrap();
    let mut tangent = V::zeros();
    assert!(flow.tangent_apply(&v, &mut tangent));
    // Central differences of fresh flows (no kept state between them).
    let eps = 1e-5;
    let (mut yp, mut ym) = (y0 + eps * v, y0 - eps * v);
    midpoint(&yp.clone()).step(h, &mut yp).unwrap();
    midpoint(&ym.clone()).step(h, &mut ym).unwrap();
    let fd = (yp - ym) / (2.0 * eps);
    let rel = (tangent - fd).amax() / fd.amax();
    println!("tangent map vs differences: relative {rel:.1e}");
    assert!(rel < 1e-8, "relative error {rel:e}");
    // A flow without a tangent map says so.
    let mut drift = from_fn(|h: f64, x: &mut V| x[0] += h);
    assert!(!drift.tangent_apply(&v, &mut tangent));
}
