//! Work–precision: the fitted slopes are the schemes' orders, the peers' rows are honest, the
//! CSV has its documented columns, and a failing run is a row.

use lieflow::scene::Scene;
use lieflow_lab::precision::{
    CSV_COLUMNS, PrecisionPlan, PrecisionRow, fitted_slopes, reference, work_precision, write_csv,
};

const PAPER: &str = include_str!("../../scenes/paper.toml");

fn paper(t_end: f64) -> Scene {
    let mut s = Scene::from_toml(PAPER, "paper.toml").unwrap();
    s.file.integrator.t_end = t_end;
    s
}

fn plan(dts: &[f64], orders: &[u32]) -> PrecisionPlan {
    let mut p = PrecisionPlan::around(0.1, 100.0);
    p.dts = dts.to_vec();
    p.orders = orders.to_vec();
    p.discrete_gradient = false;
    p.midpoint = false;
    p.modified = false;
    p.petrov_galerkin.clear();
    p.peers = false;
    p.adaptive = false;
    p.repeats = 1;
    p
}

/// The fitted slopes of the rows with errors in `[floor, 1e-2]`.
fn slopes_of(scene: &Scene, plan: &PrecisionPlan, floor: f64) -> Vec<(String, f64)> {
    let r = reference(scene, plan).unwrap();
    let rows = work_precision(scene, plan, &r, &mut |_| {});
    assert!(rows.iter().all(|r| r.status == "ok"), "{rows:?}");
    fitted_slopes(&rows, floor, 1e-2)
}

/// Against the closed-form solution, step sizes in each scheme's asymptotic range, every error
/// far above the accumulated round-off. The order-8 composition needs the long horizon to lift
/// its errors above round-off, and there the round-off of 10⁴–10⁵ steps is 2e-11 to 6e-11 (the
/// whole error at h ≤ 0.5, which moves with any change of rounding): its floor is 2e-10, and
/// its steps (errors 2.4e-7 … 8e-10) stay above it. Fitted there: 8.25.
#[test]
fn fitted_slopes_are_the_orders_on_the_paper_example() {
    let cases: [(f64, &[f64], u32, f64); 4] = [
        (100.0, &[0.4, 0.2, 0.1, 0.05], 2, 1e-11),
        (100.0, &[0.4, 0.2, 0.1, 0.05], 4, 1e-11),
        (100.0, &[1.25, 0.625, 0.3125, 0.15625], 6, 1e-11),
        (10000.0, &[1.6, 1.25, 1.0, 0.8], 8, 2e-10),
    ];
    for (t_end, dts, order, floor) in cases {
        let slopes = slopes_of(&paper(t_end), &plan(dts, &[order]), floor);
        assert_eq!(slopes.len(), 1);
        let (name, slope) = &slopes[0];
        assert_eq!(name, &format!("lieflow order {order}"));
        assert!(
            (slope - order as f64).abs() < 0.3,
            "order {order}: slope {slope}"
        );
    }
    // The implicit schemes of the paper's model are second order too.
    let mut p = plan(&[0.4, 0.2, 0.1, 0.05], &[]);
    p.midpoint = true;
    p.modified = true;
    for (name, slope) in slopes_of(&paper(100.0), &p, 1e-11) {
        assert!((slope - 2.0).abs() < 0.1, "{name}: {slope}");
    }
}

/// DOP853 on the index-1 ODE converges with its tolerance but drifts off the constraint; the
/// projection keeps |g| at round-off whatever its error.
#[test]
fn peers_converge_and_drift() {
    let scene = paper(100.0);
    let mut p = plan(&[0.1], &[2]);
    p.peers = true;
    p.tolerances = vec![1e-6, 1e-10];
    let r = reference(&scene, &p).unwrap();
    let rows = work_precision(&scene, &p, &r, &mut |_| {});
    let dop: Vec<&PrecisionRow> = rows
        .iter()
        .filter(|r| r.method.starts_with("DOP853"))
        .collect();
    assert_eq!(dop.len(), 2);
    assert!(dop.iter().all(|r| r.status == "ok"));
    assert!(dop[1].error.unwrap() < 1e-3 * dop[0].error.unwrap());
    assert!(dop[0].max_abs_g.unwrap() > 1e-8, "{:?}", dop[0].max_abs_g);
    let radau: Vec<&PrecisionRow> = rows
        .iter()
        .filter(|r| r.method.starts_with("Radau5"))
        .collect();
    assert_eq!(radau.len(), 2);
    assert!(
        radau
            .iter()
            .all(|r| r.status == "ok" && r.error.unwrap() < 1e-2),
        "{radau:?}"
    );
    let lieflow = rows.iter().find(|r| r.method == "lieflow order 2").unwrap();
    assert!(lieflow.max_abs_g.unwrap() < 1e-15);
}

