//! The constrained discrete gradient of a model of mechanical form: the discrete gradient
//! block by block (`∇̄H = (∇̄V, W⁻¹p̄)`, `∇̄g` on the positions), the momenta eliminated, Newton
//! on `(δq, ν)`. Its discrete energy identity to round-off, symmetry, order 2, agreement with
//! the full-state discrete gradient to the schemes' common order (a long chain: in
//! `mechanical_form.rs`).

use faer::Col;
use lieflow::prelude::*;
use std::sync::Arc;

use crate::scene_text;
use scene_text::moving_shell;

type V = Col<f64>;
type Model = Arc<lieflow::scene::SceneModel>;

/// The damped shell with a magnetic field and a dashpot (every term of `B`), momenta set off
/// rest tangent to the spheres (`φ = 0`).
fn shell() -> (Model, V) {
    moving_shell(
        "[[effects]]\ntype = \"magnetic\"\nfield = [0.0, 0.0, 0.7]\n\n\
         [[effects]]\ntype = \"dashpot\"\nbodies = [\"p.0\", \"p.3\"]\ncoefficient = 0.3\n",
    )
}

/// A Hamiltonian that hides its mechanical form: the flow then takes the full-state path.
struct Opaque(Model);

impl Hamiltonian<V> for Opaque {
    fn energy(&self, x: &V) -> f64 {
        self.0.energy(x)
    }
    fn gradient(&self, x: &V, out: &mut V) {
        self.0.gradient(x, out)
    }
    fn hessian_apply(&self, x: &V, v: &V, out: &mut V) -> bool {
        self.0.hessian_apply(x, v, out)
    }
}

fn g_norm(model: &Model, x: &V) -> f64 {
    let mut r = vec![0.0; HolonomicConstraint::<V>::dim(model)];
    model.residual(x, &mut r);
    r.iter().fold(0.0, |a, &b| a.max(b.abs()))
}

fn flow<H: Hamiltonian<V>>(
    model: &Model,
    hamiltonian: H,
    x0: &V,
) -> ConstrainedDiscreteGradient<V, System<Model, H, Model>> {
    let system = System::new(model.clone(), hamiltonian, model.clone());
    ConstrainedDiscreteGradient::try_new(system, x0, ProjectionOptions::default()).unwrap()
}

/// `x(T)` after `steps` steps of `T / steps`.
fn end<H: Hamiltonian<V>>(model: &Model, hamiltonian: H, x0: &V, t: f64, steps: usize) -> V {
    let mut f = flow(model, hamiltonian, x0);
    let mut x = x0.clone();
    for _ in 0..steps {
        f.step(t / steps as f64, &mut x).unwrap();
    }
    x
}

/// `H(x') − H(x) = h v̄ᵀB v̄ ≤ 0` at every step to the rounding of the energies (`H ≈ −15`,
/// each energy a sum of 45 pair terms: a few ε |H|), `|g|` at round-off, and the hidden
/// projection never adds energy.
#[test]
fn the_energy_identity_holds_to_round_off_at_every_step() {
    let (model, x0) = shell();
    let mut f = flow(&model, model.clone(), &x0);
    assert!(format!("{f:?}").contains("mechanical: true"), "{f:?}");
    let mut x = x0.clone();
    let mut dissipated = 0.0;
    for _ in 0..300 {
        f.step(0.02, &mut x).unwrap();
        let b = f.energy_balance().unwrap();
        let scale = b.before.abs().max(1.0);
        let identity = (b.after_step - b.before - b.supplied).abs();
        assert!(
            identity <= 64.0 * f64::EPSILON * scale,
            "identity off by {identity:e}"
        );
        assert!(b.supplied <= 0.0, "the step supplied {:e}", b.supplied);
        assert!(b.after <= b.after_step + 8.0 * f64::EPSILON * scale);
        assert!(
            g_norm(&model, &x) <= 1e-14,
            "|g| = {:e}",
            g_norm(&model, &x)
        );
        dissipated -= b.supplied;
    }
    assert!(dissipated > 1e-3, "the damping acted: {dissipated:e}");
}

/// Without the hidden projection the step is Gonzalez's symmetric step: `Φ_{−h} ∘ Φ_h = id`
/// (the discrete gradients are symmetric in their two points, `B` is constant).
#[test]
fn without_the_hidden_projection_the_step_is_symmetric() {
    let (model, x0) = shell();
    let mut f = flow(&model, model.clone(), &x0).without_hidden_projection();
    let mut x = x0.clone();
    for _ in 0..5 {
        f.step(0.05, &mut x).unwrap();
    }
    let mid = x.clone();
    f.step(0.05, &mut x).unwrap();
    f.step(-0.05, &mut x).unwrap();
    let back = (&x - &mid).norm_max();
    assert!(back <= 1e-13, "Φ_-h ∘ Φ_h moved the state by {back:e}");
}

/// Order 2 (the error against a step of a sixteenth falls four times per halving, ±0.3 in
/// the exponent), and the full-state discrete gradient — a different discrete gradient of
/// the same order — differs from it by `O(h²)` as well.
#[test]
fn it_is_order_2_and_agrees_with_the_full_state_discrete_gradient() {
    let (model, x0) = shell();
    let t = 0.4;
    let reference = end(&model, model.clone(), &x0, t, 640);
    let err = |steps| (&end(&model, model.clone(), &x0, t, steps) - &reference).norm_max();
    let gap = |steps| {
        let a = end(&model, model.clone(), &x0, t, steps);
        let b = end(&model, Opaque(model.clone()), &x0, t, steps);
        (&a - &b).norm_max()
    };
    let (e1, e2) = (err(20), err(40));
    let order = (e1 / e2).log2();
    assert!((order - 2.0).abs() <= 0.3, "order {order} ({e1:e}, {e2:e})");
    let (d1, d2) = (gap(20), gap(40));
    let order = (d1 / d2).log2();
    assert!(
        (order - 2.0).abs() <= 0.3,
        "gap order {order} ({d1:e}, {d2:e})"
    );
}
