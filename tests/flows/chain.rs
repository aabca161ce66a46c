//! The N-link pendulum chain, and particles on spheres: RATTLE keeps short chains on their
//! constraints with the default options; through the sparse path dense and sparse
//! backends give the same trajectory, the constraints hold at round-off for N = 1000, and
//! redundant constraint sets are typed errors that name a constraint.

use faer::Col;
use lieflow::linalg::{LinearSolver, SolverChoice, SolverKind};
use lieflow::models::PendulumChain;
use lieflow::prelude::*;

type V = Col<f64>;

fn shape(n: usize) -> impl Fn(usize) -> f64 {
    move |i| 0.5 + 0.1 * (std::f64::consts::PI * i as f64 / n as f64).sin()
}

fn rattle(
    model: &PendulumChain<f64>,
    x0: &V,
    solver: SolverChoice,
) -> Result<impl Flow<V> + use<>, SetupError> {
    let options = model.projection_options();
    let options = options.with_newton(options.newton.with_solver(solver));
    model
        .kick::<V>()
        .strang(model.drift())
        .projected(model.system(), x0, options)
}

fn residuals(model: &PendulumChain<f64>, x: &V) -> (f64, f64) {
    let sys = model.system();
    let m = model.constraints();
    let (mut g, mut phi) = (vec![0.0; m], vec![0.0; m]);
    let (mut t1, mut t2) = (x.clone(), x.clone());
    sys.constraint.residual(x, &mut g);
    sys.hidden_constraint(x, &mut t1, &mut t2, &mut phi);
    let norm = |v: &[f64]| v.iter().fold(0.0f64, |a, b| a.max(b.abs()));
    (norm(&g), norm(&phi))
}

/// Steps `flow` `steps` times from `x` with step `h`; the worst `|g|`, `|φ|` and `|H − H₀|`.
fn run_checked(
    model: &PendulumChain<f64>,
    flow: &mut impl Flow<V>,
    x: &mut V,
    h: f64,
    steps: usize,
) -> (f64, f64, f64) {
    let e0 = model.energy(x);
    let (mut max_g, mut max_phi, mut max_de) = (0.0f64, 0.0f64, 0.0f64);
    for _ in 0..steps {
        flow.step(h, x).unwrap();
        let (g, phi) = residuals(model, x);
        max_g = max_g.max(g);
        max_phi = max_phi.max(phi);
        max_de = max_de.max((model.energy(x) - e0).abs());
    }
    (max_g, max_phi, max_de)
}

/// A short chain through the default options (case and coupling decided from the brackets).
#[test]
fn rattle_keeps_a_short_chain_on_its_constraints() {
    for dim in [2, 3] {
        let model = PendulumChain::<f64>::uniform(dim, 8).unwrap();
        let x0: V = model.at_rest(|i| 0.3 + 0.1 * i as f64);
        let (g0, _) = residuals(&model, &x0);
        assert!(g0 <= 1e-15, "initial state off the rods: {g0:e}");
        let mut flow = model
            .kick()
            .strang(model.drift())
            .projected(model.system(), &x0, ProjectionOptions::default())
            .unwrap();
        let e0 = model.energy(&x0);
        let mut x = x0.clone();
        let (max_g, max_phi, max_de) = run_checked(&model, &mut flow, &mut x, 0.005, 1000);
        println!(
            "dim {dim}: max |g| {max_g:.2e}, max |phi| {max_phi:.2e}, max |E - E0| {max_de:.2e}"
        );
        assert!(max_g <= 1e-12 && max_phi <= 1e-12, "dim {dim}");
        // RATTLE's energy error is a bounded O(h²) oscillation.
        assert!(max_de <= 1e-2 * e0.abs().max(1.0), "dim {dim}: {max_de:e}");
    }
}

#[test]
fn bad_parameters_are_typed_errors() {
    assert!(PendulumChain::<f64>::try_new(4, vec![1.0], vec![1.0], 1.0).is_err());
    assert!(PendulumChain::<f64>::try_new(2, vec![1.0, 1.0], vec![1.0], 1.0).is_err());
    assert!(PendulumChain::<f64>::try_new(2, vec![-1.0], vec![1.0], 1.0).is_err());
    assert!(PendulumChain::<f64>::try_new(2, vec![1.0], vec![f64::NAN], 1.0).is_err());
    assert!(PendulumChain::<f64>::try_new(3, vec![], vec![], 1.0).is_err());
}

