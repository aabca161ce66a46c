//! Rigid bodies and joints in scene files: a heavy top on a ball joint against its steady
//! precession, a bar on a hinge against the compound pendulum, a free body's quaternion and
//! angular velocity against uniform rotation — each at order 2 with every row (`QᵀQ = I`, the
//! joints) at round-off — and bad bodies and joints refused where they are written.

use crate::common::{fitted_order, pendulum_angle};
use lieflow::scene::{Scene, SceneErrorKind, run};

fn parse(text: &str) -> Scene {
    Scene::from_toml(text, "rigid.toml").unwrap_or_else(|e| panic!("{e}"))
}

/// A projected step keeps every row at the level its Newton tolerance asks of a unit-scale
/// scene, `16 ε`.
const ROWS: f64 = 16.0 * f64::EPSILON;

/// Runs `text`; returns the final state, the last outputs and `max |g|` over the run.
fn run_scene(text: &str) -> (Vec<f64>, Vec<f64>, f64) {
    let mut c = parse(text).compile().unwrap_or_else(|e| panic!("{e}"));
    let mut outputs = Vec::new();
    let s = run(c.simulation.as_mut(), &c.plan, &mut |s| {
        outputs = s.outputs.to_vec();
    });
    assert!(s.error.is_none(), "{:?}", s.error);
    (s.x.clone(), outputs, s.max_abs_g.unwrap_or(0.0))
}

/// The heavy top of `scenes/spinning_top.toml`: a cylinder (1 kg, r = 0.1, h = 0.2) on a ball
/// joint at its base, tilted `θ` from the vertical, spinning at `Ω`, started on its slow
/// steady precession `s` (Goldstein §5.7: `I₁ cos θ s² − I₃ Ω s + m g l = 0`).
fn top(dt: f64, t_end: f64) -> (String, f64, f64) {
    let (m, r, h, g, theta, spin) = (1.0f64, 0.1, 0.2, 9.81, 0.5f64, 60.0);
    let l = 0.5 * h;
    let (j1, j3) = (m * (3.0 * r * r + h * h) / 12.0, 0.5 * m * r * r);
    let (i1, c) = (j1 + m * l * l, theta.cos());
    let s =
        (j3 * spin - (j3 * j3 * spin * spin - 4.0 * i1 * c * m * g * l).sqrt()) / (2.0 * i1 * c);
    let axis = [theta.sin(), 0.0, c];
    let omega: [f64; 3] =
        core::array::from_fn(|k| s * [0.0, 0.0, 1.0][k] + (spin - s * c) * axis[k]);
    let pos = axis.map(|a| l * a);
    let v = [
        omega[1] * pos[2] - omega[2] * pos[1],
        omega[2] * pos[0] - omega[0] * pos[2],
        omega[0] * pos[1] - omega[1] * pos[0],
    ];
    let text = format!(
        r#"
version = 1
dim = 3
[[bodies]]
name = "top"
mass = {m}
inertia = {{ shape = "cylinder", radius = {r}, height = {h} }}
position = {pos:?}
velocity = {v:?}
orientation = {{ axis = [0, 1, 0], angle_deg = {deg} }}
angular_velocity = {omega:?}
[[constraints]]
type = "ball"
name = "pivot"
bodies = ["top"]
anchor = [0, 0, 0]
[[effects]]
type = "gravity"
g = [0, 0, -{g}]
[integrator]
dt = {dt}
t_end = {t_end}
"#,
        deg = theta.to_degrees()
    );
    (text, s, l)
}

#[test]
fn a_spinning_top_scene_precesses_steadily_at_order_two() {
    // The centre is `l` along the axis, which turns about the vertical at `s` with the tilt
    // constant: `c(t) = l (sin θ cos st, sin θ sin st, cos θ)`.
    let t_end = 0.5;
    let hs = [4e-3, 2e-3, 1e-3, 5e-4];
    let mut errs = Vec::new();
    for &h in &hs {
        let (text, s, l) = top(h, t_end);
        let (x, _, g) = run_scene(&text);
        assert!(g <= ROWS, "h = {h}: rows {g:e}");
        let st = s * t_end;
        let want = [
            0.5f64.sin() * st.cos(),
            0.5f64.sin() * st.sin(),
            0.5f64.cos(),
        ]
        .map(|a| l * a);
        errs.push((0..3).map(|k| (x[k] - want[k]).abs()).fold(0.0, f64::max));
    }
    let p = fitted_order(&hs, &errs, 1e-13);
    eprintln!("spinning top scene against steady precession: errors {errs:?}, order {p:.3}");
    assert!((p - 2.0).abs() < 0.2, "{p}");
}

