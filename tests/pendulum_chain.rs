//! The N-link pendulum chain (Cartesian, planar and spatial) by RATTLE on heap storage with the
//! dense backend: constraint and hidden-constraint residuals at round-off, bounded energy error.
//! (The sparse backend and the 10⁵-link scaling of issue 3 build on this model.)

use faer::Col;
use lieflow::models::PendulumChain;
use lieflow::prelude::*;

fn residuals(model: &PendulumChain<f64>, x: &Col<f64>) -> (f64, f64) {
    let sys = model.system();
    let m = model.links();
    let (mut g, mut phi) = (vec![0.0; m], vec![0.0; m]);
    let (mut t1, mut t2) = (x.clone(), x.clone());
    sys.constraint.residual(x, &mut g);
    sys.hidden_constraint(x, &mut t1, &mut t2, &mut phi);
    let norm = |v: &[f64]| v.iter().fold(0.0f64, |a, b| a.max(b.abs()));
    (norm(&g), norm(&phi))
}

#[test]
fn rattle_keeps_the_chain_on_its_constraints() {
    for dim in [2, 3] {
        let model = PendulumChain::<f64>::uniform(dim, 8).unwrap();
        let x0: Col<f64> = model.at_rest(|i| 0.3 + 0.1 * i as f64);
        let (g0, _) = residuals(&model, &x0);
        assert!(g0 <= 1e-15, "initial state off the rods: {g0:e}");
        let mut flow = model
            .kick()
            .strang(model.drift())
            .projected(model.system(), &x0, ProjectionOptions::default())
            .unwrap();
        let e0 = model.energy(&x0);
        let mut x = x0.clone();
        let (mut max_g, mut max_phi, mut max_de) = (0.0f64, 0.0f64, 0.0f64);
        for _ in 0..1000 {
            flow.step(0.005, &mut x).unwrap();
            let (g, phi) = residuals(&model, &x);
            max_g = max_g.max(g);
            max_phi = max_phi.max(phi);
            max_de = max_de.max((model.energy(&x) - e0).abs());
        }
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
