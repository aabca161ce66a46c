//! The default quadrature: the fewest Gauss points that integrate every integral of the step
//! exactly when `H` and `g` are quadratic, and the step it gives is the step of more points.

use super::test_scenes::scene;
use super::{PetrovGalerkin, exact_quadrature};
use crate::flow::{Flow, ProjectionOptions};
use crate::system::Model;
use nalgebra::DVector;

const PENDULUM: &str = include_str!("../../../scenes/damped_pendulum.toml");
const CHAIN: &str = include_str!("../../../scenes/chain100_damped.toml");
const SHELL: &str = include_str!("../../../scenes/shell_damped.toml");

/// `⌊3k/2⌋` points with quadratic constraints (integrands of degree `3k − 2`), `k` without
/// (degree `2k − 1`), `k + 2` when `H` or `g` is not quadratic.
#[test]
fn the_rule() {
    let with_constraints: Vec<usize> = (1..=4)
        .map(|k| exact_quadrature(k, 3, true, true))
        .collect();
    assert_eq!(with_constraints, [1, 3, 4, 6]);
    for k in 1..=4 {
        // Exact to degree 2s − 1 ≥ 3k − 2, and one point fewer is not.
        let s = exact_quadrature(k, 3, true, true);
        assert!(2 * s > 3 * k - 2 && 2 * (s - 1) <= 3 * k - 2);
        assert_eq!(exact_quadrature(k, 0, true, false), k);
        assert_eq!(exact_quadrature(k, 3, false, true), k + 2);
        assert_eq!(exact_quadrature(k, 3, true, false), k + 2);
    }
}

fn scheme<Sys: Model<DVector<f64>>>(
    system: Sys,
    x0: &DVector<f64>,
    order: u32,
) -> PetrovGalerkin<DVector<f64>, Sys> {
    PetrovGalerkin::try_new(system, x0, order, ProjectionOptions::default()).expect("a scheme")
}

/// `steps` steps of `h` from `x0` by `flow`.
fn run(mut flow: impl Flow<DVector<f64>>, x0: &DVector<f64>, h: f64, steps: usize) -> DVector<f64> {
    let mut x = x0.clone();
    for _ in 0..steps {
        flow.step(h, &mut x).expect("a step");
    }
    x
}

/// On the damped pendulum and a damped chain (`H` kinetic plus gravity, rods: all quadratic)
/// the default takes `⌊3k/2⌋` points, and its steps are those of `k + 2` points to the
/// solves' stop: the same equations, summed in another order. With `k` points, one too few
/// for the constraint rows, the steps differ by far more — the comparison sees inexactness.
#[test]
fn exact_points_give_the_same_steps() {
    let chain = CHAIN.replace("links = 100", "links = 6");
    for (text, h, steps) in [(PENDULUM, 0.05, 200), (chain.as_str(), 1e-3, 200)] {
        for order in [4u32, 6] {
            let k = (order / 2) as usize;
            let (system, x0) = scene(text);
            let exact = scheme(system, &x0, order);
            assert_eq!(exact.quadrature_points(), 3 * k / 2);
            let a = run(exact, &x0, h, steps);
            let (system, _) = scene(text);
            let more = scheme(system, &x0, order)
                .with_quadrature(k + 2)
                .expect("k + 2 points");
            let b = run(more, &x0, h, steps);
            let (system, _) = scene(text);
            let fewer = scheme(system, &x0, order)
                .with_quadrature(k)
                .expect("k points");
            let c = run(fewer, &x0, h, steps);
            let scale = x0.amax().max(a.amax());
            let same = (&a - &b).amax();
            let other = (&a - &c).amax();
            println!("order {order}: |default − (k+2)| = {same:.1e}, |default − k| = {other:.1e}");
            // Each step's solves stop within a few dozen ε of the state (their rounding
            // floor); over the run these add up, and a damped motion does not amplify them.
            assert!(
                same <= 64.0 * f64::EPSILON * scale * steps as f64,
                "order {order}: {same:e} apart"
            );
            assert!(
                other > 100.0 * same,
                "order {order}: k points {other:e} apart"
            );
        }
    }
}

/// A pair potential (`log`) is not a polynomial: `k + 2` points.
#[test]
fn non_polynomial_potentials_keep_two_more_points() {
    for order in [4u32, 6] {
        let (system, x0) = scene(SHELL);
        assert_eq!(
            scheme(system, &x0, order).quadrature_points(),
            (order / 2) as usize + 2
        );
    }
}
