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
    // Eight steps: the solve used to fail at the fifth (t = 4e-4).
    scene.file.integrator.t_end = 8e-4;
    let mut c = scene.compile().unwrap_or_else(|e| panic!("{e}"));
    let s = run(c.simulation.as_mut(), &c.plan, &mut |_| {});
    assert_eq!(s.error, None);
    assert_eq!(s.steps, 8);
    // The solve accepts the constraint rows at 100 ftol (a stalled residual at its noise), with
    // the scene's ftol = 16 ε ℓ E: ℓ = 1e-3 the link length, E ≈ 8.7 m the chain's extent.
    let g = s.max_abs_g.unwrap();
    eprintln!(
        "max |g| {g:e}, {} Newton iterations in {} steps",
        s.newton_iterations, s.steps
    );
    assert!(
        g <= 100.0 * 16.0 * f64::EPSILON * 1e-3 * 8.7,
        "max |g| {g:e}"
    );
    // Fewer than the solver's 25 a step: it converges, it does not run out.
    assert!(
        s.newton_iterations < 10 * s.steps as u64,
        "{}",
        s.newton_iterations
    );
}