#[test]
fn the_csv_has_the_documented_columns() {
    let scene = paper(10.0);
    let p = plan(&[0.1, 0.05], &[2, 4]);
    let r = reference(&scene, &p).unwrap();
    let rows = work_precision(&scene, &p, &r, &mut |_| {});
    let slopes = fitted_slopes(&rows, 0.0, f64::INFINITY);
    let mut out = Vec::new();
    write_csv(
        &mut out,
        &[("reference", r.source.clone()), ("machine", "test".into())],
        &rows,
        &slopes,
    )
    .unwrap();
    let text = String::from_utf8(out).unwrap();
    let mut lines = text.lines();
    assert!(
        lines
            .next()
            .unwrap()
            .starts_with("# reference: closed form")
    );
    assert_eq!(lines.next().unwrap(), "# machine: test");
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(header, CSV_COLUMNS);
    let data: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(data.len(), 4);
    let col = |name: &str| CSV_COLUMNS.iter().position(|c| *c == name).unwrap();
    for row in &data {
        assert_eq!(row.len(), CSV_COLUMNS.len());
        assert_eq!(row[col("status")], "ok");
        let e: f64 = row[col("error")].parse().unwrap();
        assert!(e > 0.0 && e < 1e-2);
        let _: f64 = row[col("time_min_s")].parse().unwrap();
        let _: u64 = row[col("evaluations")].parse().unwrap();
        let slope: f64 = row[col("fitted_order")].parse().unwrap();
        assert!(slope > 1.5);
    }
}

/// A step so large that the multiplier equation has no solution near the iterates, and a step
/// that does not divide the horizon: rows with their error kinds, not panics.
#[test]
fn a_failing_setup_is_a_row() {
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
        dt = 0.01
        t_end = 2.0
    "#;
    let scene = Scene::from_toml(text, "whirl.toml").unwrap();
    let p = plan(&[0.5, 0.3, 0.01], &[2]);
    let r = reference(&scene, &plan(&[0.01], &[2])).unwrap();
    let rows = work_precision(&scene, &p, &r, &mut |_| {});
    assert_eq!(rows.len(), 3);
    assert_eq!(rows[0].status, "Newton", "{:?}", rows[0]);
    assert!(rows[0].message.contains("step 1"), "{}", rows[0].message);
    assert_eq!(rows[1].status, "Setup");
    assert!(rows[1].message.contains("does not divide"));
    assert_eq!(rows[2].status, "ok");
    assert!(rows[2].error.unwrap() < 1e-2);
}

/// Without a closed form the reference is a double-double run of order 8 (with damping, Strang
/// extrapolated to order 8: every sub-step forward) whose own error is far below f64's
/// resolution — under a tenth of ε for a state of size one; the double-precision reference
/// agrees with it to round-off.
#[test]
fn the_double_double_reference_is_below_double_precision() {
    let text =
        include_str!("../../scenes/damped_pendulum.toml").replace("t_end = 10.0", "t_end = 1.0");
    let scene = Scene::from_toml(&text, "damped_pendulum.toml").unwrap();
    let mut p = plan(&[0.02, 0.01], &[2]);
    let dd = reference(&scene, &p).unwrap();
    assert!(dd.source.contains("double-double"), "{}", dd.source);
    assert!(
        dd.error_estimate.unwrap() < f64::EPSILON / 10.0,
        "{:?}",
        dd.error_estimate
    );
    p.double_double = false;
    let f = reference(&scene, &p).unwrap();
    assert!(!f.source.contains("double-double"));
    let diff =
        dd.x.iter()
            .zip(&f.x)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    // Kahan–Li 8 at h/16 in f64 over 800 steps: a few hundred ulps of |x| ≤ 1.
    assert!(diff < 1e-13, "{diff:e}");
}

