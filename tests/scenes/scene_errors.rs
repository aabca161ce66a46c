//! Scenes refuse what they cannot run, with typed errors located at the field: refused
//! combinations, bad and oversized inputs, redundant and off-manifold constraints, settings that
//! would be ignored; and the edge cases that must stay finite.

use faer::Col;
use lieflow::scene::{DEFAULT_SCENE, Scene, SceneErrorKind, SceneFile};
use lieflow::{Hamiltonian, Vector};

use crate::scene_text;

use scene_text::{parse, run_scene, set};

const ALL_EFFECTS: &str = include_str!("../../scenes/all_effects.toml");

#[test]
fn refused_combinations_name_the_field() {
    // A named composition of order 8 on a damped scene steps the damping backwards.
    let text = set(&set(DEFAULT_SCENE, "order", "8"), "scheme", "\"kahan-li8\"");
    let e = parse(&text).compile().unwrap_err();
    assert_eq!(e.kind, SceneErrorKind::Unsupported);
    assert_eq!(e.path.to_string(), "integrator.scheme");
    let loc = e.location.unwrap();
    let line = text.lines().nth(loc.line - 1).unwrap();
    assert!(line.starts_with("scheme"), "{line}");
    assert!(e.message.contains("extrapolation"), "{}", e.message);
    // Without damping the same composition is fine; with damping `order = 8` extrapolates.
    let ok = text.replace("[flags]", "[flags]\ndamping = false");
    assert!(parse(&ok).compile().is_ok());
    let c = parse(&set(DEFAULT_SCENE, "order", "8")).compile().unwrap();
    assert!(
        c.assembly.scheme.contains("extrapolated to order 8"),
        "{}",
        c.assembly.scheme
    );
}

#[test]
fn bad_scenes_get_located_typed_errors() {
    // (replace, with, kind, path, text on the line the error points at)
    let cases: [(&str, &str, SceneErrorKind, &str, &str); 6] = [
        (
            "mass = 1.0\n\n[[chains]]",
            "mass = -2.0\n\n[[chains]]",
            SceneErrorKind::Value,
            "chains[0].mass",
            "mass = -2.0",
        ),
        (
            "stiffness = 20.0",
            "stifness = 20.0",
            SceneErrorKind::Syntax,
            // A key the format does not know is named by its path, as the checks' errors are.
            "effects[1].stifness",
            "stifness",
        ),
        (
            "\"right.2\"]",
            "\"right.9\"]",
            SceneErrorKind::Reference,
            "effects[1].bodies[1]",
            "right.9",
        ),
        (
            "dim = 2",
            "dim = 4",
            SceneErrorKind::Dimension,
            "dim",
            "dim = 4",
        ),
        (
            "dt = 1e-4",
            "dt = 0.0",
            SceneErrorKind::Value,
            "integrator.dt",
            "dt = 0.0",
        ),
        (
            "length = 0.5\nmass = 1.0\n\n[[effects]]",
            "length = 0.0\nmass = 1.0\n\n[[effects]]",
            SceneErrorKind::Value,
            "chains[1].length",
            "length = 0.0",
        ),
    ];
    for (from, to, kind, path, on_line) in cases {
        assert!(DEFAULT_SCENE.contains(from), "{from}");
        let text = DEFAULT_SCENE.replacen(from, to, 1);
        let e = Scene::from_toml(&text, "bad.toml")
            .and_then(|s| s.compile())
            .unwrap_err();
        assert_eq!(e.kind, kind, "{e}");
        assert_eq!(e.path.to_string(), path, "{e}");
        let loc = e.location.clone().expect("located");
        assert_eq!(loc.file, "bad.toml");
        let at = text.lines().nth(loc.line - 1).unwrap();
        assert!(at.contains(on_line), "{e}: line {} is `{at}`", loc.line);
        assert!(
            e.to_string()
                .starts_with(&format!("bad.toml:{}:", loc.line))
        );
    }
    // Unknown top-level keys and versions.
    let e = Scene::from_toml(
        &DEFAULT_SCENE.replace("dim = 2", "dim = 2\ncolour = 3"),
        "x.toml",
    )
    .unwrap_err();
    assert_eq!(e.kind, SceneErrorKind::Syntax);
    assert!(e.message.contains("colour"));
    let e = parse(&DEFAULT_SCENE.replace("version = 1", "version = 2"))
        .compile()
        .unwrap_err();
    assert_eq!(e.kind, SceneErrorKind::Version);
}

