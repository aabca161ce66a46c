//! Planar scenes (`dim = 2`) with rigid bodies: a body in the plane is its centre and two
//! directors, its inertia the moment about the plane's normal; a hinge is a pin, a slider keeps
//! its axis in the plane. The planar four-bar and slider-crank run through the states of the
//! spatial scenes they mirror; a disc on a sprung, damped pin rings down as its closed form;
//! a free body keeps its spin; what would leave the plane is refused where it is written.

use crate::common::fitted_order;
use crate::scene_text::parse;
use lieflow::scene::{RunSummary, Scene, SceneErrorKind, run};

/// The run of `text` (its final state, outputs and summary), with every row at the projection's
/// level for unit-scale rows (as every rigid scene).
fn run_text(text: &str, t_end: f64) -> (RunSummary, Vec<f64>) {
    let text: String = text
        .lines()
        .map(|l| {
            if l.starts_with("t_end") {
                format!("t_end = {t_end}")
            } else {
                l.to_owned()
            }
        })
        .collect::<Vec<_>>()
        .join("\n");
    let mut c = Scene::from_toml(&text, "planar.toml")
        .unwrap()
        .compile()
        .unwrap_or_else(|e| panic!("{e}"));
    let mut out = Vec::new();
    let s = run(c.simulation.as_mut(), &c.plan, &mut |s| {
        out = s.outputs.to_vec()
    });
    assert!(s.error.is_none(), "{:?}", s.error);
    assert!(
        s.max_abs_g.unwrap() <= 64.0 * f64::EPSILON,
        "rows {:?}",
        s.max_abs_g
    );
    (s, out)
}

/// The planar scene against the spatial one it mirrors into the x–z plane, over `t_end`: every
/// body's centre and its momentum (planar `(x, y)` against spatial `(x, z)`), the energy, the
/// work supplied and taken, and the outputs (`signs`: +1 where the planar output equals the
/// spatial one, −1 where the mirror turns it). The spatial scene's motion stays in its plane (its
/// bodies are symmetric about it, every force lies in it), and there its projected steps are the
/// planar ones: they differ by rounding grown by the motion, `≲ N ε e^{λt}` over N = 10³…2·10³
/// steps — below 1e-10.
fn twins(planar: &str, spatial: &str, t_end: f64, bodies: usize, signs: &[f64]) {
    let (p, po) = run_text(planar, t_end);
    let (s, so) = run_text(spatial, t_end);
    let (np, ns) = (p.x.len() / 2, s.x.len() / 2);
    assert_eq!((np, ns), (6 * bodies, 12 * bodies));
    let mut worst = 0.0f64;
    for b in 0..bodies {
        for (k2, k3) in [(0, 0), (1, 2)] {
            worst = worst.max((p.x[6 * b + k2] - s.x[12 * b + k3]).abs());
            worst = worst.max((p.x[np + 6 * b + k2] - s.x[ns + 12 * b + k3]).abs());
        }
    }
    let close = |a: Option<f64>, b: Option<f64>| match (a, b) {
        (Some(a), Some(b)) => (a - b).abs() <= 1e-10 * b.abs().max(1.0),
        (a, b) => a == b,
    };
    eprintln!(
        "planar against spatial over {t_end} s: centres {worst:e}, supplied {:?} / {:?}, newton {} / {}, {:.1} / {:.1} µs a step",
        p.supplied,
        s.supplied,
        p.newton_iterations,
        s.newton_iterations,
        p.ns_per_step * 1e-3,
        s.ns_per_step * 1e-3,
    );
    assert!(worst <= 1e-10, "centres {worst:e}");
    assert!(close(p.energy_final, s.energy_final));
    assert!(close(p.supplied, s.supplied) && close(p.dissipated, s.dissipated));
    assert!(p.supplied.unwrap().abs() > 1.0, "the motor works");
    for (k, sign) in signs.iter().enumerate() {
        assert!(
            (po[k] - sign * so[k]).abs() <= 1e-9 * so[k].abs().max(1.0),
            "output {k}: {} against {}",
            po[k],
            so[k]
        );
    }
}

