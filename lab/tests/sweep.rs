//! Parameter sweeps: members enumerate the grid in id order, run in parallel with the
//! same rows bit for bit whatever the number of threads, a failing member is a row, and random
//! sweeps draw each member's values from its own seeded stream.

use lieflow_lab::sweep::{Sweep, SweepFile, run_all, to_jsonl};
use std::path::Path;

fn sweep() -> Sweep {
    Sweep::from_path(Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../tests/data/sweep_damped.toml"
    )))
    .unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn the_grid_is_enumerated_in_id_order() {
    let s = sweep();
    assert_eq!(s.len(), 12);
    let m = s.member(5);
    assert_eq!(m.parameters[0], ("effects[1].coefficient".to_owned(), 0.5));
    assert_eq!(m.parameters[1].0, "integrator.dt");
    assert!(
        (m.parameters[1].1 - 2e-3).abs() < 1e-15,
        "{:?}",
        m.parameters
    );
    let ids: Vec<usize> = s.members().map(|m| m.id).collect();
    assert_eq!(ids, (0..12).collect::<Vec<_>>());
}

#[test]
fn rows_are_identical_for_one_and_two_threads() {
    let s = sweep();
    let members: Vec<_> = s.members().collect();
    let one = run_all(&s, &members, 1, &|| {}).unwrap();
    let two = run_all(&s, &members, 2, &|| {}).unwrap();
    let rows = |r: &[(lieflow_lab::sweep::MemberRow, f64)]| {
        r.iter().map(|(r, _)| r.clone()).collect::<Vec<_>>()
    };
    let (a, b) = (to_jsonl(&rows(&one)), to_jsonl(&rows(&two)));
    assert_eq!(a, b, "the rows differ between 1 and 2 threads");
    assert_eq!(a.lines().count(), 12);
    // Physics: without damping nothing is dissipated; with it, more damping dissipates more
    // by t = 10 (the pendulum has not come to rest).
    for (row, _) in &one {
        assert_eq!(row.error, None, "member {}", row.id);
        let c = row.parameter("effects[1].coefficient").unwrap();
        // Zero damping assembles no damping term: nothing is reported as dissipated.
        let d = row.output("dissipated").unwrap_or(0.0);
        if c == 0.0 {
            assert!(d.abs() < 1e-9, "member {}: dissipated {d:e}", row.id);
        } else {
            assert!(d > 0.0);
        }
        assert!(row.max_abs_g.unwrap() < 1e-13);
    }
}

#[test]
fn a_failing_member_is_a_row_not_an_abort() {
    let mut s = sweep();
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../scenes/damped_pendulum.toml"
    ))
    .unwrap();
    let file = SweepFile {
        parameters: vec![lieflow_lab::sweep::ParameterSpec {
            path: "integrator.dt".into(),
            values: Some(vec![0.01, -1.0, 0.02]),
            grid: None,
            random: None,
        }],
        plot: None,
        ..s.file.clone()
    };
    s = Sweep::new(file, &text, "damped_pendulum.toml").unwrap();
    let members: Vec<_> = s.members().collect();
    let rows = run_all(&s, &members, 2, &|| {}).unwrap();
    assert_eq!(rows.len(), 3);
    assert!(rows[0].0.error.is_none() && rows[2].0.error.is_none());
    let (kind, message) = rows[1].0.error.clone().expect("dt = -1 fails");
    assert_eq!(kind, "Setup");
    assert!(message.contains("dt"), "{message}");
}

#[test]
fn random_members_are_reproducible_and_in_bounds() {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../scenes/damped_pendulum.toml"
    ))
    .unwrap();
    let file: SweepFile = toml::from_str(
        r#"
        version = 1
        scene = "unused.toml"
        mode = "random"
        members = 50
        seed = 7
        [[parameters]]
        path = "effects[1].coefficient"
        random = { low = 0.01, high = 10.0, scale = "log" }
        [[parameters]]
        path = "bodies[0].velocity[0]"
        random = { low = -1.0, high = 1.0 }
        "#,
    )
    .unwrap();
    let a = Sweep::new(file.clone(), &text, "damped_pendulum.toml").unwrap();
    let b = Sweep::new(file, &text, "damped_pendulum.toml").unwrap();
    assert_eq!(a.len(), 50);
    for id in [0, 17, 49] {
        assert_eq!(a.member(id), b.member(id));
        let p = &a.member(id).parameters;
        assert!(
            (0.01..10.0).contains(&p[0].1) && (-1.0..1.0).contains(&p[1].1),
            "{p:?}"
        );
    }
    assert_ne!(a.member(0), a.member(1));
}

#[test]
fn bad_random_values_are_refused_and_integer_fields_can_be_swept() {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../scenes/chain100_damped.toml"
    ))
    .unwrap();
    let empty: SweepFile = toml::from_str(
        "version = 1\nscene = \"x\"\nmode = \"random\"\nmembers = 3\n[[parameters]]\npath = \"integrator.dt\"\nvalues = []\n",
    )
    .unwrap();
    let err = Sweep::new(empty, &text, "chain.toml")
        .unwrap_err()
        .to_string();
    assert!(err.contains("at least one"), "{err}");
    // `links` is an integer field: swept values are written as integers.
    let links: SweepFile = toml::from_str(
        "version = 1\nscene = \"x\"\n[[parameters]]\npath = \"chains[0].links\"\nvalues = [3, 5]\n[[parameters]]\npath = \"integrator.t_end\"\nvalues = [0.01]\n",
    )
    .unwrap();
    let s = Sweep::new(links, &text, "chain.toml").unwrap();
    let members: Vec<_> = s.members().collect();
    let rows = run_all(&s, &members, 1, &|| {}).unwrap();
    for (row, _) in &rows {
        assert_eq!(row.error, None, "member {}: {:?}", row.id, row.error);
        assert_eq!(row.steps, 10);
    }
}

/// A sweep file and its base scene are read as scene files are: a device or a directory is
/// refused before anything is read (`/dev/zero` as the base scene read without bound).
#[test]
fn a_sweep_reads_only_regular_files() {
    let dir = std::env::temp_dir().join(format!("lieflow-sweep-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("sweep.toml");
    std::fs::write(
        &file,
        "version = 1\nscene = \"/dev/zero\"\nmode = \"grid\"\n[[parameters]]\npath = \"integrator.dt\"\nvalues = [0.1]\n",
    )
    .unwrap();
    let e = Sweep::from_path(&file).unwrap_err();
    assert!(e.to_string().contains("not a regular file"), "{e}");
    assert_eq!(e.path.to_string(), "scene", "{e}");
    let e = Sweep::from_path(&dir).unwrap_err();
    assert!(e.to_string().contains("not a regular file"), "{e}");
    std::fs::remove_dir_all(&dir).ok();
}
