//! The examples' command lines and final JSON line are an interface: flags, exit codes, keys.
//! `cargo test` builds the examples next to the test binaries (`target/<profile>/examples`).

use std::path::PathBuf;
use std::process::Command;

fn example(name: &str) -> PathBuf {
    let exe = std::env::current_exe().unwrap();
    let dir = exe.parent().unwrap().parent().unwrap().join("examples");
    let path = dir.join(name);
    assert!(path.exists(), "example binary {} not built", path.display());
    path
}

fn run(name: &str, args: &[&str]) -> (i32, String, String) {
    let out = Command::new(example(name)).args(args).output().unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// The value of `"key":` in a one-line JSON object (numbers and strings only).
fn field<'a>(json: &'a str, key: &str) -> &'a str {
    let pat = format!("\"{key}\":");
    let start = json
        .find(&pat)
        .unwrap_or_else(|| panic!("no key {key} in {json}"))
        + pat.len();
    let rest = &json[start..];
    let end = if rest.starts_with('[') {
        rest.find(']').unwrap() + 1
    } else if let Some(quoted) = rest.strip_prefix('"') {
        quoted.find('"').unwrap() + 2
    } else {
        rest.find([',', '}']).unwrap()
    };
    &rest[..end]
}

#[test]
fn paper_example_prints_the_json_contract_last() {
    let (code, out, _) = run(
        "paper_example",
        &["--t-end", "5", "--scheme", "triple-jump"],
    );
    assert_eq!(code, 0);
    let last = out.lines().last().unwrap();
    assert!(last.starts_with('{') && last.ends_with('}'), "{last}");
    for key in [
        "t",
        "x",
        "steps",
        "max_abs_g",
        "max_abs_phi",
        "h_tilde_max_err",
        "newton_iterations",
        "ns_per_step",
    ] {
        field(last, key);
    }
    assert_eq!(field(last, "steps"), "50");
    assert_eq!(field(last, "scheme"), "\"triple-jump\"");
    let g: f64 = field(last, "max_abs_g").parse().unwrap();
    assert!(g <= 1e-14);
    // The §2 scheme (modified Hamiltonian) is selectable and keeps the residuals at round-off.
    let (code, out, err) = run("paper_example", &["--t-end", "5", "--scheme", "modified"]);
    assert_eq!(code, 0, "{err}");
    let last = out.lines().last().unwrap();
    for key in ["max_abs_g", "max_abs_phi"] {
        let v: f64 = field(last, key).parse().unwrap();
        assert!(v <= 1e-15, "{key} = {v:e}");
    }
}

#[test]
fn spherical_pendulum_prints_the_json_contract_last() {
    let (code, out, _) = run("spherical_pendulum", &["--t-end", "1"]);
    assert_eq!(code, 0);
    let last = out.lines().last().unwrap();
    for key in [
        "t",
        "x",
        "steps",
        "max_abs_g",
        "max_abs_phi",
        "energy_max_err",
        "ns_per_step",
    ] {
        field(last, key);
    }
    let e: f64 = field(last, "energy_max_err").parse().unwrap();
    assert!(e.is_finite() && e < 1e-2);
}

#[test]
fn rigid_body_prints_the_json_contract_last() {
    let (code, out, _) = run("rigid_body", &["--t-end", "10"]);
    assert_eq!(code, 0);
    let last = out.lines().last().unwrap();
    for key in [
        "t",
        "x",
        "steps",
        "casimir_max_err",
        "energy_max_err",
        "ns_per_step",
    ] {
        field(last, key);
    }
    let c: f64 = field(last, "casimir_max_err").parse().unwrap();
    assert!(c <= 1e-14, "{c:e}");
}

