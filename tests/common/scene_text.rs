//! Scene texts in tests: parse, run, set an `[integrator]` key, and the moving damped shell
//! (included with `#[path]` by the scene and mechanical-form tests).
#![allow(dead_code)]

use lieflow::scene::{RunSummary, Scene, SceneModel, run};
use std::sync::Arc;

/// scenes/damped_pendulum.toml reporting every `dt`, with `extra` integrator keys.
/// Two boxes (1 and 2 kg) on a slider along `u = (1, 1, 0)/√2`, the second 0.5 m along `u`
/// from the first and moving away along it at `speed`; `rest` follows the bodies and the
/// slider (effects, inputs, outputs), then `[integrator]` with `dt`, `t_end` and `scheme`.
pub fn boxes_on_a_slider(speed: f64, rest: &str, dt: f64, t_end: f64, scheme: &str) -> String {
    let u = std::f64::consts::FRAC_1_SQRT_2;
    format!(
        r#"
version = 1
dim = 3
[[bodies]]
name = "a"
mass = 1.0
inertia = {{ shape = "box", size = [0.2, 0.1, 0.3] }}
position = [0, 0, 0]
[[bodies]]
name = "b"
mass = 2.0
inertia = {{ shape = "box", size = [0.1, 0.3, 0.2] }}
position = [{p}, {p}, 0]
velocity = [{v}, {v}, 0]
[[constraints]]
type = "slider"
bodies = ["a", "b"]
axis = [1, 1, 0]
{rest}
[integrator]
dt = {dt}
t_end = {t_end}
{scheme}
"#,
        p = 0.5 * u,
        v = speed * u,
    )
}

pub fn damped_pendulum(dt: f64, extra: &str) -> String {
    include_str!("../../scenes/damped_pendulum.toml")
        .replace("dt = 0.01", &format!("dt = {dt}\n{extra}"))
}

pub fn parse(text: &str) -> Scene {
    Scene::from_toml(text, "test.toml").unwrap_or_else(|e| panic!("{e}"))
}

pub fn run_scene(scene: &Scene) -> RunSummary {
    let mut c = scene.compile().unwrap_or_else(|e| panic!("{e}"));
    run(c.simulation.as_mut(), &c.plan, &mut |_| {})
}

/// Replaces the `[integrator]` table's `key = …` line.
pub fn set(text: &str, key: &str, value: &str) -> String {
    let mut out = String::new();
    let mut done = false;
    for line in text.lines() {
        if !done && line.starts_with(&format!("{key} =")) {
            out.push_str(&format!("{key} = {value}\n"));
            done = true;
        } else {
            out.push_str(line);
            out.push('\n');
        }
    }
    assert!(done, "no line `{key} = …`");
    out
}

/// scenes/shell_damped.toml with `extra` effects before its `[integrator]`, compiled: its model
/// and an initial state whose momenta are set off rest tangent to the spheres (`q · p = 0` per
/// particle, so `φ = 0`), so that the pair forces, damping and field terms act from the first
/// step.
pub fn moving_shell(extra: &str) -> (Arc<SceneModel>, faer::Col<f64>) {
    let text = include_str!("../../scenes/shell_damped.toml")
        .replace("[integrator]", &format!("{extra}\n[integrator]"));
    let c = parse(&text).compile().unwrap_or_else(|e| panic!("{e}"));
    let state = c.simulation.state();
    let mut x0 = faer::Col::from_fn(state.len(), |i| state[i]);
    let n = x0.nrows();
    for b in 0..n / 6 {
        let q = [x0[3 * b], x0[3 * b + 1], x0[3 * b + 2]];
        let t = [-q[1], q[0], 0.0];
        for k in 0..3 {
            x0[n / 2 + 3 * b + k] = 0.4 * t[k] * (1.0 + 0.1 * b as f64);
        }
    }
    (c.model.expect("a scene of bodies"), x0)
}

/// scenes/chain1000.toml with `links` links of its 1 g and 1 mm under gravity `g` (downward),
/// damped by 0.01 against the ground, stepped by the `[integrator]` lines `scheme` (e.g.
/// `scheme = "midpoint"`) for `steps` steps of its `h = 1e-4`, nothing observed.
pub fn damped_chain(links: usize, g: f64, scheme: &str, steps: usize) -> Scene {
    let base = include_str!("../../scenes/chain1000.toml");
    assert!(
        base.contains("links = 1000") && base.contains("g = [0.0, -9.81]"),
        "the chain's keys as replaced here"
    );
    let text = base
        .replace("links = 1000", &format!("links = {links}"))
        .replace("g = [0.0, -9.81]", &format!("g = [0.0, {:?}]", -g))
        .replace(
            "[integrator]",
            &format!(
                "[[effects]]\ntype = \"damping\"\ncoefficient = 0.01\n\n[integrator]\n{scheme}\ndiagnostics = []"
            ),
        );
    let mut scene = parse(&text);
    scene.file.integrator.t_end = steps as f64 * scene.file.integrator.dt;
    scene
}
