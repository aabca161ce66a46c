//! The implicit schemes on a scene without constraints: a damped lattice of particles joined by
//! springs, one of them held by a trap. A scene is of mechanical form, so each scheme eliminates
//! the momenta and solves for the positions alone with the model's sparsity (the Schur
//! iteration's diagonal `D⁻¹`, or Newton with the pattern of the springs' Hessian), as it does
//! with constraints, instead of dense Newton on all `n` unknowns, whose difference Jacobian
//! costs `n` gradient evaluations each time it is built.

use faer::Col;
use lieflow::nonlinear::NewtonOptions;
use lieflow::prelude::*;
use lieflow::scene::{Scene, run};

/// An `nx × ny` lattice of 10 g particles 0.1 apart, neighbours joined by springs of stiffness
/// 10 (at their rest length), the first held by a trap, under gravity, damped; `dt = 1e-3`.
fn lattice(nx: usize, ny: usize, scheme: &str, t_end: f64) -> Scene {
    let mut text = format!(
        "version = 1\nname = \"lattice\"\ndim = 2\n[[grids]]\nname = \"g\"\norigin = [0.0, 0.0]\nspacing = 0.1\ncounts = [{nx}, {ny}]\nmass = 0.01\n"
    );
    let at = |i: usize, j: usize| i + nx * j;
    for j in 0..ny {
        for i in 0..nx {
            for (a, b) in [(i + 1, j), (i, j + 1)] {
                if a < nx && b < ny {
                    text += &format!(
                        "[[effects]]\ntype = \"spring\"\nbodies = [\"g.{}\", \"g.{}\"]\nstiffness = 10.0\n",
                        at(i, j),
                        at(a, b)
                    );
                }
            }
        }
    }
    text += "[[effects]]\ntype = \"trap\"\nstiffness = 100.0\ncenter = [0.0, 0.0]\nbodies = [\"g.0\"]\n";
    text += "[[effects]]\ntype = \"gravity\"\ng = [0.0, -9.81]\n";
    text += "[[effects]]\ntype = \"damping\"\ncoefficient = 0.01\n";
    text += &format!("[integrator]\n{scheme}\ndt = 1e-3\nt_end = {t_end}\n");
    Scene::from_toml(&text, "lattice.toml").unwrap_or_else(|e| panic!("{e}"))
}

/// The scene's midpoint rule takes the same steps as the library's `ImplicitMidpoint` (dense
/// Newton on all unknowns) on the scene's own model: both solve the same equations, each to its
/// Newton tolerance, so the states differ by the solves' rounding, `O(ε)` relative per step,
/// not by a truncation error (`O(h³) ≈ 1e-9` a step here).
#[test]
fn the_reduced_midpoint_steps_are_those_of_dense_newton() {
    let steps = 50;
    let scene = lattice(4, 3, "scheme = \"midpoint\"", 1.0);
    let mut c = scene.compile().unwrap_or_else(|e| panic!("{e}"));
    let model = c.model.clone().expect("a scene's model");
    let mut x = Col::<f64>::from_fn(c.simulation.state().len(), |i| c.simulation.state()[i]);
    let mut dense = ImplicitMidpoint::<Col<f64>, _, _>::try_new(
        model.clone(),
        model.clone(),
        &x,
        NewtonOptions::default(),
    )
    .unwrap();
    let size = x.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    let mut worst = 0.0f64;
    for _ in 0..steps {
        c.simulation.step().unwrap();
        dense.step(1e-3, &mut x).unwrap();
        let d = c
            .simulation
            .state()
            .iter()
            .zip(x.iter())
            .fold(0.0f64, |a, (p, q)| a.max((p - q).abs()));
        worst = worst.max(d);
    }
    eprintln!("max |x_reduced − x_dense| = {worst:e} over {steps} steps");
    // Each solve stops within ~100 ε of its root (the rows' noise); the two paths separate by
    // at most that per step, carried by a flow whose growth over 0.05 s is O(1).
    let bound = 100.0 * f64::EPSILON * size * steps as f64;
    assert!(worst <= bound, "{worst:e} > {bound:e}");
}

