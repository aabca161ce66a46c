//! A compiled scene writes its hidden constraint `φ = G M ∇H` directly as the constraint
//! velocities `G_q W⁻¹ p`, without `∇H`: the two agree on scenes with every kind of
//! constraint and every effect (damping and a magnetic field in `M`, pair potentials in `H`).

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
}

#[test]
fn the_direct_hidden_constraint_is_g_m_grad_h() {
    check(include_str!("../scenes/all_effects.toml"));
    check(include_str!("../scenes/shell_damped.toml"));
    check(include_str!("../scenes/parallel_cranks.toml"));
    check(include_str!("../scenes/stiff_chain.toml"));
}
