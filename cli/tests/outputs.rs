//! What a run writes besides its summary: the CSV's named columns, velocities and
//! multipliers, and the SVG's panels, checked by reading the files.

mod common;

use common::{lieflow, pendulum_with, repo, scratch, stderr, stdout, summary};

#[test]
fn the_csv_names_its_columns_and_holds_velocities_and_named_multipliers() {
    // A named rod to a fixed point: its multiplier column carries the name.
    let f = pendulum_with(
        "named_rod.toml",
        "type = \"rod\"\nbodies = [\"bob\"]",
        "type = \"rod\"\nname = \"hinge\"\nbodies = [\"bob\"]",
    );
    let csv = scratch("named.csv");
    let o = lieflow(&["run", &f, "--t-end", "0.05", "--csv", csv.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    let header = lines.next().unwrap();
    assert_eq!(
        header,
        "step,t,q.bob.x,q.bob.y,p.bob.x,p.bob.y,v.bob.x,v.bob.y,energy,max_abs_g,max_abs_phi,lambda.hinge"
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows[0][11], "", "no multiplier before the first step");
    let value = |r: &Vec<&str>, i: usize| r[i].parse::<f64>().unwrap();
    // g = (|q|² − L²)/2, so the rod's force on the bob is −λ q, its magnitude λ |q| = λ L:
    // the tension m g cos θ + m |v|²/L (the damping acts across the rod).
    let tension = |r: &Vec<&str>| 9.81 * -value(r, 3) + value(r, 6).powi(2) + value(r, 7).powi(2);
    for pair in rows.windows(2) {
        let (before, r) = (&pair[0], &pair[1]);
        // Unit mass: v = p.
        assert_eq!(value(r, 6), value(r, 4));
        assert_eq!(value(r, 7), value(r, 5));
        // λ is the step's (λ_k + λ_{k+1})/2: the tension at the step's middle, which the mean
        // of its ends matches to h² T''/8 ≤ 5e-3 (T'' ≤ 400 here).
        let mean = 0.5 * (tension(before) + tension(r));
        assert!(
            (value(r, 11) - mean).abs() < 5e-3,
            "{} against {mean}",
            value(r, 11)
        );
    }
    // The name is what the messages call it, and what --off switches off.
    let o = lieflow(&["run", &f, "--t-end", "0.05", "--off", "hinge"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stdout(&o).starts_with("damped pendulum: 1 body, 0 constraint rows"),
        "{}",
        stdout(&o)
    );
    let text = stdout(&lieflow(&["check", &f]));
    assert!(text.contains("1 row: 1 rod"), "{text}");
    let o = lieflow(&["run", &f, "--off", "hinj"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("no effect or constraint is named 'hinj' (named here: 'hinge')"),
        "{}",
        stderr(&o)
    );
}

/// The texts of an SVG's `<text>` elements.
fn svg_texts(svg: &str) -> Vec<String> {
    svg.split("<text")
        .skip(1)
        .filter_map(|s| {
            let body = &s[s.find('>')? + 1..];
            Some(body[..body.find("</text>")?].trim().to_owned())
        })
        .collect()
}

/// The number after `prefix` in the caption that starts with it, up to `)`.
fn caption_number(texts: &[String], prefix: &str) -> f64 {
    let t = texts
        .iter()
        .find(|t| t.starts_with(prefix))
        .unwrap_or_else(|| panic!("no `{prefix}`: {texts:?}"));
    t[prefix.len()..].trim_end_matches(')').parse().unwrap()
}

#[test]
fn figures_show_the_balance_both_residuals_and_paths_at_equal_aspect_with_a_legend() {
    let svg = scratch("figures_2d.svg");
    let o = lieflow(&[
        "run",
        &repo("scenes/damped_pendulum.toml"),
        "--plot",
        svg.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let j = summary(&o);
    let texts = svg_texts(&std::fs::read_to_string(&svg).unwrap());
    for wanted in [
        "energy",
        "H(t) - H(0)",
        "H - H(0) + dissipated - supplied",
        "paths, x-y plane (equal aspect)",
        "bob",
    ] {
        assert!(
            texts.iter().any(|t| t == wanted),
            "no `{wanted}`: {texts:?}"
        );
    }
    // The plotted maxima are the summary's (to the caption's three digits).
    for (what, key) in [("g", "max_abs_g"), ("phi", "max_abs_phi")] {
        let shown = caption_number(
            &texts,
            &format!("constraint residual max |{what}| (largest "),
        );
        let summary = j[key].as_f64().unwrap();
        assert!(
            (shown / summary - 1.0).abs() < 5e-3,
            "{what}: {shown} against {summary}"
        );
    }
    // Decade labels on the residual axes, and no tick that is rounding noise around zero.
    assert!(
        texts.iter().any(|t| t == "1e-15" || t == "1e-16"),
        "{texts:?}"
    );
    for t in texts.iter().filter(|t| !t.starts_with("1e")) {
        if let Ok(v) = t.parse::<f64>() {
            assert!(v == 0.0 || v.abs() > 1e-9, "a tick of {t}");
        }
    }
    // A 3D scene gets two projections.
    let svg = scratch("figures_3d.svg");
    let o = lieflow(&[
        "run",
        &repo("scenes/shell_damped.toml"),
        "--t-end",
        "0.5",
        "--plot",
        svg.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let texts = svg_texts(&std::fs::read_to_string(&svg).unwrap());
    assert!(
        texts.iter().any(|t| t == "paths, x-z plane (equal aspect)"),
        "{texts:?}"
    );
    assert!(texts.iter().any(|t| t == "p.9"), "{texts:?}");
}

#[test]
fn plot_targets_are_checked_before_the_run() {
    let png = scratch("paths.png");
    let o = lieflow(&[
        "run",
        &repo("scenes/damped_pendulum.toml"),
        "--plot",
        png.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stdout(&o).is_empty(), "refused before running");
    assert!(
        stderr(&o).contains("the plot is SVG; give a file name ending in .svg"),
        "{}",
        stderr(&o)
    );
    assert!(!png.exists(), "no SVG bytes in a .png");
    let o = lieflow(&[
        "run",
        &repo("scenes/damped_pendulum.toml"),
        "--plot",
        "/nonexistent-dir/p.svg",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stdout(&o).is_empty(), "refused before running");
    assert!(
        stderr(&o).contains("cannot write /nonexistent-dir/p.svg"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn fmu_refuses_a_file_that_is_not_an_fmu_and_a_bad_scene() {
    let o = lieflow(&[
        "fmu",
        &repo("tests/data/fmu_pendulum.toml"),
        "-o",
        "pendulum.zip",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("an FMU's file name ends in .fmu"),
        "{}",
        stderr(&o)
    );
    let bad = pendulum_with("bad_fmu.toml", "mass = 1.0", "mass = -1.0");
    let o = lieflow(&["fmu", &bad, "-o", scratch("bad.fmu").to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("`bodies[0].mass`"), "{}", stderr(&o));
    assert!(!scratch("bad.fmu").exists());
    // Help names the subcommand.
    assert!(stdout(&lieflow(&["--help"])).contains("fmu"));
}

#[test]
fn accepted_steps_writes_a_row_at_each_step_the_controller_chose() {
    // Kepler at e = 0.9 (tol 1e-8): a row per accepted step, at the times the controller
    // chose (short at perihelion, long at aphelion), the last at t_end; `--every 2` keeps
    // every second and the last.
    let scene = repo("scenes/kepler.toml");
    let csv = scratch("kepler_steps.csv");
    let plot = scratch("kepler_steps.svg");
    let o = lieflow(&[
        "run",
        &scene,
        "--accepted-steps",
        "--csv",
        csv.to_str().unwrap(),
        "--plot",
        plot.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let j = summary(&o);
    let steps = j["steps"].as_u64().unwrap() as usize;
    assert_eq!(j["steps"], j["adaptive"]["accepted"]);
    assert_eq!(j["steps_planned"], j["steps"]);
    assert!(
        stdout(&o)
            .lines()
            .next()
            .unwrap()
            .contains("steps chosen to t_end = 62.8")
    );
    let text = std::fs::read_to_string(&csv).unwrap();
    let times: Vec<f64> = text
        .lines()
        .filter(|l| !l.starts_with('#'))
        .skip(1)
        .map(|l| l.split(',').nth(1).unwrap().parse().unwrap())
        .collect();
    assert_eq!(times.len(), steps + 1);
    assert_eq!(*times.last().unwrap(), j["t"].as_f64().unwrap());
    let lengths: Vec<f64> = times.windows(2).map(|w| w[1] - w[0]).collect();
    assert!(lengths.iter().all(|&h| h > 0.0));
    let (short, long) = lengths
        .iter()
        .fold((f64::INFINITY, 0.0_f64), |(a, b), &h| (a.min(h), b.max(h)));
    assert!(long > 10.0 * short, "steps {short} … {long}");
    // The longest row-to-row interval is the controller's longest step (to the rounding of
    // the times' difference).
    let largest = j["adaptive"]["largest_step"].as_f64().unwrap();
    assert!(
        (largest - long).abs() <= 1e-13 * 62.8,
        "{largest} vs {long}"
    );
    assert!(std::fs::read_to_string(&plot).unwrap().contains("<svg"));
    let o = lieflow(&[
        "run",
        &scene,
        "--accepted-steps",
        "--every",
        "2",
        "--csv",
        csv.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let rows = std::fs::read_to_string(&csv)
        .unwrap()
        .lines()
        .filter(|l| !l.starts_with('#'))
        .skip(1)
        .count();
    assert_eq!(rows, 1 + steps / 2 + steps % 2);
    // A fixed-step scene has no steps of its own to write: refused, saying what to give.
    let o = lieflow(&[
        "run",
        &repo("scenes/damped_pendulum.toml"),
        "--accepted-steps",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("--accepted-steps: the scheme takes fixed steps of dt = 0.01"),
        "{}",
        stderr(&o)
    );
}