#[test]
fn redundant_constraints_are_named() {
    // A second rod between the anchor and the first body of the left chain repeats link 0.
    let text = DEFAULT_SCENE.replace(
        "[[effects]]\ntype = \"gravity\"",
        "[[constraints]]\ntype = \"rod\"\nbodies = [\"left.0\"]\npoint = [0.0, 0.0]\n\n[[effects]]\ntype = \"gravity\"",
    );
    let e = parse(&text).compile().unwrap_err();
    assert_eq!(e.kind, SceneErrorKind::Redundant, "{e}");
    assert!(
        e.message.contains("rod") || e.message.contains("link"),
        "{e}"
    );
}

#[test]
fn an_initial_state_off_the_constraints_is_refused_or_projected() {
    let text = r#"
        version = 1
        dim = 3
        [[bodies]]
        name = "bob"
        mass = 2.0
        position = [1.01, 0.0, -0.02]
        velocity = [0.1, 0.5, 0.3]
        [[constraints]]
        type = "sphere"
        bodies = ["bob"]
        radius = 1.0
        [[effects]]
        type = "gravity"
        g = [0.0, 0.0, -9.81]
        [integrator]
        dt = 0.01
        t_end = 1.0
    "#;
    let e = parse(text).compile().unwrap_err();
    assert_eq!(e.kind, SceneErrorKind::OffConstraints);
    assert!(e.message.contains("project_initial"), "{e}");
    assert!(e.message.contains("sphere 'bob'"), "{e}");
    let projected = text.replace("t_end = 1.0", "t_end = 1.0\nproject_initial = true");
    let c = parse(&projected).compile().unwrap();
    let (dq, dp) = c.assembly.initial_projection.unwrap();
    // The position moves radially by |q| − 1 ≈ 0.0102; the velocity loses its radial part.
    assert!((dq - 0.0102).abs() < 2e-3, "{dq}");
    assert!(dp > 0.1 && dp < 0.3, "{dp}");
    let s = run_scene(&parse(&projected));
    assert!(s.max_abs_g.unwrap() < 1e-14);
    assert!(s.max_abs_phi.unwrap() < 1e-13);
}

#[test]
fn built_in_models_run_from_scenes() {
    let text = r#"
        version = 1
        [builtin]
        model = "paper"
        [integrator]
        dt = 0.1
        t_end = 100.0
    "#;
    let s = run_scene(&parse(text));
    assert_eq!(s.steps, 1000);
    // The paper example's own figures (README): |g| at round-off, error vs exact 5.5e-4.
    assert!(s.max_abs_g.unwrap() < 1e-15);
    let exact = lieflow::models::paper::exact(100.0, -0.15);
    let err =
        s.x.iter()
            .zip(exact)
            .fold(0.0f64, |a, (u, v)| a.max((u - v).abs()));
    assert!((err - 5.549e-4).abs() < 1e-6, "{err}");
    // The rigid body: implicit midpoint, which keeps the quadratic energy to the Newton tolerance.
    let t = text.replace("\"paper\"", "\"rigid-body\"");
    let s = run_scene(&parse(&t));
    assert_eq!(s.error, None);
    assert_eq!(s.max_abs_g, None);
    assert!(
        s.max_abs_energy_error.unwrap() < 1e-12,
        "{:?}",
        s.max_abs_energy_error
    );
    let e = parse(&t.replace("t_end = 100.0", "t_end = 100.0\norder = 4"))
        .compile()
        .unwrap_err();
    assert_eq!(e.kind, SceneErrorKind::Unsupported);
    for model in ["pendulum-chain", "spherical-pendulum"] {
        let t = text
            .replace("\"paper\"", &format!("\"{model}\""))
            .replace("t_end = 100.0", "t_end = 1.0")
            .replace("dt = 0.1", "dt = 0.01");
        let s = run_scene(&parse(&t));
        assert_eq!(s.error, None, "{model}");
        assert!(s.max_abs_g.unwrap() < 1e-13, "{model}: {:?}", s.max_abs_g);
    }
}

#[test]
fn large_scenes_take_the_sparse_path() {
    let text = r#"
        version = 1
        dim = 2
        [[chains]]
        name = "long"
        links = 400
        direction = [1.0, 0.0]
        length = 0.0025
        mass = 0.0025
        [[effects]]
        type = "gravity"
        g = [0.0, -1.0]
        [integrator]
        dt = 1e-4
        t_end = 0.01
    "#;
    let c = parse(text).compile().unwrap();
    assert_eq!(c.assembly.solver.as_deref(), Some("Banded"));
    let s = run_scene(&parse(text));
    assert_eq!(s.error, None);
    assert!(s.max_abs_g.unwrap() < 1e-15, "{:?}", s.max_abs_g);
}