/// A bar (1 kg, 0.1 × 0.1 × 1 m) hanging from a hinge about `y` at its top end, released at
/// `θ₀` from the vertical.
fn hinged_bar(dt: f64, t_end: f64, theta0: f64) -> String {
    let l = 0.5;
    let (s, c) = theta0.sin_cos();
    format!(
        r#"
version = 1
dim = 3
[[bodies]]
name = "bar"
mass = 1.0
inertia = {{ shape = "box", size = [0.1, 0.1, 1.0] }}
position = [{x}, 0.0, {z}]
orientation = {{ axis = [0, 1, 0], angle_deg = {deg} }}
[[constraints]]
type = "hinge"
name = "hinge"
bodies = ["bar"]
anchor = [0, 0, 0]
axis = [0, 1, 0]
[[effects]]
type = "gravity"
g = [0, 0, -9.81]
[[outputs]]
quantity = "orientation"
body = "bar"
component = 2
[[outputs]]
quantity = "angular-velocity"
body = "bar"
component = 1
[integrator]
dt = {dt}
t_end = {t_end}
"#,
        x = -l * s,
        z = -l * c,
        deg = theta0.to_degrees()
    )
}

#[test]
fn a_bar_on_a_scene_hinge_swings_as_a_compound_pendulum() {
    // θ'' = −(m g l / I_p) sin θ, l = 0.5, I_p = J + m l² = (1 + 0.01)/12 + 0.25. The bar's
    // quaternion about y is (cos θ/2, 0, sin θ/2, 0) and its angular velocity θ' about y.
    let (g, l, theta0, t_end) = (9.81, 0.5, 1.0f64, 3.0);
    let ip = (1.0 + 0.01) / 12.0 + l * l;
    let theta = pendulum_angle(|th, _| -g * l / ip * th.sin(), theta0, t_end);
    let want = [-l * theta.sin(), 0.0, -l * theta.cos()];
    let hs = [0.04, 0.02, 0.01, 0.005];
    let mut errs = Vec::new();
    for &h in &hs {
        let (x, out, rows) = run_scene(&hinged_bar(h, t_end, theta0));
        assert!(rows <= ROWS, "h = {h}: rows {rows:e}");
        errs.push((0..3).map(|k| (x[k] - want[k]).abs()).fold(0.0, f64::max));
        // The outputs read the same motion: qy = sin(θ/2) to the scheme's error.
        assert!(
            (out[0] - (0.5 * theta).sin()).abs() < 50.0 * h * h,
            "{out:?}"
        );
    }
    let p = fitted_order(&hs, &errs, 1e-12);
    eprintln!("hinged bar scene against the compound pendulum: errors {errs:?}, order {p:.3}");
    assert!((p - 2.0).abs() < 0.2, "{p}");
}

#[test]
fn a_free_body_spinning_about_a_principal_axis_turns_uniformly() {
    // Moments (2, 3, 4), spinning at ω = 4 about its third axis: q(t) = (cos ωt/2, 0, 0,
    // sin ωt/2), body-frame Ω = (0, 0, ω) for ever. RATTLE's rotation rate is ω + O(h²).
    let (w, t_end) = (4.0f64, 1.0);
    let hs = [0.04, 0.02, 0.01, 0.005];
    let mut errs = Vec::new();
    for &h in &hs {
        let text = format!(
            r#"
version = 1
dim = 3
[[bodies]]
name = "box"
mass = 2.0
inertia = {{ moments = [2, 3, 4] }}
position = [0, 0, 0]
angular_velocity = [0, 0, {w}]
{outputs}
[integrator]
dt = {h}
t_end = {t_end}
"#,
            outputs = (0..4)
                .map(|k| format!("[[outputs]]\nquantity = \"orientation\"\nbody = \"box\"\ncomponent = {k}\n"))
                .chain((0..3).map(|k| format!("[[outputs]]\nquantity = \"body-angular-velocity\"\nbody = \"box\"\ncomponent = {k}\n")))
                .collect::<String>()
        );
        let (_, out, rows) = run_scene(&text);
        assert!(rows <= ROWS, "rows {rows:e}");
        let half = 0.5 * w * t_end;
        let want = [half.cos(), 0.0, 0.0, half.sin()];
        // No motion leaves the spin axis: the other components stay at round-off.
        for k in [1, 2] {
            assert!(
                out[k].abs() < 1e-14 && out[4 + k - 1].abs() < 1e-13,
                "{out:?}"
            );
        }
        assert!((out[6] - w).abs() < w * h * h, "Ω_z {}", out[6]);
        // q and −q are one rotation; the output takes w ≥ 0.
        let off = |sign: f64| {
            (0..4)
                .map(|k| (out[k] - sign * want[k]).abs())
                .fold(0.0, f64::max)
        };
        errs.push(off(1.0).min(off(-1.0)));
    }
    let p = fitted_order(&hs, &errs, 1e-13);
    eprintln!("free spin's quaternion against uniform rotation: errors {errs:?}, order {p:.3}");
    assert!((p - 2.0).abs() < 0.2, "{p}");
}