#[test]
fn the_planar_four_bar_runs_through_the_spatial_one_s_states() {
    // Four pins in the plane against two hinges and two balls in space; the crank's rate
    // (about +z against +y: mirrored) and the rocker's spin (its z against y: mirrored).
    twins(
        include_str!("../../scenes/four_bar_planar.toml"),
        include_str!("../../scenes/four_bar.toml"),
        1.0,
        3,
        &[-1.0],
    );
}

#[test]
fn the_planar_slider_crank_runs_through_the_spatial_one_s_states() {
    // Pins and a planar slider against hinges, balls and a spatial slider, with friction on the
    // piston; the flywheel's rate (both counter-clockwise about the motor's axis) and the
    // piston's x.
    twins(
        include_str!("../../scenes/slider_crank_planar.toml"),
        include_str!("../../scenes/slider_crank.toml"),
        2.0,
        3,
        &[1.0, 1.0],
    );
}

/// A disc (2 kg, radius 0.2: moment 0.04) on a pin at the origin with a torsion spring `k` and a
/// damper `c`, started turning at `w0`; its angle and the damper's account as outputs.
fn sprung_disc(dt: f64, t_end: f64, k: f64, c: f64, w0: f64) -> String {
    format!(
        r#"
version = 1
dim = 2
[[bodies]]
name = "disc"
mass = 2.0
inertia = {{ moment = 0.04 }}
position = [0.0, 0.0]
angular_velocity = [{w0}]
[[constraints]]
type = "hinge"
name = "axle"
bodies = ["disc"]
anchor = [0.0, 0.0]
[[effects]]
type = "torsion-spring"
bodies = ["disc"]
stiffness = {k}
[[effects]]
type = "hinge-damper"
bodies = ["disc"]
coefficient = {c}
[[outputs]]
quantity = "joint-position"
constraint = "axle"
[[outputs]]
quantity = "angular-velocity"
body = "disc"
component = 2
[integrator]
dt = {dt}
t_end = {t_end}
"#
    )
}

#[test]
fn a_disc_on_a_sprung_damped_pin_rings_down_as_its_closed_form() {
    // I θ'' + c θ' + k θ = 0, θ(0) = 0, θ'(0) = ω₀: θ = (ω₀/ω_d) e^{−ζω t} sin ω_d t. The pin's
    // angle follows it at order 2, the energy lost equals the damper's booked dissipation to
    // the scheme's error, and the angle never runs backwards in energy.
    let (i, k, c, w0, t_end): (f64, f64, f64, f64, f64) = (0.04, 1.0, 0.02, 2.0, 2.0);
    let wn = (k / i).sqrt();
    let zeta = c / (2.0 * (k * i).sqrt());
    let wd = wn * (1.0 - zeta * zeta).sqrt();
    let want = (w0 / wd) * (-zeta * wn * t_end).exp() * (wd * t_end).sin();
    let hs = [0.004, 0.002, 0.001, 0.0005];
    let mut errs = Vec::new();
    for &h in &hs {
        let (s, out) = run_text(&sprung_disc(h, t_end, k, c, w0), t_end);
        errs.push((out[0] - want).abs());
        assert!(s.dissipated.unwrap() > 0.0);
        assert!(
            s.max_energy_increase.unwrap() <= 1e-12,
            "{:?}",
            s.max_energy_increase
        );
        let lost = s.energy_initial.unwrap() - s.energy_final.unwrap();
        assert!(
            (lost - s.dissipated.unwrap()).abs() <= 1e-3 * lost,
            "lost {lost}, booked {:?}",
            s.dissipated
        );
    }
    let p = fitted_order(&hs, &errs, 1e-12);
    eprintln!("planar sprung disc: errors {errs:?}, order {p:.3}");
    assert!((p - 2.0).abs() < 0.2, "order {p}");
}