#[test]
fn the_default_scene_parses_and_scene_files_round_trip_through_serde() {
    let s = Scene::default_scene();
    assert_eq!(s.file.version, 1);
    let f: SceneFile = parse(DEFAULT_SCENE).file;
    assert_eq!(f, s.file);
    let all = parse(ALL_EFFECTS);
    let c = all.compile().unwrap();
    assert_eq!(c.assembly.bodies, 3 + 9 + 5 + 2);
    assert_eq!(c.assembly.constraint_rows, 3 + 5 + 1 + 2);
    assert!(!c.assembly.canonical && c.assembly.dissipative);
}

#[test]
fn oversized_or_inconsistent_generators_are_refused_not_allocated() {
    let grid = r#"
        version = 1
        dim = 2
        [[grids]]
        name = "g"
        spacing = 1.0
        counts = [100000000000, 100000000000]
        mass = 1.0
        [integrator]
        dt = 0.1
        t_end = 1.0
    "#;
    let e = parse(grid).compile().unwrap_err();
    assert_eq!(e.kind, SceneErrorKind::Unsupported);
    assert_eq!(e.path.to_string(), "grids[0].counts");
    let pairs = grid
        .replace("100000000000, 100000000000", "200, 100")
        .replace(
            "[integrator]",
            "[[effects]]\ntype = \"pair\"\nlaw = \"log\"\nstrength = 1.0\n[integrator]",
        );
    let e = parse(&pairs).compile().unwrap_err();
    assert_eq!(e.kind, SceneErrorKind::Unsupported, "{e}");
    assert_eq!(e.path.to_string(), "effects[0].bodies");
    let shell = r#"
        version = 1
        dim = 3
        [[shells]]
        name = "s"
        radius = 1.0
        mass = 1.0
        rings = [3, 3]
        velocities = [[0.0, 0.0, 1.0]]
        [integrator]
        dt = 0.1
        t_end = 1.0
    "#;
    let e = parse(shell).compile().unwrap_err();
    assert_eq!(e.path.to_string(), "shells[0].velocities");
    let ok = parse(&shell.replace("velocities = [[0.0, 0.0, 1.0]]\n", ""))
        .compile()
        .unwrap();
    assert_eq!(ok.assembly.bodies, 6);
    assert_eq!(ok.assembly.constraint_rows, 6);
}

/// The initial-state check and the initial projection work at each constraint's own scale,
/// wherever the scene sits.
#[test]
fn constraint_checks_use_each_rows_own_scale() {
    // A body at x = 1e4, one unit off its plane: refused (an absolute √ε·|q|² test would not).
    let far = r#"
        version = 1
        dim = 2
        [[bodies]]
        name = "b"
        mass = 1.0
        position = [10000.0, 1.0]
        [[constraints]]
        type = "plane"
        bodies = ["b"]
        normal = [0.0, 1.0]
        offset = 0.0
        [integrator]
        dt = 0.01
        t_end = 0.1
    "#;
    let e = parse(far).compile().unwrap_err();
    assert_eq!(e.kind, SceneErrorKind::OffConstraints, "{e}");
    assert_eq!(e.path.to_string(), "constraints[0]");
    // A short link far from the origin, 1% too long: refused, pointing at the chain.
    let link = r#"
        version = 1
        dim = 2
        [[bodies]]
        name = "a"
        mass = 1.0
        position = [100.0, 0.0]
        [[bodies]]
        name = "b"
        mass = 1.0
        position = [100.0101, 0.0]
        [[constraints]]
        type = "rod"
        bodies = ["a", "b"]
        length = 0.01
        [integrator]
        dt = 0.01
        t_end = 0.1
    "#;
    let e = parse(link).compile().unwrap_err();
    assert_eq!(e.kind, SceneErrorKind::OffConstraints, "{e}");
    // A long rod to a far point: the projection converges to the row's own rounding level.
    let long = r#"
        version = 1
        dim = 2
        [[bodies]]
        name = "b"
        mass = 1.0
        position = [0.5, 0.1]
        [[constraints]]
        type = "rod"
        bodies = ["b"]
        point = [1000.0, 0.0]
        length = 1000.0
        [integrator]
        dt = 0.01
        t_end = 0.1
        project_initial = true
    "#;
    let c = parse(long).compile().unwrap_or_else(|e| panic!("{e}"));
    let (dq, _) = c.assembly.initial_projection.unwrap();
    assert!(dq > 0.4 && dq < 0.6, "{dq}");
}