#[test]
fn dense_and_sparse_backends_give_the_same_trajectory() {
    let n = 50;
    let model = PendulumChain::<f64>::uniform(2, n).unwrap();
    let x0: V = model.at_rest(shape(n));
    let mut dense = rattle(&model, &x0, SolverChoice::Force(SolverKind::Dense)).unwrap();
    let mut sparse = rattle(&model, &x0, SolverChoice::Force(SolverKind::Sparse)).unwrap();
    let (mut xd, mut xs) = (x0.clone(), x0.clone());
    let mut max_diff = 0.0f64;
    for _ in 0..1000 {
        dense.step(1e-3, &mut xd).unwrap();
        sparse.step(1e-3, &mut xs).unwrap();
        let d = xd
            .as_slice()
            .iter()
            .zip(xs.as_slice())
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        max_diff = max_diff.max(d);
    }
    println!("N = 50, 1000 steps: max |x_dense - x_sparse| = {max_diff:.2e}");
    assert!(max_diff <= 1e-11, "{max_diff:e}");
}

#[test]
fn a_thousand_links_stay_on_their_constraints() {
    let n = 1000;
    let model = PendulumChain::<f64>::uniform(2, n).unwrap();
    let x0: V = model.at_rest(shape(n));
    let mut flow = rattle(&model, &x0, SolverChoice::Auto).unwrap();
    let e0 = model.energy(&x0);
    let mut x = x0.clone();
    let h = 1e-4;
    let (max_g, max_phi, max_de) = run_checked(&model, &mut flow, &mut x, h, 1000);
    println!(
        "N = 1000, 1000 steps: max |g| {max_g:.2e}, max |phi| {max_phi:.2e}, max |H - H0| {max_de:.2e} (H0 = {e0:.3})"
    );
    // The bound is 1e-12; the round-off level of the chain: positions of size 1 differenced over links of 1e-3.
    let l = 1.0 / n as f64;
    assert!(max_g <= 64.0 * f64::EPSILON * l && max_phi <= 64.0 * f64::EPSILON * l);
    // RATTLE's energy error is O(h²) and bounded; relative to |H0| it stays far below h.
    assert!(max_de <= h * e0.abs() * 1e-2, "{max_de:e}");
}

#[test]
fn redundant_constraints_are_typed_errors_naming_one() {
    // The same link constrained twice: rod 2–3 again, as constraint N.
    let n = 200;
    let model = PendulumChain::<f64>::uniform(2, n)
        .unwrap()
        .with_rod(Some(2), 3, 1.0 / n as f64)
        .unwrap();
    let x0: V = model.at_rest(shape(n));
    match rattle(&model, &x0, SolverChoice::Auto).err() {
        Some(SetupError::RankDeficient { constraint, ratio }) => {
            assert!(constraint == 3 || constraint == n, "named {constraint}");
            assert!(ratio <= 1e-12);
        }
        other => panic!("expected a rank-deficiency error, got {other:?}"),
    }
    // Without naming the case (the brackets would only see singular matrices), and for the
    // constrained discrete gradient, the same typed error.
    let small = PendulumChain::<f64>::uniform(2, 4)
        .unwrap()
        .with_rod(Some(0), 1, 0.25)
        .unwrap();
    let xs: V = small.at_rest(shape(4));
    let err = small
        .kick::<V>()
        .strang(small.drift())
        .projected(small.system(), &xs, ProjectionOptions::default())
        .err();
    assert!(
        matches!(err, Some(SetupError::RankDeficient { constraint, .. }) if constraint == 1 || constraint == 4),
        "{err:?}"
    );
    let err = lieflow::flow::ConstrainedDiscreteGradient::<V, _>::try_new(
        small.system(),
        &xs,
        small.projection_options(),
    )
    .err();
    assert!(
        matches!(err, Some(SetupError::RankDeficient { .. })),
        "{err:?}"
    );
    // An over-constrained closed loop: a flat triangle — particles 0 and 1 on a straight line
    // through the pin, and a rod from the pin to particle 1 closing the loop. Its three
    // gradients are dependent (the triangle is degenerate), whichever backend is used.
    for solver in [
        SolverChoice::Auto,
        SolverChoice::Force(SolverKind::Dense),
        SolverChoice::Force(SolverKind::Sparse),
    ] {
        let model = PendulumChain::<f64>::try_new(2, vec![1.0; 2], vec![1.0; 2], 1.0)
            .unwrap()
            .with_rod(None, 1, 2.0)
            .unwrap();
        let x0: V = model.at_rest(|_| 0.3);
        let err = rattle(&model, &x0, solver).err();
        assert!(
            matches!(err, Some(SetupError::RankDeficient { .. })),
            "{solver:?}: {err:?}"
        );
        let msg = err.unwrap().to_string();
        assert!(msg.contains("redundant constraints"), "{msg}");
    }
    // A genuine (non-flat) loop closure is fine: the equilateral triangle pin-0-1.
    let model = PendulumChain::<f64>::try_new(2, vec![1.0; 2], vec![1.0; 2], 1.0)
        .unwrap()
        .with_rod(None, 1, 1.0)
        .unwrap();
    let x0: V = model.at_rest(|i| {
        if i == 0 {
            0.0
        } else {
            std::f64::consts::FRAC_PI_3 * 2.0
        }
    });
    let (g0, _) = residuals(&model, &x0);
    assert!(g0 <= 1e-15, "{g0:e}");
    assert!(rattle(&model, &x0, SolverChoice::Auto).is_ok());
    // The backend check: the auto choice for a long chain is the band solver (its multiplier
    // systems are tridiagonal).
    let model = PendulumChain::<f64>::uniform(3, 500).unwrap();
    let x0: V = model.at_rest(shape(500));
    let flow = model
        .kick::<V>()
        .strang(model.drift())
        .projected(model.system(), &x0, model.projection_options())
        .unwrap();
    assert_eq!(flow.newton().linear_solver().kind(), SolverKind::Banded);
}

