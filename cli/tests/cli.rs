//! The `lieflow` command as a user runs it: flags, exit codes, the JSON line, CSV and SVG.

mod common;

use common::{lieflow, repo, scratch, stderr, stdout, summary};

#[test]
fn run_without_a_scene_runs_the_default_and_ends_with_json() {
    let o = lieflow(&["run", "--t-end", "0.5"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let j = summary(&o);
    assert_eq!(j["steps"], 5000);
    assert!((j["t"].as_f64().unwrap() - 0.5).abs() < 1e-12);
    assert!(j["max_abs_g"].as_f64().unwrap() < 1e-13);
    assert!(j["ns_per_step"].as_f64().unwrap() > 0.0);
    assert!(j["max_energy_increase"].as_f64().unwrap() <= 0.0);
    let names: Vec<&str> = j["effects"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e["name"].as_str().unwrap())
        .collect();
    assert_eq!(
        names,
        [
            "kinetic",
            "gravity",
            "coupling",
            "right damper",
            "constraints"
        ]
    );
    assert!(j["error"].is_null());
}

#[test]
fn scene_prints_a_scene_that_check_accepts() {
    let o = lieflow(&["scene"]);
    assert!(o.status.success());
    let path = scratch("default.toml");
    std::fs::write(&path, stdout(&o)).unwrap();
    let c = lieflow(&["check", path.to_str().unwrap()]);
    assert!(c.status.success(), "{}", stderr(&c));
    let text = stdout(&c);
    for what in [
        "6 rod",
        "coupling (spring)",
        "degenerate",
        "Strang",
        "order 2",
        "dissipative",
    ] {
        assert!(text.contains(what), "`{what}` missing from:\n{text}");
    }
    let j = lieflow(&["check", "--json", path.to_str().unwrap()]);
    let j: serde_json::Value = serde_json::from_str(stdout(&j).trim()).unwrap();
    assert_eq!(j["constraint_rows"], 6);
}

#[test]
fn a_bad_scene_exits_2_with_file_line_and_field() {
    let text = lieflow::scene::DEFAULT_SCENE.replace("coefficient = 0.3", "coefficient = -0.3");
    let path = scratch("bad.toml");
    std::fs::write(&path, text).unwrap();
    let o = lieflow(&["run", path.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    let err = stderr(&o);
    assert!(err.contains("bad.toml:"), "{err}");
    assert!(err.contains("effects[2].coefficient"), "{err}");
    assert!(o.stdout.is_empty());
    let o = lieflow(&["run", "--off", "gravitation"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("--off gravitation: not a kind of part (gravity, springs"),
        "{}",
        stderr(&o)
    );
    let o = lieflow(&["run", "--dt", "-1"]);
    assert_eq!(o.status.code(), Some(2));
    let o = lieflow(&["run", "--bogus"]);
    assert_eq!(o.status.code(), Some(2));
}

/// The constraint rows a run's first line reports.
fn j_rows(o: &std::process::Output) -> usize {
    let head = stdout(o);
    let head = head.lines().next().unwrap();
    let (_, rest) = head.split_once(" bod").unwrap();
    let rows = rest.split(", ").nth(1).unwrap();
    rows.split(' ').next().unwrap().parse().unwrap()
}

#[test]
fn csv_and_plot_are_written_and_flags_switch_effects_off() {
    let csv = scratch("run.csv");
    let svg = scratch("run.svg");
    let o = lieflow(&[
        "run",
        &repo("scenes/all_effects.toml"),
        "--t-end",
        "0.2",
        "--csv",
        csv.to_str().unwrap(),
        "--every",
        "10",
        "--plot",
        svg.to_str().unwrap(),
        "--off",
        "pair",
        "--off",
        "magnetic",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let j = summary(&o);
    let kinds: Vec<&str> = j["effects"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e["kind"].as_str().unwrap())
        .collect();
    assert!(
        !kinds.contains(&"pair") && !kinds.contains(&"magnetic"),
        "{kinds:?}"
    );
    assert!(kinds.contains(&"trap") && kinds.contains(&"damping"));
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    // step, t, 2·2·19 state entries, 2·19 velocities, energy, max_abs_g, max_abs_phi, one
    // multiplier per constraint row.
    let m = j_rows(&o);
    assert_eq!(header.len(), 2 + 76 + 38 + 3 + m);
    assert_eq!(header[..2], ["step", "t"]);
    assert!(
        header[2].starts_with("q.") && header[40].starts_with("p.") && header[78].starts_with("v.")
    );
    assert!(header[2 + 76 + 38 + 3].starts_with("lambda."), "{header:?}");
    let rows: Vec<&str> = lines.collect();
    assert_eq!(rows.len(), 200 / 10 + 1);
    for (k, r) in rows.iter().enumerate() {
        assert_eq!(r.split(',').count(), header.len());
        for (i, v) in r.split(',').enumerate() {
            // The initial row has no step, hence no multipliers.
            if k == 0 && i >= 2 + 76 + 38 + 3 {
                assert!(v.is_empty());
            } else {
                v.parse::<f64>().unwrap();
            }
        }
    }
    let svg = std::fs::read_to_string(&svg).unwrap();
    assert!(svg.starts_with("<svg") && svg.contains("constraint residual"));
}

#[test]
fn a_failing_run_exits_1_and_keeps_what_it_computed() {
    // A pendulum whirling at h = 0.5: in the second step the rod's multiplier equation
    // g(x_{k+1}) = 0 has no solution near the iterates (the drift overshoots the circle by more
    // than a half-step force can pull back), Newton stops, and the run ends there with the typed
    // error; the CSV holds every step up to it, the JSON says what failed.
    let text = r#"
        version = 1
        dim = 2
        [[bodies]]
        name = "bob"
        mass = 1.0
        position = [1.0, 0.0]
        velocity = [0.0, 3.0]
        [[constraints]]
        type = "rod"
        bodies = ["bob"]
        point = [0.0, 0.0]
        [[effects]]
        type = "gravity"
        g = [0.0, -9.81]
        [integrator]
        dt = 0.5
        t_end = 20.0
    "#;
    let path = scratch("failing.toml");
    std::fs::write(&path, text).unwrap();
    let csv = scratch("failing.csv");
    let o = lieflow(&[
        "run",
        path.to_str().unwrap(),
        "--csv",
        csv.to_str().unwrap(),
        "--every",
        "7",
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    // The rod's one multiplier is the root of a quadratic (the free fall is affine): at this
    // step it has none, and the solve says so at once.
    assert!(stderr(&o).contains("has no real root"), "{}", stderr(&o));
    let j = summary(&o);
    let steps = j["steps"].as_u64().unwrap();
    assert!(steps < 40, "{steps}");
    assert_eq!(j["error"]["kind"], "Newton");
    assert_eq!(j["error"]["step"].as_u64().unwrap(), steps);
    // The state is the last good one: on the circle.
    let x: Vec<f64> = j["x"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    assert!(((x[0] * x[0] + x[1] * x[1]).sqrt() - 1.0).abs() < 1e-14);
    // The last row is the last good state, although it is not a multiple of --every.
    let text = std::fs::read_to_string(&csv).unwrap();
    let last = text.lines().last().unwrap();
    assert!(last.starts_with(&format!("{steps},")), "{last}");
    let xs: Vec<f64> = last
        .split(',')
        .skip(2)
        .take(4)
        .map(|v| v.parse().unwrap())
        .collect();
    // The same digits on both sides; serde_json's float parser (without its `float_roundtrip`
    // feature) may land one ulp from the correctly rounded `str::parse`.
    assert!(
        xs.iter()
            .zip(&x)
            .all(|(a, b)| (a - b).abs() <= 2.0 * f64::EPSILON * a.abs()),
        "{xs:?} against {x:?}"
    );
}

#[test]
fn help_lists_the_subcommands() {
    let o = lieflow(&["--help"]);
    assert!(o.status.success());
    let text = stdout(&o);
    for sub in ["run", "check", "scene"] {
        assert!(text.contains(sub));
    }
    let o = lieflow(&["run", "--help"]);
    let text = stdout(&o);
    for flag in [
        "--csv",
        "--plot",
        "--every",
        "--off",
        "--dt",
        "--t-end",
        "--profile",
    ] {
        assert!(text.contains(flag), "{flag}");
    }
}

#[test]
fn precision_writes_a_table_a_csv_and_figures() {
    let dir = scratch("wp");
    let o = lieflow(&[
        "precision",
        &repo("scenes/paper.toml"),
        "--dt",
        "0.2,0.1",
        "--orders",
        "2,4",
        "--tols",
        "1e-6,1e-8",
        "--repeats",
        "1",
        "--out",
        dir.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let j = summary(&o);
    assert_eq!(j["failed"], 0);
    assert!(j["reference"].as_str().unwrap().contains("closed form"));
    // 2 orders × 2 steps, midpoint and §2 × 2 steps, 2 peers × 2 tolerances.
    assert_eq!(j["rows"], 4 + 4 + 4);
    let csv = std::fs::read_to_string(dir.join("work_precision.csv")).unwrap();
    assert!(csv.lines().any(|l| l.starts_with("# machine: ")));
    assert!(csv.lines().any(|l| l.starts_with("# revision: ")));
    let header = csv.lines().find(|l| !l.starts_with('#')).unwrap();
    assert_eq!(header, lieflow_lab::precision::CSV_COLUMNS.join(","));
    for stem in ["time", "dt", "g"] {
        let svg = std::fs::read_to_string(dir.join(format!("work_precision_{stem}.svg"))).unwrap();
        assert!(svg.starts_with("<svg"));
    }
    let text = stdout(&o);
    assert!(text.contains("DOP853 (index-1 ODE)") && text.contains("fitted order lieflow order 4"));
}

#[test]
fn a_scene_with_ports_writes_its_outputs_events_and_budget() {
    let csv = scratch("ports.csv");
    let svg = scratch("ports.svg");
    let o = lieflow(&[
        "run",
        &repo("scenes/forced_pendulum.toml"),
        "--t-end",
        "4",
        "--csv",
        csv.to_str().unwrap(),
        "--plot",
        svg.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let s = summary(&o);
    // The motor supplies energy, the damper removes it, and the budget closes to O(h²).
    assert!(s["supplied"].as_f64().unwrap() > 0.0);
    assert!(s["dissipated"].as_f64().unwrap() > 0.0);
    assert!(s["max_energy_balance_error"].as_f64().unwrap() < 1e-3);
    let events = s["events"].as_array().unwrap();
    assert!(!events.is_empty() && events.iter().all(|e| e["name"] == "bottom"));
    assert!(s["stopped_by"].is_null());
    let text = std::fs::read_to_string(&csv).unwrap();
    let header = text.lines().nth(1).unwrap();
    assert!(
        header.ends_with(
            "max_abs_phi,lambda.rod:bob,bob.x,y.motor,power.motor,lambda0,supplied,dissipated"
        ),
        "{header}"
    );
    let last: Vec<&str> = text.lines().last().unwrap().split(',').collect();
    let supplied: f64 = last[last.len() - 2].parse().unwrap();
    // serde_json reads floats to within an ulp (without its `float_roundtrip` feature).
    let expected = s["supplied"].as_f64().unwrap();
    assert!((supplied - expected).abs() <= 2.0 * f64::EPSILON * expected.abs());
    let plot = std::fs::read_to_string(&svg).unwrap();
    assert!(plot.contains("output power.motor"));
}

/// `lieflow check` says which scheme and order a damped scene gets, and why: extrapolation when
/// damping is declared and a higher order asked, the named energy-consistent scheme when named
/// (with its Gauss points and why).
#[test]
fn check_says_which_scheme_a_damped_scene_gets_and_why() {
    let base = include_str!("../../scenes/damped_pendulum.toml");
    for (extra, scheme, why) in [
        (
            "order = 8",
            "extrapolated to order 8",
            "damping is declared and an order above 2 asked",
        ),
        (
            "order = 6\nscheme = \"petrov-galerkin\"",
            "energy-consistent Petrov–Galerkin",
            "an exact discrete energy balance",
        ),
        (
            // Kinetic energy, gravity and a rod: ⌊3k/2⌋ points integrate every term exactly.
            "order = 6\nscheme = \"petrov-galerkin\"",
            "energy-consistent Petrov–Galerkin",
            "4 Gauss points a residual: H and any constraints are quadratic",
        ),
        (
            "",
            "free flight under gravity (exact)",
            "the damping flow among them",
        ),
    ] {
        let path = scratch("why.toml");
        std::fs::write(
            &path,
            base.replace("[integrator]", &format!("[integrator]\n{extra}")),
        )
        .unwrap();
        let c = lieflow(&["check", path.to_str().unwrap()]);
        assert!(c.status.success(), "{}", stderr(&c));
        let text = stdout(&c);
        let line = |key: &str| {
            text.lines()
                .find(|l| l.starts_with(key))
                .unwrap_or_else(|| panic!("no `{key}` line in:\n{text}"))
                .to_owned()
        };
        assert!(line("scheme").contains(scheme), "{text}");
        assert!(line("why").contains(why), "{text}");
        let j = lieflow(&["check", "--json", path.to_str().unwrap()]);
        let j: serde_json::Value = serde_json::from_str(stdout(&j).trim()).unwrap();
        assert!(j["reason"].as_str().unwrap().contains(why));
    }
}

/// A pair potential is not a polynomial: the Petrov–Galerkin scheme keeps `k + 2` Gauss points,
/// and `lieflow check` says that its balance then holds to the quadrature error.
#[test]
fn check_says_a_non_polynomial_potential_keeps_two_more_points() {
    let text = include_str!("../../scenes/shell_damped.toml").replace(
        "[integrator]",
        "[integrator]\nscheme = \"petrov-galerkin\"\norder = 4",
    );
    let path = scratch("shell_pg.toml");
    std::fs::write(&path, text).unwrap();
    let c = lieflow(&["check", path.to_str().unwrap()]);
    assert!(c.status.success(), "{}", stderr(&c));
    let out = stdout(&c);
    assert!(
        out.contains("4 Gauss points a residual (k + 2): the potential is not a polynomial"),
        "{out}"
    );
}

#[test]
fn a_tolerance_run_bound_by_its_reports_points_at_dense_output() {
    // The damped pendulum at tol 1e-8 reporting every 0.01 s: every step ends on a report
    // time, and the run says `--dense` would lift that; with it, the rows are the same 1000
    // and the steps the controller's own (tens), and nothing is suggested.
    let text = std::fs::read_to_string(repo("scenes/damped_pendulum.toml"))
        .unwrap()
        .replace("dt = 0.01", "dt = 0.01\ntol = 1e-8");
    let path = scratch("pendulum_tol.toml");
    std::fs::write(&path, text).unwrap();
    let landed = lieflow(&["run", path.to_str().unwrap()]);
    assert!(landed.status.success(), "{}", stderr(&landed));
    assert!(stdout(&landed).contains("`--dense`"), "{}", stdout(&landed));
    let dense = lieflow(&["run", path.to_str().unwrap(), "--dense"]);
    assert!(dense.status.success(), "{}", stderr(&dense));
    assert!(!stdout(&dense).contains("`--dense`"), "{}", stdout(&dense));
    let (l, d) = (summary(&landed), summary(&dense));
    assert_eq!(l["steps"], 1000);
    assert_eq!(d["steps"], 1000);
    assert_eq!(l["adaptive"]["accepted"], 1000);
    assert!(
        d["adaptive"]["accepted"].as_u64().unwrap() < 100,
        "{}",
        d["adaptive"]
    );
    assert!(d["max_abs_g"].as_f64().unwrap() < 1e-13);
    assert!(stdout(&dense).contains("reports from the dense output"));
}
