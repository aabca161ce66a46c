//! A compiled scene writes its hidden constraint `φ = G M ∇H` directly as the constraint
//! velocities `G_q W⁻¹ p`, without `∇H`, and its constraint force `M Gᵀλ` as `(0, −G_qᵀλ)`,
//! without `M`, and the hidden constraint's derivative along a momentum-only direction as
//! `G_q W⁻¹ d_p`, without `∇²H` and `M`: each agrees with the generic form on scenes with every
//! kind of constraint and every effect (damping, dashpots and a magnetic field in `M`, pair
//! potentials in `H`).

use faer::Col;
use lieflow::scene::Scene;
use lieflow::{Hamiltonian, HolonomicConstraint, StructureMatrix};

fn check(text: &str) {
    let c = Scene::from_toml(text, "test.toml")
        .unwrap_or_else(|e| panic!("{e}"))
        .compile()
        .unwrap_or_else(|e| panic!("{e}"));
    let model = c.model.expect("a scene of bodies");
    let x0 = c.simulation.state().to_vec();
    let n = x0.len();
    let m = HolonomicConstraint::<Col<f64>>::dim(&model);
    assert!(m > 0);
    // A state off equilibrium: the scene's positions, momenta of either sign.
    let x = Col::<f64>::from_fn(n, |i| {
        if i < n / 2 {
            x0[i]
        } else {
            0.3 + 0.7 * ((i as f64) * 0.618).fract() - 0.5
        }
    });
    let (mut grad, mut field) = (Col::<f64>::zeros(n), Col::<f64>::zeros(n));
    model.gradient(&x, &mut grad);
    model.apply(&x, &grad, &mut field);
    let mut generic = vec![0.0; m];
    model.jacobian_apply(&x, &field, &mut generic);
    let mut direct = vec![f64::NAN; m];
    assert!(HolonomicConstraint::<Col<f64>>::hidden_constraint_direct(
        &model,
        &x,
        &mut direct
    ));
    // Both are sums of the same products G_ij v_j, rounded in a different order; the generic
    // one also adds and subtracts the q-rows' zero blocks: a few ε of the largest term.
    let scale = generic.iter().fold(1.0f64, |a, b| a.max(b.abs()));
    for (i, (a, b)) in generic.iter().zip(&direct).enumerate() {
        assert!(
            (a - b).abs() <= 16.0 * f64::EPSILON * scale,
            "row {i}: generic {a:e}, direct {b:e}"
        );
    }
    // The constraint force: M applied to Gᵀλ against the direct (0, −G_qᵀλ). Both are the
    // same sums with the sign flipped (M's damping and field blocks meet Gᵀλ's zero momenta),
    // so they agree exactly (as numbers: −0 = 0).
    let lambda: Vec<f64> = (0..m).map(|i| 1.0 - 0.37 * i as f64).collect();
    let (mut gt, mut force) = (Col::<f64>::zeros(n), Col::<f64>::zeros(n));
    model.jacobian_transpose_apply(&x, &lambda, &mut gt);
    model.apply(&x, &gt, &mut force);
    let mut direct_force = Col::<f64>::from_fn(n, |_| f64::NAN);
    assert!(HolonomicConstraint::<Col<f64>>::constraint_force_direct(
        &model,
        &x,
        &lambda,
        &mut direct_force
    ));
    for i in 0..n {
        assert!(
            force[i] == direct_force[i],
            "entry {i}: M Gᵀλ {:e}, direct {:e}",
            force[i],
            direct_force[i]
        );
    }
    // The hidden constraint's derivative along that force (momenta only): G M ∇²H d against
    // the direct G_q W⁻¹ d_p, the same products in another order (∇²V meets d's zero
    // positions); refused along a direction that moves positions.
    let (mut hd, mut mhd) = (Col::<f64>::zeros(n), Col::<f64>::zeros(n));
    assert!(model.hessian_apply(&x, &force, &mut hd));
    model.apply(&x, &hd, &mut mhd);
    let mut generic = vec![0.0; m];
    model.jacobian_apply(&x, &mhd, &mut generic);
    let mut direct = vec![f64::NAN; m];
    assert!(HolonomicConstraint::<Col<f64>>::hidden_derivative_direct(
        &model,
        &x,
        &force,
        &mut direct
    ));
    let scale = generic.iter().fold(1.0f64, |a, b| a.max(b.abs()));
    for (i, (a, b)) in generic.iter().zip(&direct).enumerate() {
        assert!(
            (a - b).abs() <= 16.0 * f64::EPSILON * scale,
            "row {i}: derivative generic {a:e}, direct {b:e}"
        );
    }
    assert!(!HolonomicConstraint::<Col<f64>>::hidden_derivative_direct(
        &model,
        &x,
        &x,
        &mut direct
    ));
}

#[test]
fn the_direct_hidden_constraint_and_constraint_force_are_the_generic_ones() {
    check(include_str!("../../scenes/all_effects.toml"));
    check(include_str!("../../scenes/shell_damped.toml"));
    check(include_str!("../../scenes/parallel_cranks.toml"));
    check(include_str!("../../scenes/stiff_chain.toml"));
    // A dashpot between two bodies on rods to fixed points: its block of R couples momenta.
    check(
        r#"version = 1
dim = 2
[[bodies]]
name = "a"
mass = 1.0
position = [0.0, -1.0]
velocity = [1.0, 0.0]
[[bodies]]
name = "b"
mass = 3.0
position = [1.0, -1.0]
velocity = [-0.2, 0.0]
[[constraints]]
type = "rod"
bodies = ["a"]
point = [0.0, 0.0]
length = 1.0
[[constraints]]
type = "rod"
bodies = ["b"]
point = [1.0, 0.0]
length = 1.0
[[effects]]
type = "dashpot"
bodies = ["a", "b"]
coefficient = 1.5
[integrator]
dt = 0.01
t_end = 1.0
"#,
    );
}