/// A scene of one rigid body `body` (TOML lines) and `rest` after it.
fn with_body(body: &str, rest: &str) -> String {
    format!(
        "version = 1\ndim = 3\n[[bodies]]\nname = \"b\"\nposition = [0, 0, -0.5]\n{body}\n{rest}\n[integrator]\ndt = 0.01\nt_end = 0.1\n"
    )
}

#[test]
fn impossible_bodies_and_misplaced_joints_are_refused_where_they_are_written() {
    let cases: Vec<(String, SceneErrorKind, &str, &str)> = vec![
        (
            with_body("mass = 1\ninertia = { moments = [1, 1, 3] }", ""),
            SceneErrorKind::Value,
            "bodies[0].inertia.moments",
            "exceeds",
        ),
        (
            with_body("mass = 1\ninertia = { shape = \"box\", size = [1, 1, 1], density = 2 }", ""),
            SceneErrorKind::Value,
            "bodies[0].inertia.density",
            "not both",
        ),
        (
            with_body("inertia = { moments = [1, 2, 2] }", ""),
            SceneErrorKind::Value,
            "bodies[0].mass",
            "needs a `mass`",
        ),
        (
            with_body("mass = 1\ninertia = { shape = \"cone\", radius = 1 }", ""),
            SceneErrorKind::Value,
            "bodies[0].inertia.shape",
            "not a shape",
        ),
        (
            with_body(
                "mass = 1\ninertia = { moments = [1, 2, 2] }\norientation = { quaternion = [0, 0, 0, 0] }",
                "",
            ),
            SceneErrorKind::Value,
            "bodies[0].orientation.quaternion",
            "quaternion",
        ),
        (
            with_body("mass = 1\nangular_velocity = [0, 0, 1]", ""),
            SceneErrorKind::Value,
            "bodies[0].angular_velocity",
            "inertia",
        ),
        (
            with_body(
                "mass = 1\ninertia = { moments = [1, 2, 2] }",
                "[[constraints]]\ntype = \"hinge\"\nbodies = [\"b\"]\nanchors = [[0, 0, 0.5], [0, 0, 0.1]]\naxis = [0, 1, 0]",
            ),
            SceneErrorKind::OffConstraints,
            "constraints[0]",
            "hinge",
        ),
        (
            with_body(
                "mass = 1",
                "[[constraints]]\ntype = \"hinge\"\nbodies = [\"b\"]\nanchor = [0, 0, 0]\naxis = [0, 1, 0]",
            ),
            SceneErrorKind::Value,
            "constraints[0]",
            "point mass",
        ),
        (
            with_body(
                "mass = 1\ninertia = { moments = [1, 2, 2] }",
                "[[constraints]]\ntype = \"ball\"\nbodies = [\"b\"]\nanchor = [0, 0, 0]\nanchors = [[0, 0, 0.5], [0, 0, 0]]",
            ),
            SceneErrorKind::Value,
            "constraints[0]",
            "exactly one",
        ),
        (
            with_body(
                "mass = 1\ninertia = { moments = [1, 2, 2] }",
                "[[constraints]]\ntype = \"ball\"\nbodies = [\"b\"]\nanchor = [0, 0, 0]\n[[outputs]]\nquantity = \"joint-force\"\ncomponent = 2",
            ),
            SceneErrorKind::Value,
            "outputs[0]",
            "names its joint",
        ),
        (
            with_body(
                "mass = 1",
                "[[constraints]]\ntype = \"rod\"\nname = \"r\"\nbodies = [\"b\"]\npoint = [0, 0, 0]\n[[outputs]]\nquantity = \"joint-force\"\nconstraint = \"r\"",
            ),
            SceneErrorKind::Reference,
            "outputs[0].constraint",
            "constraint-force",
        ),
        (
            with_body(
                "mass = 1",
                "[[constraints]]\ntype = \"ball\"\nname = \"j\"\nbodies = [\"b\"]\nanchor = [0, 0, 0]\n[[outputs]]\nquantity = \"joint-torque\"\nconstraint = \"j\"",
            ),
            SceneErrorKind::Value,
            "outputs[0].constraint",
            "point mass",
        ),
        (
            "version = 1\ndim = 3\n[[bodies]]\nname = \"a#d1\"\nmass = 1\nposition = [0, 0, 0]\n[integrator]\ndt = 0.01\nt_end = 0.1\n".to_owned(),
            SceneErrorKind::Reference,
            "bodies[0].name",
            "'#'",
        ),
        (
            with_body(
                "mass = 1\ninertia = { moments = [1, 2, 2] }",
                "[[outputs]]\nquantity = \"orientation\"\nbody = \"b\"\ncomponent = 4",
            ),
            SceneErrorKind::Dimension,
            "outputs[0].component",
            "0 … 3",
        ),
    ];
    for (text, kind, at, says) in cases {
        let e = match Scene::from_toml(&text, "bad.toml").and_then(|s| s.compile().map(|_| ())) {
            Err(e) => e,
            Ok(()) => panic!("accepted:\n{text}"),
        };
        let shown = e.to_string();
        assert_eq!(e.kind, kind, "{shown}");
        assert!(
            shown.contains(at) && shown.contains(says),
            "{shown}\nwant '{at}' and '{says}'"
        );
    }
}