/// The errors of the rows whose method starts with `method`, each row `ok`.
fn errors_of(rows: &[PrecisionRow], method: &str) -> Vec<f64> {
    rows.iter()
        .filter(|r| r.method.starts_with(method))
        .map(|r| {
            assert_eq!(r.status, "ok", "{r:?}");
            r.error.expect("an ok row has an error")
        })
        .collect()
}

/// Radau5's error falls with its tolerance (vector tolerances, Hairer's Newton tolerance): a
/// scalar tolerance used to be transformed once per component and left the error flat at
/// 1e-5 … 1e-3 whatever was asked. Radau IIA is of order 5 (stage order 3), so six decades of
/// tolerance buy at least three decades of error.
#[test]
fn radau5_error_falls_with_its_tolerance() {
    let scene = paper(100.0);
    let mut p = plan(&[0.1], &[2]);
    p.peers = true;
    p.tolerances = vec![1e-6, 1e-12];
    let r = reference(&scene, &p).unwrap();
    let rows = work_precision(&scene, &p, &r, &mut |_| {});
    let radau = errors_of(&rows, "Radau5");
    let (loose, tight) = (radau[0], radau[1]);
    eprintln!("Radau5 on the paper's example: {loose:e} at 1e-6, {tight:e} at 1e-12");
    assert!(tight < 1e-3 * loose, "{loose:e} → {tight:e}");
}

/// A damped pendulum driven by a torque at its pivot: every row integrates the input.
const DRIVEN: &str = r#"
version = 1
dim = 2
[[bodies]]
name = "bob"
mass = 1.0
position = [0.6, -0.8]
[[constraints]]
type = "rod"
bodies = ["bob"]
point = [0.0, 0.0]
[[effects]]
type = "gravity"
g = [0.0, -9.81]
[[effects]]
type = "damping"
coefficient = 0.3
[[inputs]]
type = "torque"
name = "motor"
body = "bob"
pivot = [0.0, 0.0]
signal = { type = "sine", amplitude = 2.0, omega = 3.0 }
[integrator]
dt = 0.01
t_end = 3.0
"#;

/// On a scene with inputs the peers take the input in their right-hand sides and the
/// Petrov–Galerkin rows in their residual: every error falls with the tolerance or the step
/// (a peer that ignored the torque stayed ~1 away at every tolerance).
#[test]
fn every_row_of_a_driven_scene_integrates_its_input() {
    let scene = Scene::from_toml(DRIVEN, "driven.toml").unwrap();
    let mut p = plan(&[0.02, 0.01], &[2]);
    p.peers = true;
    p.tolerances = vec![1e-6, 1e-10];
    p.petrov_galerkin = vec![4];
    let r = reference(&scene, &p).unwrap();
    let rows = work_precision(&scene, &p, &r, &mut |_| {});
    for row in &rows {
        eprintln!(
            "{} dt {:?} tol {:?}: {} {:?}",
            row.method, row.dt, row.tol, row.status, row.error
        );
    }
    assert!(rows.iter().all(|r| r.status == "ok"), "{rows:?}");
    for prefix in ["DOP853", "Radau5"] {
        let peer = errors_of(&rows, prefix);
        assert_eq!(peer.len(), 2, "{prefix}");
        assert!(
            peer[1] < 1e-6 && peer[1] < 1e-2 * peer[0],
            "{prefix}: {peer:?}"
        );
    }
    let pg = errors_of(&rows, "lieflow Petrov");
    // Order 4: halving the step divides the error by about 16.
    assert_eq!(pg.len(), 2);
    assert!(pg[1] < 1e-6 && pg[0] / pg[1] > 10.0, "{pg:?}");
}