#[test]
fn spinning_top_prints_the_json_contract_last() {
    let (code, out, _) = run("spinning_top", &["--t-end", "0.5", "--dt", "5e-4"]);
    assert_eq!(code, 0);
    let last = out.lines().last().unwrap();
    for key in [
        "t",
        "x",
        "steps",
        "max_abs_g",
        "energy_max_err",
        "ns_per_step",
    ] {
        field(last, key);
    }
    // The rows at round-off; the axis on its steady precession to the step's O(h²) error
    // (2e-5 at h = 5e-4 in `rigid::a_lagrange_top…`).
    let g: f64 = field(last, "max_abs_g").parse().unwrap();
    assert!(g <= 1e-14, "{g:e}");
    let a: f64 = field(last, "azimuth_err").parse().unwrap();
    assert!(a <= 1e-4, "{a:e}");
}

/// The damped pendulum: the discrete gradient never increases H across step sizes; the
/// projection scheme keeps the residuals at round-off; a triple jump is refused (exit 1).
#[test]
fn damped_pendulum_prints_the_json_contract_last() {
    for dt in ["0.001", "0.1", "1"] {
        let (code, out, err) = run(
            "damped_pendulum",
            &["--scheme", "discrete-gradient", "--dt", dt, "--t-end", "5"],
        );
        assert_eq!(code, 0, "{err}");
        let last = out.lines().last().unwrap();
        for key in [
            "t",
            "x",
            "energy",
            "max_abs_g",
            "max_abs_phi",
            "ns_per_step",
        ] {
            field(last, key);
        }
        assert_eq!(field(last, "energy_increase_steps"), "0", "dt {dt}: {last}");
    }
    let (code, out, _) = run("damped_pendulum", &["--t-end", "5"]);
    assert_eq!(code, 0);
    let last = out.lines().last().unwrap();
    for key in ["max_abs_g", "max_abs_phi"] {
        let v: f64 = field(last, key).parse().unwrap();
        assert!(v <= 1e-13, "{key} = {v:e}");
    }
    let (code, _, err) = run("damped_pendulum", &["--scheme", "triple-jump"]);
    assert_eq!(code, 1);
    assert!(err.contains("backward sub-step"), "{err}");
    let (code, _, err) = run("damped_pendulum", &["--damping", "-1"]);
    assert_eq!(code, 2, "{err}");
}

/// Stiff damping c = 1e6 at h = 0.1: the exact-damping splitting, the implicit flows and the
/// exact flow decay monotonically; the triple jump is refused; explicit damping blows up.
#[test]
fn stiff_chain_sorts_the_schemes() {
    let (code, out, err) = run("stiff_chain", &[]);
    assert_eq!(code, 0, "{err}");
    let last = out.lines().last().unwrap();
    assert_eq!(
        field(last, "monotone"),
        "\"strang-exact-damping,discrete-gradient,implicit-midpoint,exact\""
    );
    assert_eq!(field(last, "refused"), "\"triple-jump\"");
    assert_eq!(field(last, "unstable"), "\"explicit-damping\"");
    let (code, out, _) = run("stiff_chain", &["--scheme", "discrete-gradient"]);
    assert_eq!(code, 0);
    let last = out.lines().last().unwrap();
    assert_eq!(field(last, "energy_increase_steps"), "0");
}

/// The N-link chain: the JSON contract, the backend flag, and bad values.
#[test]
fn chain_prints_the_json_contract_last() {
    let mut energies = Vec::new();
    for solver in ["sparse", "dense", "banded", "auto"] {
        let (code, out, err) = run(
            "chain",
            &["--links", "300", "--steps", "100", "--solver", solver],
        );
        assert_eq!(code, 0, "{err}");
        let last = out.lines().last().unwrap();
        for key in [
            "t",
            "steps",
            "links",
            "max_abs_g",
            "max_abs_phi",
            "energy_max_err",
            "newton_iterations",
            "ns_per_step",
            "peak_rss_mb",
        ] {
            field(last, key);
        }
        assert_eq!(field(last, "links"), "300");
        assert_eq!(field(last, "steps"), "100");
        // Auto takes the band solver for the chain's tridiagonal multiplier systems.
        let expected = if solver == "auto" { "banded" } else { solver };
        assert_eq!(field(last, "solver"), format!("\"{expected}\""));
        let g: f64 = field(last, "max_abs_g").parse().unwrap();
        let phi: f64 = field(last, "max_abs_phi").parse().unwrap();
        assert!(g <= 1e-12 && phi <= 1e-12, "{last}");
        energies.push(field(last, "energy_max_err").to_string());
    }
    // Same trajectory whatever the backend (the energy error agrees to its printed digits
    // except the last few).
    let e: Vec<f64> = energies.iter().map(|v| v.parse().unwrap()).collect();
    assert!((e[0] - e[1]).abs() <= 1e-6 * e[0].abs(), "{e:?}");
    assert_eq!(e[0], e[2], "auto picks sparse for 300 links");
    for args in [
        &["--links", "0"][..],
        &["--solver", "lu"],
        &["--dim", "4"],
        &["--links", "10000", "--solver", "dense"],
    ] {
        let (code, _, err) = run("chain", args);
        assert_eq!(code, 2, "{args:?}: {err}");
    }
}

