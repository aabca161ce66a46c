//! A hanging chain long enough that its tension makes the constraint forces' rounding the
//! residual's floor: 10⁴ links of 1 g and 1 mm, h = 10⁻⁴, where `G(q)ᵀλ` rounds at 4e-15 in
//! the Petrov–Galerkin momentum rows while those rows are of size 1e-6. The scheme's noise
//! floor measures that rounding, so its solve stops there instead of iterating on noise until
//! Newton gives up; the constraints stay at round-off.

use crate::scene_text;

use lieflow::scene::{Scene, run};
use scene_text::{damped_chain, run_scene};

const CHAIN: &str = include_str!("../../scenes/chain1000.toml");

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

/// Linear time per step: a step's work is a number of iterations, residual evaluations and
/// band solves each linear in the number of links, so the step is linear in `N` when those
/// counts do not grow with it. They depend on the stiffness of the chain's top links (their
/// transverse waves' `ωh`, `ω² = 2T/(mℓ)`), which under one gravity grows with the length: so
/// the lengths are compared at one tension profile, gravity scaled by `1000/N` (every fraction
/// of the chain carries the tension of the same fraction of the 1000-link chain).
#[test]
fn an_implicit_step_does_no_more_work_a_link_on_a_longer_chain_of_the_same_tension() {
    let counts = |links: usize, scheme: &str| {
        let s = run_scene(&damped_chain(
            links,
            9.81 * 1000.0 / links as f64,
            scheme,
            100,
        ));
        assert_eq!(s.error, None, "{scheme}, {links} links");
        assert_eq!(s.steps, 100);
        let per_step = |v: u64| v as f64 / s.steps as f64;
        (
            per_step(s.newton_iterations),
            per_step(s.residual_evaluations),
        )
    };
    for scheme in [
        "scheme = \"midpoint\"",
        "scheme = \"discrete-gradient\"",
        "scheme = \"petrov-galerkin\"\norder = 4",
    ] {
        let (short, long) = (counts(300, scheme), counts(3000, scheme));
        eprintln!(
            "{scheme}: iterations, residuals a step: 300 links {short:.2?}, 3000 links {long:.2?}"
        );
        // Not more a step on ten times the links (a quarter of an iteration for the spread of
        // the runs' transients).
        assert!(long.0 <= short.0 + 0.25, "{scheme}: {short:?} → {long:?}");
        assert!(long.1 <= short.1 + 0.25, "{scheme}: {short:?} → {long:?}");
    }
}