#[test]
fn settings_that_would_be_ignored_are_errors() {
    let with = |law: &str, extra: &str| {
        format!(
            "version = 1\ndim = 2\n[[grids]]\nname = \"g\"\nspacing = 1.0\ncounts = [2, 1]\nmass = 1.0\n[[effects]]\ntype = \"pair\"\nlaw = \"{law}\"\n{extra}\n[integrator]\ndt = 0.1\nt_end = 1.0\n"
        )
    };
    let e = parse(&with("log", "strength = 1.0\npower = 2.0"))
        .compile()
        .unwrap_err();
    assert_eq!(e.path.to_string(), "effects[0].power", "{e}");
    let e = parse(&with(
        "lennard-jones",
        "epsilon = 1.0\nsigma = 1.0\nstrength = 1.0",
    ))
    .compile()
    .unwrap_err();
    assert_eq!(e.path.to_string(), "effects[0].strength", "{e}");
    assert!(
        parse(&with("lennard-jones", "epsilon = 1.0\nsigma = 1.0"))
            .compile()
            .is_ok()
    );
    let builtin =
        "version = 1\n[builtin]\nmodel = \"paper\"\n[integrator]\ndt = 0.1\nt_end = 1.0\n";
    assert!(parse(builtin).compile().is_ok());
    for (extra, path) in [
        ("[flags]\ngravity = false\n", "flags"),
        ("", "integrator.project_initial"),
    ] {
        let mut text = builtin.to_owned();
        if extra.is_empty() {
            text = text.replace("t_end = 1.0", "t_end = 1.0\nproject_initial = true");
        } else {
            text.push_str(extra);
        }
        let e = parse(&text).compile().unwrap_err();
        assert_eq!(e.path.to_string(), path, "{e}");
    }
    let e = parse(&builtin.replace("\"paper\"", "\"paper\"\nlinks = 3"))
        .compile()
        .unwrap_err();
    assert_eq!(e.path.to_string(), "builtin.links", "{e}");
    // An unknown key in the second of two effects that both could hold it elsewhere: the error
    // points at the table it is wrong in.
    let text = DEFAULT_SCENE.replace("rest_length = 2.0", "rest_length = 2.0\ncoefficient = 1.0");
    let e = Scene::from_toml(&text, "k.toml").unwrap_err();
    let line = text.lines().nth(e.location.unwrap().line - 1).unwrap();
    assert_eq!(line, "coefficient = 1.0");
}

#[test]
fn degenerate_parameters_stay_finite_or_assemble_nothing() {
    // Two bodies at the same point joined by a spring of default (zero) rest length: the
    // Hessian product is finite (no 0/0) and the run is finite.
    let text = r#"
        version = 1
        dim = 2
        [[bodies]]
        name = "a"
        mass = 1.0
        position = [0.0, 0.0]
        velocity = [1.0, 0.0]
        [[bodies]]
        name = "b"
        mass = 1.0
        position = [0.0, 0.0]
        [[effects]]
        type = "spring"
        bodies = ["a", "b"]
        stiffness = 4.0
        [[effects]]
        type = "magnetic"
        field = [1e-200]
        [[effects]]
        type = "damping"
        coefficient = 0.0
        [integrator]
        order = 4
        dt = 0.01
        t_end = 1.0
    "#;
    let text = text.replace(
        "velocity = [1.0, 0.0]",
        "velocity = [1.0, 0.0]\n        charge = 1.0",
    );
    let c = parse(&text).compile().unwrap_or_else(|e| panic!("{e}"));
    // Zero damping is no damping: order 4 is allowed and the model is conservative.
    assert!(!c.assembly.dissipative);
    assert!(
        c.assembly.disabled.iter().any(|d| d.contains("damping")),
        "{:?}",
        c.assembly.disabled
    );
    let model = c.model.unwrap();
    let x = Col::<f64>::from_fn(8, |i| [0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0][i]);
    let v = Col::<f64>::from_fn(8, |i| i as f64);
    let mut hv = Col::<f64>::zeros(8);
    model.hessian_apply(&x, &v, &mut hv);
    assert!(hv.as_slice().iter().all(|x| x.is_finite()), "{hv:?}");
    let s = run_scene(&parse(&text));
    assert_eq!(s.error, None);
    assert!(s.x.iter().all(|x| x.is_finite()));
    // A 1e-200 field: the free flight is the drift to round-off, not NaN — the run equals the
    // run without the field.
    let plain = run_scene(&parse(
        &text
            .replace("[flags]", "")
            .replace("[integrator]", "[flags]\nmagnetic = false\n[integrator]"),
    ));
    for (a, b) in s.x.iter().zip(&plain.x) {
        assert!((a - b).abs() < 1e-14, "{:?} vs {:?}", s.x, plain.x);
    }
}