#[test]
fn bad_flags_exit_2_with_a_message_and_help_exits_0() {
    for args in [
        &["--bogus", "1"][..],
        &["--dt", "-0.1"],
        &["--dt", "abc"],
        &["--scheme", "rk4"],
        &["--t-end"],
    ] {
        for name in [
            "paper_example",
            "spherical_pendulum",
            "rigid_body",
            "spinning_top",
            "damped_pendulum",
            "stiff_chain",
            "chain",
        ] {
            let (code, out, err) = run(name, args);
            assert_eq!(code, 2, "{name} {args:?}: exit {code}, stdout {out}");
            assert!(err.contains("error:"), "{name} {args:?}: {err}");
        }
    }
    let (code, out, _) = run("paper_example", &["--help"]);
    assert_eq!(code, 0);
    assert!(out.contains("--scheme") && out.contains("--plot"));
}

#[test]
fn long_horizon_prints_the_json_contract_last() {
    let (code, out, err) = run(
        "long_horizon",
        &["--t-end", "200", "--repeat", "1", "--target", "1e-6"],
    );
    assert_eq!(code, 0, "{err}");
    let last = out.lines().last().unwrap();
    assert!(last.starts_with('{') && last.ends_with('}'), "{last}");
    for key in [
        "t",
        "x",
        "steps",
        "max_abs_g",
        "ns_per_step",
        "lieflow_error",
        "lieflow_ms",
        "peer_best_error",
        "peer_best_ms",
        "peer_max_abs_g",
    ] {
        field(last, key);
    }
    // Every lieflow run keeps g at round-off; the peer's reduced ODE lets it drift.
    let g: f64 = field(last, "max_abs_g").parse().unwrap();
    assert!(g <= 1e-15, "{g:e}");
    let e: f64 = field(last, "lieflow_error").parse().unwrap();
    assert!(e <= 1e-6, "{e:e}");
    let (code, _, err) = run("long_horizon", &["--repeat", "x"]);
    assert_eq!(code, 2, "{err}");
}

#[test]
fn control_loop_reaches_its_target_on_the_sphere() {
    let (code, out, err) = run("control_loop", &["--t-end", "8"]);
    assert_eq!(code, 0, "{err}");
    let last = out.lines().last().unwrap();
    let angle_error: f64 = field(last, "angle_error").parse().unwrap();
    let max_g: f64 = field(last, "max_abs_g").parse().unwrap();
    let balance: f64 = field(last, "energy_balance_error").parse().unwrap();
    assert!(angle_error.abs() < 1e-3, "{last}");
    assert!(max_g < 1e-14, "{last}");
    assert_eq!(field(last, "samples"), "400");
    // The balance H(T) − H(0) = supplied closes at the composition's order 4 with a held
    // (piecewise-constant) torque: halving the step divides its error by 16.
    let (_, out, _) = run("control_loop", &["--t-end", "8", "--dt", "0.002"]);
    let coarse: f64 = field(out.lines().last().unwrap(), "energy_balance_error")
        .parse()
        .unwrap();
    let ratio = coarse / balance;
    assert!(
        (14.0..18.0).contains(&ratio),
        "{coarse} / {balance} = {ratio}"
    );
}