/// The scene's discrete gradient without constraints is the constrained discrete gradient's
/// reduced step with none: Gonzalez's discrete gradient block by block (of `V` on the
/// positions; the kinetic term's is exact), another discrete gradient than the full-state one
/// of `DiscreteGradient`, so the two agree only to `O(h³)` a step. What makes it one is its
/// identity, checked at every step on the scene's model: `H(x') − H(x) = h v̄ᵀB v̄ ≤ 0`, to
/// the solve's rounding (the residual `100 ftol` in the positions, times the forces).
#[test]
fn the_reduced_discrete_gradient_keeps_its_energy_identity() {
    let scene = lattice(4, 3, "scheme = \"discrete-gradient\"", 1.0);
    let mut c = scene.compile().unwrap_or_else(|e| panic!("{e}"));
    let model = c.model.clone().expect("a scene's model");
    let mut x = Col::<f64>::from_fn(c.simulation.state().len(), |i| c.simulation.state()[i]);
    let system = System::new(model.clone(), model.clone(), model.clone());
    let mut dg = ConstrainedDiscreteGradient::<Col<f64>, _>::try_new(
        system,
        &x,
        ProjectionOptions::default(),
    )
    .unwrap();
    let (mut worst, mut supplied_max, mut scene_gap) = (0.0f64, f64::NEG_INFINITY, 0.0f64);
    for _ in 0..200 {
        dg.step(1e-3, &mut x).unwrap();
        c.simulation.step().unwrap();
        let b = dg.energy_balance().expect("a step was taken");
        worst = worst.max((b.after - b.before - b.supplied).abs() / b.before.abs().max(1.0));
        supplied_max = supplied_max.max(b.supplied);
        scene_gap = c
            .simulation
            .state()
            .iter()
            .zip(x.iter())
            .fold(scene_gap, |a, (p, q)| a.max((p - q).abs()));
    }
    eprintln!(
        "|ΔH − supplied| ≤ {worst:e} (relative), supplied ≤ {supplied_max:e}, scene − library {scene_gap:e}"
    );
    assert!(worst <= 1e-12, "{worst:e}");
    assert!(supplied_max <= 0.0, "{supplied_max:e}");
    // The scene steps this very flow (its tolerance from the scene's scales: a rounding apart).
    assert!(scene_gap <= 1e-12, "{scene_gap:e}");
}

/// On a 20 × 20 lattice (n = 1600, whose Petrov–Galerkin stages have 3200 unknowns: dense
/// Newton refused them) every implicit scheme runs, with the gradient evaluations of a sparse
/// solve — a few per step, against the `n` of one dense difference Jacobian — and the discrete
/// gradient and the Petrov–Galerkin scheme never raise the energy (the latter's balance exact).
#[test]
fn a_large_lattice_runs_at_the_cost_of_its_structure() {
    for scheme in [
        "scheme = \"midpoint\"",
        "scheme = \"discrete-gradient\"",
        "scheme = \"petrov-galerkin\"\norder = 4",
    ] {
        let scene = lattice(20, 20, scheme, 0.02);
        let mut c = scene.compile().unwrap_or_else(|e| panic!("{e}"));
        let n = c.simulation.state().len();
        let s = run(c.simulation.as_mut(), &c.plan, &mut |_| {});
        assert_eq!(s.error, None, "{scheme}");
        let trap = s
            .effects
            .iter()
            .find(|e| e.kind == "trap")
            .expect("the trap's count")
            .evaluations;
        let per_step = trap as f64 / s.steps as f64;
        eprintln!(
            "{scheme}: {per_step:.1} gradient evaluations a step (n = {n}), balance {:?}, max rise {:?}",
            s.max_energy_balance_error, s.max_energy_increase
        );
        assert!(per_step < 0.05 * n as f64, "{scheme}: {per_step}");
        let energy = s.energy_initial.unwrap().abs();
        if !scheme.contains("midpoint") {
            // `H` never rises: `H_{n+1} − H_n = −D_n ≤ 0` to the solve's residual.
            assert!(s.max_energy_increase.unwrap() <= 1e-12 * energy, "{scheme}");
        }
        if scheme.contains("petrov") {
            // Its discrete dissipation `D_n` is the summary's `dissipated`: the balance
            // `H_n − H_0 + Σ D_k` closes to the solves' residuals.
            let balance = s.max_energy_balance_error.unwrap();
            assert!(balance <= 1e-12 * energy, "{scheme}: balance {balance:e}");
        }
    }
}