/// The second sparsity pattern: particles each on its own sphere (block-diagonal constraints),
/// coupled by springs that the multiplier pattern does not see.
#[test]
fn particles_on_spheres_stay_on_them_with_springs_outside_the_pattern() {
    use lieflow::models::SphereParticles;
    // Drift–kick–drift, so that the springs couple the multipliers (see the model docs).
    let run = |n: usize, spring: f64, solver: SolverChoice, steps: usize| {
        let model = SphereParticles::<f64>::row(n, spring).unwrap();
        let x0: V = model.at_rest(|i| 0.3 + 0.2 * (i as f64 * 0.7).sin(), |i| 0.1 * i as f64);
        let options = model.projection_options();
        let options = options.with_newton(options.newton.with_solver(solver));
        let mut flow = model
            .drift::<V>()
            .strang(model.kick())
            .projected(model.system(), &x0, options)
            .unwrap();
        let kind = flow.newton().linear_solver().kind();
        let sys = model.system();
        let (mut g, mut phi) = (vec![0.0; n], vec![0.0; n]);
        let (mut t1, mut t2) = (x0.clone(), x0.clone());
        let e0 = model.energy(&x0);
        let mut x = x0.clone();
        let (mut max_g, mut max_phi, mut max_de) = (0.0f64, 0.0f64, 0.0f64);
        for _ in 0..steps {
            flow.step(1e-2, &mut x).unwrap();
            sys.constraint.residual(&x, &mut g);
            sys.hidden_constraint(&x, &mut t1, &mut t2, &mut phi);
            let norm = |v: &[f64]| v.iter().fold(0.0f64, |a, b| a.max(b.abs()));
            max_g = max_g.max(norm(&g));
            max_phi = max_phi.max(norm(&phi));
            max_de = max_de.max((model.energy(&x) - e0).abs());
        }
        let it = flow.stats().newton_iterations as f64 / steps as f64;
        (x, kind, max_g, max_phi, max_de / e0.abs(), it)
    };
    let (_, kind, g, phi, de, it) = run(2000, 0.0, SolverChoice::Auto, 300);
    println!(
        "2000 free particles: {kind:?}, |g| {g:.1e}, |phi| {phi:.1e}, dE/E {de:.1e}, {it:.2} it/step"
    );
    // Block-diagonal constraints: a band of width 0.
    assert_eq!(kind, SolverKind::Banded);
    // Newton stops at ftol = 16 ε r (|c| + r) ≈ 16 ε · 4000 (positions up to 4000 differenced
    // with the centres); allow that plus the rounding of g itself.
    let tol = 32.0 * f64::EPSILON * 4000.0;
    assert!(g <= tol && phi <= tol, "{g:e} {phi:e}");
    assert!(de <= 1e-4, "{de:e}");
    let (_, _, g, phi, de, it_spring) = run(2000, 50.0, SolverChoice::Auto, 300);
    println!(
        "2000 particles with springs: |g| {g:.1e}, |phi| {phi:.1e}, dE/E {de:.1e}, {it_spring:.2} it/step"
    );
    assert!(g <= tol && phi <= tol, "{g:e} {phi:e}");
    assert!(de <= 1e-4, "{de:e}");
    // Couplings outside the pattern cost iterations (linear convergence), not accuracy.
    assert!(it_spring > it, "{it_spring} vs {it}");
    // Dense and sparse agree on the coupled system too.
    let (xd, ..) = run(80, 5.0, SolverChoice::Force(SolverKind::Dense), 200);
    let (xs, ..) = run(80, 5.0, SolverChoice::Force(SolverKind::Sparse), 200);
    let d = xd
        .as_slice()
        .iter()
        .zip(xs.as_slice())
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    assert!(d <= 1e-11, "{d:e}");
}
