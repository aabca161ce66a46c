//! The energy-consistent Petrov–Galerkin scheme on the damped pendulum: fitted orders 2, 4, 6,
//! the exact discrete energy balance `H_{n+1} − H_n = −D_n` with `D_n ≥ 0` at every step, the
//! constraint and the hidden constraint at round-off, and the refusals.

use crate::common;

use common::fitted_order;
use lieflow::flow::{Ledger, PetrovGalerkin};
use lieflow::models::DampedPendulum;
use lieflow::prelude::*;
use nalgebra::SVector;

type V = SVector<f64, 4>;

const C: f64 = 0.5;
const THETA0: f64 = std::f64::consts::FRAC_PI_2;

fn model() -> DampedPendulum<f64> {
    DampedPendulum::try_new(C).unwrap()
}

type Pg = PetrovGalerkin<
    V,
    lieflow::System<
        lieflow::models::damped_pendulum::DampedStructure<f64>,
        DampedPendulum<f64>,
        lieflow::models::paper::Circle,
    >,
>;

fn scheme(order: u32, x0: &V) -> Pg {
    Pg::try_new(model().system(), x0, order, ProjectionOptions::default()).unwrap()
}

#[test]
fn petrov_galerkin_has_orders_2_4_6_at_the_step_points() {
    let m = model();
    let x0: V = m.state(THETA0, 0.0);
    let t_end = 5.0;
    let r = m.reference(THETA0, 0.0, t_end, 2e-4);
    for (order, hs) in [
        (2u32, [0.1, 0.05, 0.025, 0.0125]),
        (4, [0.25, 0.125, 0.0625, 0.03125]),
        (6, [0.5, 0.25, 0.125, 0.0625]),
    ] {
        let errs: Vec<f64> = hs
            .iter()
            .map(|&h| {
                let mut f = scheme(order, &x0);
                let mut x = x0;
                for _ in 0..(t_end / h).round() as usize {
                    f.step(h, &mut x).unwrap();
                }
                (0..4).map(|i| (x[i] - r[i]).abs()).fold(0.0, f64::max)
            })
            .collect();
        let p = fitted_order(&hs, &errs, 1e-12);
        eprintln!("Petrov–Galerkin order {order}: errors {errs:?}, fitted {p:.3}");
        assert!((p - f64::from(order)).abs() <= 0.3, "order {order}: {p}");
    }
}

#[test]
fn the_discrete_energy_balance_is_exact_and_dissipation_never_negative() {
    let m = model();
    let x0: V = m.state(THETA0, 0.0);
    for order in [2, 4, 6] {
        let mut f = scheme(order, &x0);
        let mut x = x0;
        let mut ledger = Ledger::at(0.0);
        let (mut worst, mut max_g, mut max_phi) = (0.0f64, 0.0f64, 0.0f64);
        let h = 0.1;
        for step in 0..2000 {
            f.step_at(&mut ledger, h, &mut x).unwrap();
            let d = f.last_dissipation().unwrap();
            // H ≈ −1 … 0 here: its rounding is a few ε.
            let defect = (d.after - d.before + d.total()).abs();
            worst = worst.max(defect);
            assert!(d.damping >= -4.0 * f64::EPSILON, "step {step}: {d:?}");
            assert!(d.projection >= -4.0 * f64::EPSILON, "step {step}: {d:?}");
            max_g = max_g.max((0.5 * (x[0] * x[0] + x[1] * x[1] - 1.0)).abs());
            max_phi = max_phi.max(m.hidden_constraint(&x).abs());
        }
        let total = m.energy(&x) - m.energy(&x0) + ledger.dissipated;
        eprintln!(
            "order {order}: worst step balance {worst:e}, over the run {total:e}, |g| {max_g:e}, |phi| {max_phi:e}"
        );
        assert!(worst <= 16.0 * f64::EPSILON, "order {order}: {worst:e}");
        assert!(total.abs() <= 2000.0 * 4.0 * f64::EPSILON, "{total:e}");
        assert!(max_g <= 8.0 * f64::EPSILON, "{max_g:e}");
        assert!(max_phi <= 16.0 * f64::EPSILON, "{max_phi:e}");
    }
}

#[test]
fn orders_and_structures_it_cannot_take_are_refused() {
    let m = model();
    let x0: V = m.state(THETA0, 0.0);
    for order in [0, 3, 10] {
        let e = Pg::try_new(m.system(), &x0, order, ProjectionOptions::default()).unwrap_err();
        assert!(matches!(e, SetupError::Scheme { .. }), "{e}");
    }
    assert!(scheme(4, &x0).with_quadrature(1).is_err());
    assert!(scheme(4, &x0).with_quadrature(6).is_ok());
}