/// A scene file is a regular file of at most `MAX_SCENE_BYTES`: a device that never ends
/// (`/dev/zero`), a directory, or a larger file is refused with an `Io` error before anything
/// is read, instead of a read without bound.
#[test]
fn scene_files_are_regular_and_bounded() {
    use lieflow::scene::MAX_SCENE_BYTES;
    let refused = |path: &std::path::Path, what: &str| {
        let e = Scene::from_path(path).expect_err("refused");
        assert_eq!(e.kind, SceneErrorKind::Io, "{e}");
        assert!(e.to_string().contains(what), "{e}");
    };
    if std::path::Path::new("/dev/zero").exists() {
        refused(std::path::Path::new("/dev/zero"), "not a regular file");
    }
    let dir = std::env::temp_dir().join(format!("lieflow-scene-files-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    refused(&dir, "not a regular file");
    // A sparse file just over the limit: refused by its length, not read.
    let big = dir.join("big.toml");
    std::fs::File::create(&big)
        .and_then(|f| f.set_len(MAX_SCENE_BYTES + 1))
        .unwrap();
    refused(&big, "more than the");
    // The default scene as a file reads as before.
    let ok = dir.join("default.toml");
    std::fs::write(&ok, DEFAULT_SCENE).unwrap();
    assert!(Scene::from_path(&ok).is_ok());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Two bodies at one point under a pair law, or a spring with a rest length between them, have
/// no force direction: refused at the effect, naming the bodies (it failed the first step as a
/// Newton failure with "try a smaller step").
#[test]
fn coincident_bodies_under_a_pair_law_or_a_spring_are_named() {
    let two = |effect: &str| {
        format!(
            r#"
version = 1
dim = 2
[[bodies]]
name = "a"
mass = 1.0
position = [0.5, 0.5]
[[bodies]]
name = "b"
mass = 1.0
position = [0.5, 0.5]
[[bodies]]
name = "c"
mass = 1.0
position = [2.0, 0.0]
{effect}
[integrator]
dt = 0.01
t_end = 0.1
"#
        )
    };
    for effect in [
        "[[effects]]\ntype = \"pair\"\nlaw = \"inverse-power\"\nstrength = 1.0",
        "[[effects]]\ntype = \"spring\"\nbodies = [\"a\", \"b\"]\nstiffness = 10.0\nrest_length = 1.0",
    ] {
        let e = parse(&two(effect)).compile().unwrap_err();
        assert_eq!(e.kind, SceneErrorKind::Value, "{e}");
        assert_eq!(e.path.to_string(), "effects[0]", "{e}");
        assert!(
            e.message.contains("'a', 'b'") && e.message.contains("coincide"),
            "{e}"
        );
        assert!(!e.message.contains("'c'"), "{e}");
    }
}

/// An initial state off its rod by 1e-10 (above round-off, below the `√ε` refusal): accepted
/// with a note, or — with `project_initial = true` — projected and reported (it was accepted
/// with the note even then, while the note recommended the setting).
#[test]
fn project_initial_projects_small_violations_too() {
    let text = |project: bool| {
        format!(
            r#"
version = 1
dim = 2
[[bodies]]
name = "bob"
mass = 1.0
position = [0.6, -0.8000000001]
[[constraints]]
type = "rod"
bodies = ["bob"]
point = [0.0, 0.0]
length = 1.0
[integrator]
dt = 0.01
t_end = 0.1
project_initial = {project}
"#
        )
    };
    let c = parse(&text(false)).compile().unwrap();
    assert!(c.assembly.initial_projection.is_none());
    assert!(
        c.assembly
            .notes
            .iter()
            .any(|n| n.contains("off the constraints")),
        "{:?}",
        c.assembly.notes
    );
    let c = parse(&text(true)).compile().unwrap();
    let (dq, _) = c.assembly.initial_projection.expect("projected");
    assert!(dq > 5e-11 && dq < 2e-10, "{dq:e}");
    assert!(
        !c.assembly
            .notes
            .iter()
            .any(|n| n.contains("off the constraints")),
        "{:?}",
        c.assembly.notes
    );
}
