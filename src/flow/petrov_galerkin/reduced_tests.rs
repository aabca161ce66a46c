//! The reduced residual against the full one it replaces, read at the momentum and constraint
//! rows.

use super::super::problem::{Problem, Scratch};
use super::super::tables::Tables;
use super::super::test_scenes::scene;
use super::{Stages, gather};
use crate::nonlinear::NonlinearProblem;
use crate::system::{HolonomicConstraint, MechanicalForm, Model};
use nalgebra::DVector;

/// A deterministic, irregular value for index `i` of sequence `seed`, in `[−1, 1]`.
fn wave(seed: usize, i: usize) -> f64 {
    (1.3 * seed as f64 + 0.41 * i as f64 + 0.017 * (i * i) as f64).sin()
}

/// At unknowns `z` off the solution (so that no row vanishes), the reduced residual equals
/// the full residual's momentum and constraint rows, and the full residual's position rows —
/// eliminated because `Y^q` solves them — vanish: both within the residual's own rounding
/// noise `4 s ε · scale` (both sum the same `s` quadrature terms per row, in another order),
/// and both residuals report the same noise.
fn check<Sys: Model<DVector<f64>>>(system: &Sys, x0: &DVector<f64>, h: f64) {
    let form = MechanicalForm::of(system, system.hamiltonian(), x0)
        .expect("a valid declaration")
        .expect("a model of mechanical form");
    assert!(
        form.momentum_block.iter().any(|&(_, _, v)| v != 0.0),
        "a damped model: B Y^q enters the rows"
    );
    let (n, m) = (x0.len(), system.constraint().dim());
    let nq = n / 2;
    for k in 1..=4 {
        let s = k + 2;
        let tables = Tables::<f64>::new(k, s);
        let mut w = Scratch::new(x0, k, s, m);
        let g0: Vec<f64> = (0..m).map(|a| 1e-3 * wave(2, a)).collect();
        let mut problem = Problem {
            h,
            x: x0,
            tables: &tables,
            w: &mut w,
            system,
            g0: &g0,
            noise: 0.0,
            floor: 0.0,
            forcing: None,
        };
        let mut u = vec![0.0; k * (n + m)];
        let dim = k * (nq + m);
        let z: Vec<f64> = (0..dim).map(|i| h * wave(k, i)).collect();
        let mut reduced = vec![0.0; dim];
        let mut stages = Stages {
            full: &mut problem,
            w: &form.inverse_mass,
            u: &mut u,
            momentum_block: &form.momentum_block,
            blocks: None,
            keep: false,
        };
        stages.residual(&z, &mut reduced).unwrap();
        let noise = stages.noise_floor();
        stages.expand(&z);
        let mut full = vec![0.0; k * (n + m)];
        problem.residual(&u, &mut full).unwrap();
        assert!(noise > 0.0);
        assert!(
            (problem.noise - noise).abs() <= 1e-6 * noise,
            "k = {k}: noise {noise:e} against the full residual's {:e}",
            problem.noise
        );
        let mut read = vec![0.0; dim];
        gather(&full, &mut read, nq, m, k);
        let diff = reduced
            .iter()
            .zip(&read)
            .fold(0.0f64, |d, (a, b)| d.max((a - b).abs()));
        assert!(
            diff <= noise,
            "k = {k}: rows differ by {diff:e} > {noise:e}"
        );
        let size = read.iter().fold(0.0f64, |d, v| d.max(v.abs()));
        assert!(
            size > 1e3 * noise,
            "k = {k}: rows of size {size:e} test nothing"
        );
        let position = (0..k)
            .flat_map(|i| &full[i * n..i * n + nq])
            .fold(0.0f64, |d, v| d.max(v.abs()));
        assert!(
            position <= noise,
            "k = {k}: position rows {position:e} > {noise:e}"
        );
    }
}

#[test]
fn reduced_residual_is_the_full_one_on_the_damped_pendulum() {
    let (system, x0) = scene(include_str!("../../../scenes/damped_pendulum.toml"));
    check(&system, &x0, 0.05);
}

/// Many bodies, damping on every momentum, the log pair potential.
#[test]
fn reduced_residual_is_the_full_one_on_the_damped_shell() {
    let (system, x0) = scene(include_str!("../../../scenes/shell_damped.toml"));
    check(&system, &x0, 0.01);
}

/// Rods that share bodies, damped.
#[test]
fn reduced_residual_is_the_full_one_on_a_damped_chain() {
    let text = include_str!("../../../scenes/chain1000.toml")
        .replace("links = 1000", "links = 6")
        .replace(
            "[integrator]",
            "[[effects]]\ntype = \"damping\"\ncoefficient = 0.3\n\n[integrator]",
        );
    let (system, x0) = scene(&text);
    check(&system, &x0, 0.01);
}

/// Every effect: a magnetic field (a skew `B`, so a transposed entry changes the rows), damping
/// on some bodies only, dashpots, rods, a pin and a plane.
#[test]
fn reduced_residual_is_the_full_one_on_all_effects() {
    let (system, x0) = scene(include_str!("../../../scenes/all_effects.toml"));
    check(&system, &x0, 0.01);
}
