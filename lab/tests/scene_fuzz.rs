//! Hostile scene files: mutated versions of the shipped scenes — a number replaced by an
//! extreme, non-finite or wrong-typed value, a line dropped or repeated, a key renamed — never
//! panic. Each is either refused with a located error or compiles, and then a short run ends with
//! a summary (possibly with a typed failure), never a crash or a non-finite state.

use lieflow::scene::{DEFAULT_SCENE, Scene, run};
use proptest::prelude::*;

const ALL_EFFECTS: &str = include_str!("../../scenes/all_effects.toml");
const SHELL: &str = include_str!("../../scenes/shell_damped.toml");

/// Values a mutated field may take: extremes, non-finite, zero, negatives, wrong types.
const VALUES: &[&str] = &[
    "0",
    "0.0",
    "-1.0",
    "1e-300",
    "1e300",
    "nan",
    "inf",
    "-inf",
    "3",
    "1000",
    "-7",
    "\"text\"",
    "[]",
    "[1.0]",
    "[1.0, 2.0, 3.0, 4.0]",
    "true",
    "1e-12",
    "0.5",
];

/// The mutation: which text, which line, what to do with it.
#[derive(Debug, Clone)]
enum Mutation {
    /// Replace the value of the `line`-th `key = value` line.
    Value { line: usize, value: usize },
    /// Drop a line.
    Drop { line: usize },
    /// Repeat a line.
    Repeat { line: usize },
    /// Rename the key of a line.
    Rename { line: usize },
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        4 => (0..200usize, 0..VALUES.len()).prop_map(|(line, value)| Mutation::Value { line, value }),
        1 => (0..200usize).prop_map(|line| Mutation::Drop { line }),
        1 => (0..200usize).prop_map(|line| Mutation::Repeat { line }),
        1 => (0..200usize).prop_map(|line| Mutation::Rename { line }),
    ]
}

fn apply(text: &str, m: &Mutation) -> String {
    let lines: Vec<&str> = text.lines().collect();
    let assignments: Vec<usize> = lines
        .iter()
        .enumerate()
        .filter(|(_, l)| l.contains('=') && !l.trim_start().starts_with('#'))
        .map(|(i, _)| i)
        .collect();
    let mut out: Vec<String> = lines.iter().map(|l| l.to_string()).collect();
    match *m {
        Mutation::Value { line, value } => {
            let i = assignments[line % assignments.len()];
            let key = out[i].split('=').next().unwrap().to_owned();
            out[i] = format!("{key}= {}", VALUES[value]);
        }
        Mutation::Drop { line } => {
            out.remove(line % out.len());
        }
        Mutation::Repeat { line } => {
            let i = line % out.len();
            let l = out[i].clone();
            out.insert(i, l);
        }
        Mutation::Rename { line } => {
            let i = assignments[line % assignments.len()];
            out[i] = format!("x{}", out[i].trim_start());
        }
    }
    out.join("\n")
}

/// Parses, compiles and runs at most 30 steps; every outcome but a panic is acceptable, and a
/// run that ends reports a finite state.
fn exercise(text: &str) {
    let Ok(mut scene) = Scene::from_toml(text, "fuzz.toml") else {
        return;
    };
    // Bound the work: at most 30 steps of whatever step size the file now has.
    let dt = scene.file.integrator.dt;
    if dt.is_finite() && dt > 0.0 {
        scene.file.integrator.t_end = 30.0 * dt;
    }
    match scene.compile() {
        Err(e) => {
            // A refused scene says where, when it came from text and the field exists.
            assert!(!e.message.is_empty());
        }
        Ok(mut c) => {
            let s = run(c.simulation.as_mut(), &c.plan, &mut |_| {});
            assert!(s.steps <= s.steps_planned);
            assert!(
                s.x.iter().all(|v| v.is_finite()),
                "a run ended with a non-finite state: {:?}",
                s.error
            );
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 96, ..ProptestConfig::default() })]

    #[test]
    fn mutated_default_scenes_never_panic(m in mutation()) {
        exercise(&apply(DEFAULT_SCENE, &m));
    }

    #[test]
    fn mutated_all_effects_scenes_never_panic(m in mutation()) {
        exercise(&apply(ALL_EFFECTS, &m));
    }

    #[test]
    fn mutated_shell_scenes_never_panic(m in mutation()) {
        exercise(&apply(SHELL, &m));
    }
}

