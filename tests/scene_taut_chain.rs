//! A hanging chain long enough that its tension makes the constraint forces' rounding the
//! residual's floor: 10⁴ links of 1 g and 1 mm, h = 10⁻⁴, where `G(q)ᵀλ` rounds at 4e-15 in
//! the Petrov–Galerkin momentum rows while those rows are of size 1e-6. The scheme's noise
//! floor measures that rounding, so its solve stops there instead of iterating on noise until
//! Newton gives up; the constraints stay at round-off.

use lieflow::scene::{Scene, run};

const CHAIN: &str = include_str!("../scenes/chain1000.toml");

#[test]
fn petrov_galerkin_converges_on_a_chain_of_ten_thousand_links() {
    let text = CHAIN.replace("links = 1000", "links = 10000").replace(
        "[integrator]",
        "[[effects]]\ntype = \"damping\"\ncoefficient = 0.01\n\n[integrator]\nscheme = \"petrov-galerkin\"\norder = 4",
    );
    let mut scene = Scene::from_toml(&text, "taut.toml").unwrap_or_else(|e| panic!("{e}"));
    // Eight steps: the solve used to fail at the fifth.
    scene.file.integrator.t_end = 8e-4;
    let mut c = scene.compile().unwrap_or_else(|e| panic!("{e}"));
    let s = run(c.simulation.as_mut(), &c.plan, &mut |_| {});
    assert_eq!(s.error, None, "{s:?}");
    assert_eq!(s.steps, 8);
    // |g| = |(|u|² − ℓ²)/2| rounds at ε ℓ L with ℓ = 1e-3 and the chain's extent L ≈ 8.7.
    let g = s.max_abs_g.unwrap();
    eprintln!(
        "max |g| {g:e}, {} Newton iterations in {} steps",
        s.newton_iterations, s.steps
    );
    assert!(g <= 16.0 * f64::EPSILON * 1e-3 * 8.7, "max |g| {g:e}");
    // Fewer than the solver's 25 a step: it converges, it does not run out.
    assert!(
        s.newton_iterations < 10 * s.steps as u64,
        "{}",
        s.newton_iterations
    );
}