#[test]
fn a_free_planar_body_keeps_its_spin_and_its_drift() {
    // No force: the centre drifts exactly, the spin read from the directors (ω = ½ Σ dᵢ × ḋᵢ)
    // stays at its start to round-off, and the energy with it (RATTLE on the rotation keeps
    // the body's angular momentum, and Q̇ Qᵀ is skew at every step).
    let text = r#"
version = 1
dim = 2
[[bodies]]
name = "plate"
mass = 3.0
inertia = { shape = "box", size = [0.4, 0.1, 0.02] }
position = [1.0, 2.0]
velocity = [0.5, -0.25]
orientation = { angle_deg = 20 }
angular_velocity = [7.0]
[[outputs]]
quantity = "angular-velocity"
body = "plate"
component = 2
[integrator]
dt = 0.01
t_end = 10.0
"#;
    let (s, out) = run_text(text, 10.0);
    assert!((out[0] - 7.0).abs() <= 1e-12, "{}", out[0]);
    assert!((s.x[0] - 6.0).abs() <= 1e-12 && (s.x[1] - (-0.5)).abs() <= 1e-12);
    assert!(s.max_abs_energy_error.unwrap() <= 1e-12 * s.energy_initial.unwrap());
}

fn planar_body(body: &str, rest: &str) -> String {
    format!(
        "version = 1\ndim = 2\n[[bodies]]\nname = \"b\"\nmass = 1\nposition = [0, -0.5]\n{body}\n{rest}\n[integrator]\ndt = 0.01\nt_end = 0.1\n"
    )
}

#[test]
fn what_would_leave_the_plane_is_refused_where_it_is_written() {
    let disc = "inertia = { moment = 0.1 }";
    let cases: Vec<(String, SceneErrorKind, &str, &str)> = vec![
        (
            planar_body(disc, "[[constraints]]\ntype = \"ball\"\nbodies = [\"b\"]\nanchor = [0, 0]"),
            SceneErrorKind::Dimension,
            "constraints[0]",
            "hinge",
        ),
        (
            planar_body(
                disc,
                "[[constraints]]\ntype = \"universal\"\nbodies = [\"b\"]\nanchor = [0, 0]\naxes = [[1, 0], [0, 1]]",
            ),
            SceneErrorKind::Dimension,
            "constraints[0]",
            "dim = 3",
        ),
        (
            planar_body(
                disc,
                "[[constraints]]\ntype = \"hinge\"\nbodies = [\"b\"]\nanchor = [0, 0]\naxis = [1, 0]",
            ),
            SceneErrorKind::Value,
            "constraints[0].axis",
            "normal",
        ),
        (
            planar_body(&format!("{disc}\nangular_velocity = [0, 0, 1]"), ""),
            SceneErrorKind::Dimension,
            "bodies[0].angular_velocity",
            "one rate",
        ),
        (
            planar_body(
                "inertia = { moments = [1, 2, 2] }\norientation = { axis = [1, 0, 0], angle_deg = 30 }",
                "",
            ),
            SceneErrorKind::Value,
            "bodies[0].orientation",
            "normal",
        ),
        (
            planar_body(
                "inertia = { tensor = [[1, 0, 0.2], [0, 1, 0], [0.2, 0, 1.5]] }",
                "",
            ),
            SceneErrorKind::Value,
            "bodies[0].inertia",
            "xz",
        ),
        (
            planar_body("inertia = { moment = 1, shape = \"box\", size = [1, 1, 1] }", ""),
            SceneErrorKind::Value,
            "bodies[0].inertia",
            "exactly one",
        ),
        (
            "version = 1\ndim = 3\n[[bodies]]\nname = \"b\"\nmass = 1\nposition = [0, 0, 0]\ninertia = { moment = 1 }\n[integrator]\ndt = 0.01\nt_end = 0.1\n".to_owned(),
            SceneErrorKind::Value,
            "bodies[0].inertia.moment",
            "planar",
        ),
        (
            planar_body(
                disc,
                "[[constraints]]\ntype = \"slider\"\nbodies = [\"b\"]\naxis = [1, 0, 0]",
            ),
            SceneErrorKind::Dimension,
            "constraints[0].axis",
            "2-dimensional",
        ),
    ];
    for (text, kind, path, word) in cases {
        let e = match parse(&text).compile() {
            Ok(_) => panic!("accepted: {text}"),
            Err(e) => e,
        };
        assert_eq!((e.kind, e.path.to_string().as_str()), (kind, path), "{e}");
        assert!(e.message.contains(word), "`{word}` not in: {e}");
    }
}
