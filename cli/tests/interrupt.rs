//! Ctrl-C keeps what was computed: a run stops after its step (its CSV, plot and summary
//! written), a work–precision set after its run in progress (its rows, CSV, figures), a sweep
//! starts no further member (the members that ran written); each says `"interrupted": true` and
//! exits with 130. A second Ctrl-C ends the process.
#![cfg(unix)]

mod common;

use common::{pendulum_with, repo, scratch};
use std::io::{BufRead, BufReader, Read};
use std::process::{Command, Stdio};
use std::time::Duration;

/// Runs `lieflow ARGS`, sends it Ctrl-C — `delay` after its first line of stdout when
/// `after_first_line` (the command prints it once it catches Ctrl-C), `delay` after its start
/// otherwise — and checks that it exits with 130 and a summary that says it was interrupted.
/// Returns the first line, the summary and stderr.
fn interrupt(
    args: &[&str],
    after_first_line: bool,
    delay: Duration,
) -> (String, serde_json::Value, String) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_lieflow"))
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut out = BufReader::new(child.stdout.take().unwrap());
    let mut head = String::new();
    if after_first_line {
        out.read_line(&mut head).unwrap();
    }
    std::thread::sleep(delay);
    let sent = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(sent.success());
    let mut rest = String::new();
    out.read_to_string(&mut rest).unwrap();
    let status = child.wait().unwrap();
    let mut err = String::new();
    child
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut err)
        .unwrap();
    assert_eq!(status.code(), Some(130), "{err}");
    let last = rest.lines().last().unwrap_or(&head);
    let summary: serde_json::Value =
        serde_json::from_str(last).unwrap_or_else(|e| panic!("{e}: {last}"));
    assert_eq!(summary["interrupted"], true);
    (head, summary, err)
}

#[test]
fn ctrl_c_stops_the_run_and_keeps_what_it_computed() {
    let scene = pendulum_with("endless.toml", "t_end = 10.0", "t_end = 1e7");
    let (csv, svg) = (scratch("interrupted.csv"), scratch("interrupted.svg"));
    let (_, j, err) = interrupt(
        &[
            "run",
            &scene,
            "--csv",
            csv.to_str().unwrap(),
            "--plot",
            svg.to_str().unwrap(),
        ],
        true,
        Duration::from_millis(300),
    );
    assert!(err.contains("interrupted at t = "), "{err}");
    let steps = j["steps"].as_u64().unwrap();
    assert!(steps > 0 && steps < j["steps_planned"].as_u64().unwrap());
    // The CSV ends with the state the summary reports, and the plot is drawn.
    let rows = std::fs::read_to_string(&csv).unwrap();
    let last_row = rows.lines().last().unwrap();
    assert_eq!(last_row.split(',').next().unwrap(), steps.to_string());
    let t: f64 = last_row.split(',').nth(1).unwrap().parse().unwrap();
    // serde_json reads floats to within an ulp (without its `float_roundtrip` feature).
    let jt = j["t"].as_f64().unwrap();
    assert!(
        (t - jt).abs() <= 2.0 * f64::EPSILON * jt,
        "{t} against {jt}"
    );
    assert!(std::fs::read_to_string(&svg).unwrap().contains("<svg"));
}

#[test]
fn ctrl_c_stops_a_precision_set_and_keeps_its_rows() {
    let dir = scratch("precision_interrupted");
    // The first line follows the reference; Ctrl-C is caught from then on.
    let (head, j, err) = interrupt(
        &[
            "precision",
            &repo("scenes/damped_pendulum.toml"),
            "--f64-reference",
            "--repeats",
            "1",
            "--dt",
            "0.01,0.005,0.0025,0.00125,0.000625,0.0003125",
            "--out",
            dir.to_str().unwrap(),
            "--stem",
            "set",
        ],
        true,
        Duration::from_millis(300),
    );
    assert!(head.contains("reference"), "{head}");
    assert!(err.contains("interrupted: "), "{err}");
    // Fewer rows than the set has (6 step sizes × 8 lieflow methods, then the peers), each in
    // the table and the CSV.
    let rows = j["rows"].as_u64().unwrap();
    assert!(rows > 0 && rows < 48, "{rows} rows");
    let csv = std::fs::read_to_string(dir.join("set.csv")).unwrap();
    let data = csv.lines().filter(|l| !l.starts_with('#')).skip(1).count();
    assert_eq!(data as u64, rows);
    assert!(dir.join("set_time.svg").exists());
}

#[test]
fn ctrl_c_stops_a_sweep_and_writes_the_members_that_ran() {
    let out = scratch("sweep_interrupted");
    // A thousand chains of a hundred links, some 40 s on one thread; it prints nothing until
    // it ends.
    let (_, j, err) = interrupt(
        &[
            "sweep",
            &repo("scenes/sweep_chain100.toml"),
            "--threads",
            "1",
            "--out",
            out.to_str().unwrap(),
        ],
        false,
        Duration::from_millis(1500),
    );
    assert!(err.contains("interrupted: "), "{err}");
    let members = j["members"].as_u64().unwrap();
    assert!(members > 0 && members < 1000, "{members} members");
    let jsonl = std::fs::read_to_string(out.join("members.jsonl")).unwrap();
    assert_eq!(jsonl.lines().count() as u64, members);
}

#[test]
fn ctrl_c_stops_a_run_at_the_accepted_steps_and_keeps_its_rows() {
    // The damped pendulum under a tolerance, endless, at its controller's own steps: the CSV
    // ends with the last accepted step the summary reports.
    let text = std::fs::read_to_string(repo("scenes/damped_pendulum.toml")).unwrap();
    let scene = common::scene_file(
        "endless_tol.toml",
        &text
            .replace("dt = 0.01", "dt = 1e4\ntol = 1e-10")
            .replace("t_end = 10.0", "t_end = 1e7"),
    );
    let csv = scratch("interrupted_steps.csv");
    let (_, j, err) = interrupt(
        &[
            "run",
            &scene,
            "--accepted-steps",
            "--csv",
            csv.to_str().unwrap(),
        ],
        true,
        Duration::from_millis(300),
    );
    assert!(
        err.contains(" accepted step") && err.contains("the CSV"),
        "{err}"
    );
    let steps = j["steps"].as_u64().unwrap();
    assert!(steps > 0);
    assert_eq!(j["adaptive"]["accepted"].as_u64().unwrap(), steps);
    let rows = std::fs::read_to_string(&csv).unwrap();
    let data: Vec<&str> = rows
        .lines()
        .filter(|l| !l.starts_with('#'))
        .skip(1)
        .collect();
    assert_eq!(data.len() as u64, steps + 1);
    assert_eq!(
        data.last().unwrap().split(',').next().unwrap(),
        steps.to_string()
    );
}
