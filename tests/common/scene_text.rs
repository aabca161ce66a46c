//! Scene texts in tests: parse, run, and set an `[integrator]` key (shared by tests/scene.rs and
//! tests/scene_errors.rs, included with `#[path]`).
#![allow(dead_code)]

use lieflow::scene::{RunSummary, Scene, run};

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