#[test]
fn the_rigid_body_scenes_run_with_their_joints_at_round_off() {
    // The scenes of docs/rigid-bodies.md for 0.2 s: every row at the projection's level, and
    // where a motor works or friction takes, the energy account closing to the scheme's
    // second-order error (well under 1e-3 of the work at h = 1e-3 over 0.2 s).
    let scenes = [
        (
            "spinning_top",
            include_str!("../../scenes/spinning_top.toml"),
        ),
        (
            "double_pendulum_links",
            include_str!("../../scenes/double_pendulum_links.toml"),
        ),
        ("four_bar", include_str!("../../scenes/four_bar.toml")),
        (
            "four_bar_planar",
            include_str!("../../scenes/four_bar_planar.toml"),
        ),
        (
            "slider_crank",
            include_str!("../../scenes/slider_crank.toml"),
        ),
        (
            "slider_crank_planar",
            include_str!("../../scenes/slider_crank_planar.toml"),
        ),
        ("bricard", include_str!("../../scenes/bricard.toml")),
    ];
    for (name, text) in scenes {
        let text: String = text
            .lines()
            .map(|l| {
                if l.starts_with("t_end") {
                    "t_end = 0.2"
                } else {
                    l
                }
            })
            .collect::<Vec<_>>()
            .join("\n");
        let mut c = Scene::from_toml(&text, name)
            .unwrap()
            .compile()
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        let s = run(c.simulation.as_mut(), &c.plan, &mut |_| {});
        assert!(s.error.is_none(), "{name}: {:?}", s.error);
        assert_eq!(s.steps, 200, "{name}");
        assert!(
            s.max_abs_g.unwrap() <= 64.0 * f64::EPSILON,
            "{name}: rows {:?}",
            s.max_abs_g
        );
        if let Some(supplied) = s.supplied {
            let balance = s.max_energy_balance_error.unwrap();
            assert!(
                supplied > 0.0 && balance < 1e-3 * supplied,
                "{name}: {balance} of {supplied}"
            );
        }
    }
}

/// A chain of `n` bars (0.1 m, 1 kg) on hinges about y, the first to the world, straight out
/// along x.
fn bar_chain(n: usize, steps: usize) -> String {
    let mut s = String::from("version = 1\ndim = 3\n");
    for i in 0..n {
        s += &format!(
            "[[bodies]]\nname = \"b{i}\"\nmass = 1.0\ninertia = {{ shape = \"box\", size = [0.1, 0.02, 0.02] }}\nposition = [{}, 0, 0]\n",
            0.1 * i as f64 + 0.05
        );
    }
    for i in 0..n {
        let ends = if i == 0 {
            "[\"b0\"]".to_owned()
        } else {
            format!("[\"b{i}\", \"b{}\"]", i - 1)
        };
        s += &format!(
            "[[constraints]]\ntype = \"hinge\"\nbodies = {ends}\nanchor = [{}, 0, 0]\naxis = [0, 1, 0]\n",
            0.1 * i as f64
        );
    }
    s + &format!(
        "[[effects]]\ntype = \"gravity\"\ng = [0, 0, -9.81]\n[integrator]\ndt = 1e-3\nt_end = {}\n",
        steps as f64 * 1e-3
    )
}