/// Runs a generated scene: a typed error, or a finite state whose `max |g|` is within `g_bound`.
fn random_system_outcome(text: &str, g_bound: f64) -> Result<(), TestCaseError> {
    let scene = match Scene::from_toml(text, "random.toml") {
        Ok(s) => s,
        Err(e) => {
            return Err(TestCaseError::fail(format!(
                "a generated scene must parse: {e}"
            )));
        }
    };
    let Ok(mut c) = scene.compile() else {
        return Ok(()); // refused with a located error: acceptable
    };
    let s = run(c.simulation.as_mut(), &c.plan, &mut |_| {});
    prop_assert!(
        s.x.iter().all(|v| v.is_finite()),
        "non-finite state ({:?})",
        s.error
    );
    if s.error.is_none() {
        let g = s.max_abs_g.unwrap_or(0.0);
        prop_assert!(g <= g_bound, "max |g| = {g:e} > {g_bound:e}");
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    /// Random planar chains: 1–12 links of length ℓ in [1e-3, 10], masses in [1e-3, 1e3] (ratios
    /// up to 1e6), step sizes from 1e-4 to 1 times the fastest swing `√(ℓ/g)`, 50 steps.
    /// `g = (|u|² − ℓ²)/2` rounds at a few `ε ℓ L`; the bound is `64 ε ℓ L` (`L` = the chain's
    /// reach).
    #[test]
    fn random_chains_run_or_fail_typed(
        masses in prop::collection::vec(-3.0f64..3.0, 1..12),
        log_l in -3.0f64..1.0,
        log_step in -4.0f64..0.0,
    ) {
        let l = 10f64.powf(log_l);
        let masses: Vec<f64> = masses.iter().map(|e| 10f64.powf(*e)).collect();
        let dt = 10f64.powf(log_step) * (l / 9.81).sqrt();
        let text = lieflow_lab::stress::chain_scene(&masses, l, None, dt, 50);
        let reach = l * masses.len() as f64;
        random_system_outcome(&text, 64.0 * f64::EPSILON * l * reach)?;
    }

    /// Random particles on a sphere: 2–24 of them, radius in [1e-2, 1e2], logarithmic repulsion
    /// of strength in [1e-2, 1e2], damping in [0, 10], step sizes from 1e-4 to 1e-1, 50 steps.
    /// `g = (|q − c|² − r²)/2` rounds at a few `ε r²`; the bound is `64 ε r²`.
    #[test]
    fn random_sphere_particles_run_or_fail_typed(
        n in 2usize..24,
        log_r in -2.0f64..2.0,
        log_s in -2.0f64..2.0,
        damping in 0.0f64..10.0,
        log_dt in -4.0f64..-1.0,
    ) {
        let (r, s, dt) = (10f64.powf(log_r), 10f64.powf(log_s), 10f64.powf(log_dt));
        let text = format!(
            "version = 1\ndim = 3\n[[shells]]\nname = \"p\"\nradius = {r:e}\nmass = 1.0\nrings = [{}, {}]\n\
             [[effects]]\ntype = \"pair\"\nlaw = \"log\"\nstrength = {s:e}\n\
             [[effects]]\ntype = \"damping\"\ncoefficient = {damping:e}\n\
             [integrator]\ndt = {dt:e}\nt_end = {:e}\n",
            n / 2,
            n - n / 2,
            50.0 * dt
        );
        random_system_outcome(&text, 64.0 * f64::EPSILON * r * r)?;
    }
}