/// Radau5 runs beside a scene of any size (here a driven double pendulum, `n + m = 10`, none of
/// the sizes it has fixed arrays for; it was a `Skipped` row) and its error falls with its
/// tolerance.
#[test]
fn radau5_runs_beside_a_scene_of_any_size() {
    let text = DRIVEN
        .replace(
            "[[constraints]]",
            "[[bodies]]\nname = \"tip\"\nmass = 0.5\nposition = [1.2, -1.6]\n[[constraints]]\ntype = \"rod\"\nbodies = [\"bob\", \"tip\"]\n[[constraints]]",
        )
        .replace("t_end = 3.0", "t_end = 1.0");
    let scene = Scene::from_toml(&text, "double.toml").unwrap();
    let mut p = plan(&[0.01], &[2]);
    p.peers = true;
    p.tolerances = vec![1e-5, 1e-13];
    let r = reference(&scene, &p).unwrap();
    let rows = work_precision(&scene, &p, &r, &mut |_| {});
    let radau = errors_of(&rows, "Radau5");
    let (loose, tight) = (radau[0], radau[1]);
    eprintln!(
        "Radau5 on a driven double pendulum (n + m = 10): {loose:e} at 1e-5, {tight:e} at 1e-13"
    );
    // Eight decades of tolerance buy at least three of error. (Between them the crate's error
    // does not fall steadily — 2.3e-6, 5.3e-7, 1.2e-7 at 1e-7, 1e-9, 1e-11 — as on its fixed
    // arrays: it keeps its LU across step-size changes; DOP853 falls 3.8e-6 … 1.9e-14 here.)
    assert!(tight < 1e-3 * loose, "{loose:e} → {tight:e}");
}

/// The adaptive extrapolation's rows: one per tolerance, the tolerance in `tol` and no `dt`,
/// the error near the tolerance (the run is one report interval: the controller chooses every
/// step), the rows at round-off, no fitted order (it has no step size).
#[test]
fn the_adaptive_extrapolation_is_a_row_per_tolerance() {
    let text = include_str!("../../scenes/damped_pendulum.toml");
    let mut scene = Scene::from_toml(text, "damped_pendulum.toml").unwrap();
    scene.file.integrator.t_end = 2.0;
    let mut p = plan(&[0.01], &[2]);
    p.adaptive = true;
    p.tolerances = vec![1e-6, 1e-9];
    let r = reference(&scene, &p).unwrap();
    let rows = work_precision(&scene, &p, &r, &mut |_| {});
    let adaptive: Vec<&PrecisionRow> = rows
        .iter()
        .filter(|r| r.method == "lieflow adaptive extrapolation")
        .collect();
    assert_eq!(adaptive.len(), 2, "{rows:?}");
    for (row, tol) in adaptive.iter().zip([1e-6, 1e-9]) {
        assert_eq!(
            (row.status.as_str(), row.dt, row.tol),
            ("ok", None, Some(tol))
        );
        let e = row.error.unwrap();
        // Each step's local error at the tolerance, over a span of 2 s: within a factor 20.
        assert!(e <= 20.0 * tol && e >= tol / 1e3, "tol {tol:e}: {e:e}");
        assert!(row.max_abs_g.unwrap() <= 64.0 * f64::EPSILON);
        assert!(row.steps > 0 && row.time_min.is_some());
    }
    let slopes = fitted_slopes(&rows, 1e-14, 1e-2);
    assert!(slopes.iter().all(|(m, _)| !m.contains("adaptive")));
}

/// A periodic motion over whole periods: the reference is the initial state, exact, and the
/// adaptive runs' errors at the end are the orbit's error after the periods.
#[test]
fn a_periodic_scene_s_reference_is_its_initial_state() {
    let text = include_str!("../../scenes/kepler.toml");
    let mut scene = Scene::from_toml(text, "kepler.toml").unwrap();
    scene.file.integrator.t_end = 2.0 * std::f64::consts::PI / 1.001f64.sqrt();
    let mut p = plan(&[scene.file.integrator.t_end / 2000.0], &[8]);
    p.periodic = true;
    p.adaptive = true;
    p.tolerances = vec![1e-10];
    let r = reference(&scene, &p).unwrap();
    assert_eq!(r.error_estimate, None);
    assert_eq!(r.x, scene.compile().unwrap().simulation.state().to_vec());
    let rows = work_precision(&scene, &p, &r, &mut |_| {});
    assert!(rows.iter().all(|r| r.status == "ok"), "{rows:?}");
    // One period at tol 1e-10: the orbit's error, 185 … 2100 × tol on this orbit
    // (docs/method.md §12d: each step's local error at the tolerance, the perihelion's shear
    // carrying it), so below 1e4 × tol; a reference that were not the initial state would be
    // off by the orbit's size, 0.1 … 1.9.
    let adaptive = rows.iter().find(|r| r.tol == Some(1e-10)).unwrap();
    assert!(adaptive.error.unwrap() < 1e-6, "{adaptive:?}");
}