#[test]
fn a_chain_of_bodies_projects_in_newton_iterations_flat_in_its_length() {
    // The multiplier systems of a chain couple each body's rows with its neighbours' only: the
    // projection factors them sparse (not dense: a pattern counted with repeats once took the
    // dense path at 100 bodies), and Newton's iterations a step do not grow with the length.
    // Time per body: docs/rigid-bodies.md (`lieflow run` on these chains).
    let mut per_step = Vec::new();
    for n in [10, 100, 1000, 10_000] {
        // Ten steps (four for 10⁴ bodies: its compile, 0.65 ms a body, dominates the test).
        let steps = if n > 1000 { 4 } else { 10 };
        let mut c = parse(&bar_chain(n, steps))
            .compile()
            .unwrap_or_else(|e| panic!("{e}"));
        if n >= 100 {
            assert_eq!(
                c.assembly.solver.as_deref(),
                Some("Sparse"),
                "{n} bodies: {:?}",
                c.assembly.solver
            );
        }
        let s = run(c.simulation.as_mut(), &c.plan, &mut |_| {});
        assert!(s.error.is_none(), "{n}: {:?}", s.error);
        // Rows at the projection's tolerance, 16 ε ℓ L with ℓ and L the chain's extent.
        assert!(s.max_abs_g.unwrap() < 16.0 * f64::EPSILON * (0.1 * n as f64).powi(2).max(1.0));
        per_step.push(s.newton_iterations as f64 / s.steps as f64);
    }
    eprintln!("Newton iterations a step for 10, 100, 1000, 10⁴ bodies: {per_step:?}");
    assert!(
        per_step[1..].iter().all(|&k| k <= per_step[0] + 1.0),
        "{per_step:?}"
    );
}

#[test]
fn a_heavy_top_converges_at_the_order_of_each_composition() {
    // The top of `top()` against its steady precession, over 0.25 s: the splitting composed to
    // orders 4 and 6 (every row still at round-off), and extrapolated to order 4.
    let t_end = 0.5;
    for (scheme, order, hs) in [
        ("order = 4", 4.0, [8e-3, 4e-3, 2e-3, 1e-3]),
        ("scheme = \"yoshida6\"", 6.0, [8e-3, 4e-3, 2e-3, 1e-3]),
        (
            "scheme = \"extrapolation\"\norder = 4",
            4.0,
            [4e-3, 2e-3, 1e-3, 5e-4],
        ),
    ] {
        let mut errs = Vec::new();
        for &h in &hs {
            let (text, s, l) = top(h, t_end);
            let text = text.replace("[integrator]\n", &format!("[integrator]\n{scheme}\n"));
            let (x, _, g) = run_scene(&text);
            assert!(g <= 4.0 * ROWS, "{scheme}, h = {h}: rows {g:e}");
            let st = s * t_end;
            let want = [
                0.5f64.sin() * st.cos(),
                0.5f64.sin() * st.sin(),
                0.5f64.cos(),
            ]
            .map(|a| l * a);
            errs.push((0..3).map(|k| (x[k] - want[k]).abs()).fold(0.0, f64::max));
        }
        let p = fitted_order(&hs, &errs, 1e-13);
        eprintln!("heavy top, '{scheme}': errors {errs:?}, order {p:.3}");
        if scheme.contains("extrapolation") {
            // Extrapolation removes the h² term of the symmetric step's even expansion and
            // promises O(h⁴); on this relative equilibrium the h⁴ term is small and the h⁶ one
            // shows over these steps (5.6 fitted): at least the promised order.
            assert!(
                p > order - 0.3,
                "'{scheme}': order {p}, want at least {order}"
            );
        } else {
            assert!(
                (p - order).abs() < 0.35,
                "'{scheme}': order {p}, want {order}"
            );
        }
    }
}

#[test]
fn switching_constraints_off_keeps_a_body_rigid() {
    // `[flags] constraints = false` removes the joints, not a body's own rows: the free box
    // still turns as a rigid body (its six rows at round-off), the hinge is gone.
    let text = hinged_bar(0.01, 0.5, 1.0)
        .replace("[integrator]", "[flags]\nconstraints = false\n[integrator]");
    let c = parse(&text).compile().unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(
        c.assembly.constraint_rows, 6,
        "{:?}",
        c.assembly.constraints
    );
    let (x, _, rows) = run_scene(&text);
    assert!(rows <= ROWS, "{rows:e}");
    // Free fall of the centre from rest: z drops by g t²/2.
    let z0 = -0.5 * 1.0f64.cos();
    assert!((x[2] - (z0 - 0.5 * 9.81 * 0.25)).abs() < 1e-12, "{}", x[2]);
}
