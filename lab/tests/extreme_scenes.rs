//! Extreme parameters through scenes: mass ratios of 1e±6 between
//! neighbours, links from 1e-6 to 1e3 long, and a chain pinned at both ends pulled almost taut
//! (a nearly singular multiplier system). Each run keeps `g` at the rounding level of its own
//! geometry, or stops with a typed error — never a panic or a non-finite state.

use lieflow::scene::{Scene, run};
use lieflow_lab::stress::{chain_scene as chain, taut_chain_scene};

/// Runs the scene; `Ok(max |g| / (ε ℓ L))` — `g` in units of its rounding level for links of
/// length `ℓ` at distance `L` from the origin — or the error's text.
fn run_scaled(text: &str, l: f64, extent: f64) -> Result<f64, String> {
    let scene = Scene::from_toml(text, "extreme.toml").map_err(|e| e.to_string())?;
    let mut c = scene.compile().map_err(|e| e.to_string())?;
    let s = run(c.simulation.as_mut(), &c.plan, &mut |_| {});
    assert!(s.x.iter().all(|v| v.is_finite()), "a non-finite state");
    if let Some(f) = s.error {
        return Err(format!("{}: {}", f.kind, f.message));
    }
    Ok(s.max_abs_g.unwrap() / (f64::EPSILON * l * extent))
}

#[test]
fn mass_ratios_of_a_million_between_neighbours() {
    for (ratio, dt) in [(1e6, 2e-5), (1e-6, 1e-5)] {
        let masses: Vec<f64> = (0..12)
            .map(|i| if i % 2 == 0 { 1.0 } else { ratio })
            .collect();
        // A light body between heavy ones under the tension T swings across its rods at
        // ω² = T (1/ℓ₁ + 1/ℓ₂)/m_light ≈ 6 · 9.81 · 1e6 · 20 (ω ≈ 3.4e4 for either ratio);
        // at ω h < 2, g = (|u|² − ℓ²)/2 rounds at a few ε ℓ L (the Newton tolerance is 16 ε ℓ L).
        let g = run_scaled(&chain(&masses, 0.1, None, dt, 1000), 0.1, 1.2)
            .unwrap_or_else(|e| panic!("ratio {ratio:e}: {e}"));
        eprintln!("ratio {ratio:e}: max |g| = {g:.1} ε ℓ L");
        assert!(g < 64.0, "ratio {ratio:e}: max |g| = {g} ε ℓ L");
    }
    // 34 times past that limit (h = 1e-3) the step fails with a typed error, never silently.
    let masses: Vec<f64> = (0..12)
        .map(|i| if i % 2 == 0 { 1.0 } else { 1e6 })
        .collect();
    let e = run_scaled(&chain(&masses, 0.1, None, 1e-3, 200), 0.1, 1.2).unwrap_err();
    assert!(e.starts_with("Newton"), "untyped failure {e}");
}

#[test]
fn links_from_a_micrometre_to_a_kilometre() {
    for l in [1e-6f64, 1e-3, 1.0, 1e3] {
        // A step that resolves the chain's fastest swing, √(ℓ/g)/10.
        let dt = (l / 9.81).sqrt() / 10.0;
        let masses = vec![1.0; 8];
        let g = run_scaled(&chain(&masses, l, None, dt, 200), l, 8.0 * l)
            .unwrap_or_else(|e| panic!("l = {l:e}: {e}"));
        eprintln!("l = {l:e}: max |g| = {g:.1} ε ℓ L");
        assert!(g < 64.0, "l = {l:e}: max |g| = {g} ε ℓ L");
    }
}

/// Both ends pinned, the chain 1e-6 (relatively) longer than the distance between its anchors:
/// nearly straight, its multiplier system nearly singular (condition ~1e7). Either it runs with
/// `g` at its rounding level, or it stops with a typed error; it never panics or returns garbage.
#[test]
fn a_chain_pulled_almost_taut() {
    for slack in [1e-3, 1e-6] {
        match run_scaled(&taut_chain_scene(10, slack), 0.1, 1.0) {
            Ok(g) => assert!(g < 64.0, "slack {slack:e}: max |g| = {g} ε ℓ L"),
            Err(e) => assert!(
                e.contains("Newton") || e.contains("redundant") || e.contains("singular"),
                "slack {slack:e}: an untyped failure: {e}"
            ),
        }
    }
}
