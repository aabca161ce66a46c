//! What the command's tests share: running it, reading its output, scratch files.

#![allow(dead_code)]

use std::path::PathBuf;
use std::process::{Command, Output};

pub fn lieflow(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_lieflow"))
        .args(args)
        .output()
        .expect("runs")
}

pub fn stdout(o: &Output) -> String {
    String::from_utf8(o.stdout.clone()).unwrap()
}

pub fn stderr(o: &Output) -> String {
    String::from_utf8(o.stderr.clone()).unwrap()
}

/// The last line of stdout as JSON.
pub fn summary(o: &Output) -> serde_json::Value {
    let out = stdout(o);
    let last = out.lines().last().expect("output");
    serde_json::from_str(last).unwrap_or_else(|e| panic!("{e}: {last}"))
}

pub fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("lieflow-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

pub fn repo(path: &str) -> String {
    format!("{}/../{path}", env!("CARGO_MANIFEST_DIR"))
}

/// Writes `text` as the scene `name` in the scratch directory and returns its path.
pub fn scene_file(name: &str, text: &str) -> String {
    let path = scratch(name);
    std::fs::write(&path, text).unwrap();
    path.display().to_string()
}

/// The damped pendulum of the repository's scenes with `from` replaced by `to`.
pub fn pendulum_with(name: &str, from: &str, to: &str) -> String {
    let text = std::fs::read_to_string(repo("scenes/damped_pendulum.toml")).unwrap();
    assert!(text.contains(from), "the pendulum scene has no `{from}`");
    scene_file(name, &text.replace(from, to))
}
