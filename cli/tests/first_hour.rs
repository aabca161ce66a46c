//! What a new user meets in the first hour with the command: steps that end at `t_end`, flags
//! parsed as written, outputs checked before a run, counts and
//! numbers printed as a person reads them, and diagnostics that name the right cause.

mod common;

use common::{lieflow, pendulum_with, repo, scene_file, scratch, stderr, stdout, summary};
use std::process::{Command, Stdio};

#[test]
fn a_step_that_does_not_divide_t_end_ends_exactly_there_with_a_shorter_last_step() {
    let o = lieflow(&["run", &repo("scenes/damped_pendulum.toml"), "--dt", "0.003"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let j = summary(&o);
    // 3333 steps of 0.003 reach 9.999; one of 0.001 lands on 10.
    assert_eq!(j["t"].as_f64().unwrap(), 10.0);
    assert_eq!(j["steps"], 3334);
    assert_eq!(j["steps_planned"], 3334);
    assert!((j["last_step"].as_f64().unwrap() - 0.001).abs() < 1e-12);
    let head = stdout(&o).lines().next().unwrap().to_owned();
    assert!(
        head.contains("3334 steps (the last 1e-3 long, to end at t_end = 10)"),
        "{head}"
    );
    // The same from the file.
    let f = pendulum_with("divide.toml", "dt = 0.01", "dt = 0.003");
    let j = summary(&lieflow(&["run", &f]));
    assert_eq!(j["t"].as_f64().unwrap(), 10.0);
    assert_eq!(j["steps"], 3334);
    // A dividing step has no last step.
    let j = summary(&lieflow(&[
        "run",
        &repo("scenes/damped_pendulum.toml"),
        "--t-end",
        "1",
    ]));
    assert!(j["last_step"].is_null());
    assert_eq!(j["steps"], 100);
}

#[test]
fn a_step_longer_than_the_run_is_refused_from_the_file_and_from_the_flag() {
    let o = lieflow(&["run", &repo("scenes/damped_pendulum.toml"), "--dt", "30"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stdout(&o).is_empty(), "nothing ran");
    assert!(
        stderr(&o).contains("--dt: the step dt = 30 is longer than the run (t_end = 10)"),
        "{}",
        stderr(&o)
    );
    let f = pendulum_with("long_step.toml", "dt = 0.01", "dt = 50");
    let o = lieflow(&["run", &f]);
    assert_eq!(o.status.code(), Some(2));
    let e = stderr(&o);
    assert!(
        e.contains("`integrator.dt`") && e.contains("the step dt = 50 is longer than the run"),
        "{e}"
    );
}

#[test]
fn a_negative_step_is_read_as_a_number_and_refused() {
    for flag in ["--dt", "--t-end"] {
        let o = lieflow(&["run", &repo("scenes/damped_pendulum.toml"), flag, "-0.001"]);
        assert_eq!(o.status.code(), Some(2));
        assert!(
            stderr(&o).contains(&format!("{flag} must be positive and finite, not -0.001")),
            "{}",
            stderr(&o)
        );
    }
}

#[test]
fn zero_damping_dissipates_zero_not_nothing() {
    let f = pendulum_with("undamped.toml", "coefficient = 0.5", "coefficient = 0.0");
    let o = lieflow(&["run", &f, "--t-end", "1"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let j = summary(&o);
    assert_eq!(j["dissipated"].as_f64(), Some(0.0));
    // The budget error is then the energy error itself.
    assert_eq!(j["max_energy_balance_error"], j["max_abs_energy_error"]);
    assert!(stdout(&o).contains("dissipated 0, supplied -"));
}

#[test]
fn counts_are_singular_for_one_and_built_in_models_describe_themselves() {
    let o = lieflow(&[
        "run",
        &repo("scenes/damped_pendulum.toml"),
        "--t-end",
        "0.1",
    ]);
    let head = stdout(&o).lines().next().unwrap().to_owned();
    assert!(
        head.starts_with("damped pendulum: 1 body, 1 constraint row, "),
        "{head}"
    );
    let o = lieflow(&["check", &repo("scenes/damped_pendulum.toml")]);
    let text = stdout(&o);
    assert!(text.contains("2D, 1 body, state of 4"), "{text}");
    assert!(text.contains("constraints  1 row: 1 rod"), "{text}");

    let rb = scene_file(
        "rigid_body.toml",
        "version = 1\nname = \"rb\"\n[builtin]\nmodel = \"rigid-body\"\n[integrator]\ndt = 0.01\nt_end = 0.1\n",
    );
    let text = stdout(&lieflow(&["check", &rb]));
    assert!(
        text.contains("structure    J non-canonical (Lie–Poisson, the rigid body's angular momentum), conservative"),
        "{text}"
    );
    assert!(!text.contains("magnetic"), "{text}");
    assert!(text.contains("constraints  none"), "{text}");
    let o = lieflow(&["run", &rb]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    assert!(
        text.starts_with("rb: built-in model, state of 3, implicit midpoint rule"),
        "{text}"
    );
    assert!(!text.contains("0 bodies"), "{text}");
    assert!(
        !text.contains("evaluations: \n"),
        "an empty evaluations line: {text}"
    );
    assert!(
        !text.contains("max |g|"),
        "no residual line without constraints: {text}"
    );
}

#[test]
fn numbers_print_in_one_format() {
    // A heavy body: its energy is -7.848e18, not nineteen digits and a fraction.
    let f = pendulum_with("heavy.toml", "mass = 1.0", "mass = 8e17");
    let o = lieflow(&["run", &f, "--t-end", "0.1"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    let energy = text.lines().find(|l| l.contains("energy ")).unwrap();
    assert!(energy.contains("energy -3.924e18 -> -3.924"), "{energy}");
    for line in text.lines().filter(|l| !l.starts_with('{')) {
        assert!(
            line.len() < 200,
            "a line of {} characters: {line}",
            line.len()
        );
    }
    // A tiny step: the time reads 1e-5, not 0.000009999999999999999.
    let o = lieflow(&[
        "run",
        &repo("scenes/damped_pendulum.toml"),
        "--dt",
        "1e-8",
        "--t-end",
        "1e-5",
    ]);
    let text = stdout(&o);
    assert!(text.contains("  t = 1e-5, 1000 of 1000 steps"), "{text}");
    // The CSV keeps every digit in the shortest form that reads back exactly.
    let csv = scratch("tiny.csv");
    let o = lieflow(&["run", &f, "--t-end", "0.1", "--csv", csv.to_str().unwrap()]);
    assert!(o.status.success());
    let rows = std::fs::read_to_string(&csv).unwrap();
    assert!(
        rows.lines().all(|l| l.len() < 2000),
        "a row of hundreds of digits"
    );
    let column = rows
        .lines()
        .find(|l| l.starts_with("step,"))
        .unwrap()
        .split(',')
        .position(|c| c == "energy")
        .unwrap();
    let last = rows.lines().last().unwrap();
    let energy: f64 = last.split(',').nth(column).unwrap().parse().unwrap();
    let final_energy = summary(&o)["energy_final"].as_f64().unwrap();
    assert!((energy - final_energy).abs() <= 2.0 * f64::EPSILON * final_energy.abs());
}

#[cfg(unix)]
#[test]
fn a_closed_pipe_ends_the_command_without_a_panic() {
    let mut child = Command::new(env!("CARGO_BIN_EXE_lieflow"))
        .args([
            "run",
            &repo("scenes/damped_pendulum.toml"),
            "--t-end",
            "0.1",
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let status = child.wait().unwrap();
    let mut err = String::new();
    std::io::Read::read_to_string(&mut child.stderr.take().unwrap(), &mut err).unwrap();
    assert!(!err.contains("panicked"), "{err}");
    assert!(!status.success() || err.is_empty());
}

#[test]
fn a_mass_ratio_is_not_reported_as_redundant_constraints() {
    let f = scene_file(
        "mass_ratio.toml",
        r#"version = 1
name = "light second bob"
dim = 2
[[bodies]]
name = "a"
mass = 1.0
position = [1.0, 0.0]
[[bodies]]
name = "b"
mass = 1e-300
position = [2.0, 0.0]
[[constraints]]
type = "rod"
bodies = ["a"]
point = [0.0, 0.0]
length = 1.0
[[constraints]]
type = "rod"
bodies = ["a", "b"]
length = 1.0
[integrator]
dt = 0.01
t_end = 1.0
"#,
    );
    let o = lieflow(&["run", &f]);
    assert_eq!(o.status.code(), Some(2));
    let e = stderr(&o);
    assert!(
        e.contains("a mass ratio of 1.0e300 among the constrained bodies ('b' 1e-300, 'a' 1e0)"),
        "{e}"
    );
    assert!(e.contains("the constraints are independent"), "{e}");
    assert!(!e.contains("redundant"), "{e}");
    // Truly redundant constraints still say so: the same rod twice.
    let text = std::fs::read_to_string(&f)
        .unwrap()
        .replace("mass = 1e-300", "mass = 1.0")
        + "[[constraints]]\ntype = \"rod\"\nbodies = [\"a\"]\npoint = [0.0, 0.0]\nlength = 1.0\n";
    let text = text.replace("[integrator]\ndt = 0.01\nt_end = 1.0\n", "")
        + "[integrator]\ndt = 0.01\nt_end = 1.0\n";
    let g = scene_file("redundant.toml", &text);
    let e = stderr(&lieflow(&["run", &g]));
    assert!(e.contains("the constraints are redundant"), "{e}");
}

#[test]
fn a_newton_failure_says_what_failed_and_what_to_try() {
    // The default scene (stiff coupling springs) at fifty times its step.
    let o = lieflow(&["run", "--dt", "0.5", "--t-end", "20"]);
    assert_eq!(o.status.code(), Some(1));
    let e = stderr(&o);
    assert!(
        e.contains("failed (Newton): lambda_k from g(x_{k+1}) = 0: Newton did not converge in 25 iterations (residual "),
        "{e}"
    );
    assert!(e.contains("what to try: the multiplier solve failed at this step size; try a smaller step (dt = 1.25e-1 or less"), "{e}");
    let j = summary(&o);
    assert!(
        j["error"]["advice"]
            .as_str()
            .unwrap()
            .contains("implicit scheme")
    );
}

#[test]
fn a_sweep_with_a_path_the_scene_lacks_is_refused_before_any_member_runs() {
    let out = scratch("bad_sweep_out");
    for (path, says) in [
        (
            "effects[5].coefficient",
            "the base scene has no element [5] (it has 2)",
        ),
        ("effects[1].coeficient", "unknown field `coeficient`"),
    ] {
        let sweep = scene_file(
            "bad_sweep.toml",
            &format!(
                "version = 1\nscene = \"{}\"\nmode = \"grid\"\n[[parameters]]\npath = \"{path}\"\nvalues = [0.1, 0.2]\n",
                repo("scenes/damped_pendulum.toml")
            ),
        );
        let o = lieflow(&["sweep", &sweep, "--out", out.to_str().unwrap()]);
        assert_eq!(o.status.code(), Some(2), "{path}");
        let e = stderr(&o);
        assert!(
            e.contains("the parameters do not fit the base scene") && e.contains(says),
            "{e}"
        );
        assert!(!stdout(&o).contains("member 0"), "no member ran");
    }
}

#[test]
fn what_is_accepted_but_unexpected_is_said_once_as_a_note() {
    // A rod longer than the initial distance by 1e-11: accepted (below √ε), and said.
    let f = pendulum_with("rod_off.toml", "length = 1.0", "length = 1.00000000001");
    let o = lieflow(&["run", &f, "--t-end", "0.1"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    assert!(
        text.contains("note: the initial positions are off the constraints by 1.0e-11 at constraints[0] rod 'bob'–point"),
        "{text}"
    );
    assert!(
        summary(&o)["max_abs_g"].as_f64().unwrap() > 5e-12,
        "the note explains this"
    );
    // Two gravities add, and check says so.
    let g = pendulum_with(
        "two_gravities.toml",
        "[integrator]",
        "[[effects]]\ntype = \"gravity\"\ng = [0.0, -1.0]\n\n[integrator]",
    );
    let text = stdout(&lieflow(&["check", &g]));
    assert!(
        text.contains("note         effects[2] is a second gravity: it adds to effects[0]"),
        "{text}"
    );
    // The repository's scenes need no note.
    let text = stdout(&lieflow(&["check", &repo("scenes/damped_pendulum.toml")]));
    assert!(!text.contains("note"), "{text}");
}

#[test]
fn off_switches_one_named_effect_and_leaves_the_others() {
    // The default scene names its spring and its damper: switch the spring off.
    let o = lieflow(&["run", "--t-end", "0.01", "--off", "coupling"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let j = summary(&o);
    let names: Vec<&str> = j["effects"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e["name"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["kinetic", "gravity", "right damper", "constraints"]);
    let text = stdout(&lieflow(&[
        "check",
        &scene_file("default.toml", &stdout(&lieflow(&["scene"]))),
    ]));
    assert!(text.contains("coupling"), "{text}");
}

#[test]
fn precision_without_a_scene_measures_the_damped_pendulum_in_seconds_and_shows_progress() {
    let start = std::time::Instant::now();
    let o = lieflow(&["precision", "--repeats", "1"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stdout(&o).starts_with("damped pendulum: T = 10"),
        "{}",
        stdout(&o)
    );
    // stderr is a pipe here: one progress line per run instead of a spinner.
    let e = stderr(&o);
    assert!(
        e.contains("[1 runs, ") && e.contains("lieflow order 2"),
        "{e}"
    );
    let j = summary(&o);
    assert_eq!(j["failed"], 0);
    assert!(start.elapsed().as_secs() < 60, "{:?}", start.elapsed());
}

#[test]
fn radau5_runs_beside_a_scene_of_any_size() {
    let o = lieflow(&[
        "precision",
        &repo("src/scene/default.toml"),
        "--t-end",
        "0.02",
        "--dt",
        "0.01,0.005",
        "--orders",
        "2",
        "--no-implicit",
        "--repeats",
        "1",
        "--tols",
        "1e-4",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    // Radau5 runs beside a scene of any size (n + m = 30 here; it was a Skipped row).
    let radau = text
        .lines()
        .find(|l| l.starts_with("Radau5"))
        .expect("a Radau5 row");
    assert!(radau.ends_with(" ok"), "{text}");
    assert!(!text.contains("Skipped"), "{text}");
}

#[test]
fn a_sweep_over_damping_from_zero_keeps_its_first_member() {
    let out = scratch("sweep_from_zero");
    let sweep = scene_file(
        "sweep_from_zero.toml",
        &format!(
            "version = 1\nscene = \"{}\"\nmode = \"grid\"\n[[parameters]]\npath = \"effects[1].coefficient\"\nvalues = [0.0, 0.5, 1.0]\n[[parameters]]\npath = \"integrator.t_end\"\nvalues = [0.5]\n[plot]\nx = \"effects[1].coefficient\"\ny = \"dissipated\"\n",
            repo("scenes/damped_pendulum.toml")
        ),
    );
    let o = lieflow(&["sweep", &sweep, "--out", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let rows = std::fs::read_to_string(out.join("members.jsonl")).unwrap();
    let first: serde_json::Value = serde_json::from_str(rows.lines().next().unwrap()).unwrap();
    assert_eq!(first["dissipated"].as_f64(), Some(0.0), "{first}");
    // The plot draws every member: three markers.
    let svg = std::fs::read_dir(&out)
        .unwrap()
        .filter_map(|e| e.ok())
        .find(|e| e.path().extension().is_some_and(|x| x == "svg"))
        .map(|e| std::fs::read_to_string(e.path()).unwrap())
        .expect("a plot");
    assert!(
        svg.matches("<circle").count() >= 3,
        "{} markers",
        svg.matches("<circle").count()
    );
}

#[test]
fn the_stress_list_speaks_of_cases_not_of_the_project_s_history() {
    let o = lieflow(&["stress", "--list"]);
    assert!(o.status.success());
    let text = stdout(&o);
    assert!(text.contains("mass-ratio-1e6"), "{text}");
    for word in ["issue", "session", "case 5"] {
        assert!(!text.to_lowercase().contains(word), "`{word}` in {text}");
    }
}

#[test]
fn scheme_and_order_are_overridden_like_the_step() {
    let o = lieflow(&[
        "run",
        &repo("scenes/forced_pendulum.toml"),
        "--scheme",
        "petrov-galerkin",
        "--order",
        "6",
        "--t-end",
        "0.1",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    assert!(
        text.lines()
            .next()
            .is_some_and(|l| l.contains("Petrov–Galerkin") && l.contains("order 6")),
        "{text}"
    );
    let o = lieflow(&["run", "--scheme", "rk4"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("--scheme rk4: not a scheme"),
        "{}",
        stderr(&o)
    );
}
