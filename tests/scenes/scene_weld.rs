//! Welds (`type = "weld"`): bodies fixed to one another are merged into one rigid body when the
//! scene is compiled. A pendulum welded from a cube, a turned bar and a point mass, hung from a
//! hinge written in the bar's own frame, swings as the compound pendulum its parts make
//! (parallel axes, closed form) and step for step as the one body written by hand; what cannot
//! be welded is refused where it is written.

use crate::common::fitted_order;
use lieflow::scene::{Scene, SceneErrorKind, run};

const G: f64 = 9.81;
/// The hinge's point (world), its axis along x.
const PIVOT_Z: f64 = 0.1;

/// The parts: `(mass, centre, J_xx about its centre in the world)`; the cube (2 kg, side 0.2)
/// at the origin, the bar (1 kg, 0.1 × 0.6 × 0.1, turned 90° about x so it hangs along z)
/// below it, a point mass (0.5 kg) off to the side along the hinge's axis.
fn parts() -> [(f64, [f64; 3], f64); 3] {
    [
        (2.0, [0.0, 0.0, 0.0], 2.0 * (0.04 + 0.04) / 12.0),
        (1.0, [0.0, 0.0, -0.5], (0.36 + 0.01) / 12.0),
        (0.5, [0.1, 0.0, -0.8], 0.0),
    ]
}

/// The parts as a scene: welded, hung from the hinge by the bar's frame, swinging at `w` rad/s
/// about x (each part's velocity `ω × (c − pivot)`).
fn welded(dt: f64, t_end: f64, w: f64, extra: &str) -> String {
    let v = |c: [f64; 3]| format!("[0, {}, {}]", -w * (c[2] - PIVOT_Z), w * c[1]);
    let [(_, c0, _), (_, c1, _), (_, c2, _)] = parts();
    format!(
        r#"
version = 1
dim = 3
[[bodies]]
name = "tip"
mass = 0.5
position = [0.1, 0, -0.8]
velocity = {v2}
[[bodies]]
name = "head"
mass = 2.0
inertia = {{ shape = "box", size = [0.2, 0.2, 0.2] }}
position = [0, 0, 0]
velocity = {v0}
angular_velocity = [{w}, 0, 0]
[[bodies]]
name = "bar"
mass = 1.0
inertia = {{ shape = "box", size = [0.1, 0.6, 0.1] }}
orientation = {{ axis = [1, 0, 0], angle_deg = 90 }}
position = [0, 0, -0.5]
velocity = {v1}
angular_velocity = [{w}, 0, 0]
[[constraints]]
type = "weld"
bodies = ["head", "bar"]
[[constraints]]
type = "weld"
name = "glue"
bodies = ["tip", "bar"]
[[constraints]]
type = "hinge"
bodies = ["bar"]
anchors = [[0, 0.6, 0], [0, 0, {PIVOT_Z}]]
axes = [[1, 0, 0], [1, 0, 0]]
[[effects]]
type = "gravity"
g = [0, 0, -{G}]
[[outputs]]
quantity = "position"
body = "head"
component = 1
[[outputs]]
quantity = "position"
body = "head"
component = 2
[integrator]
dt = {dt}
t_end = {t_end}
{extra}
"#,
        v0 = v(c0),
        v1 = v(c1),
        v2 = v(c2),
    )
}

/// The same pendulum as one body written by hand: mass, centre and inertia tensor summed from
/// the parts by parallel axes here, independently of the library.
fn by_hand(dt: f64, t_end: f64, w: f64) -> String {
    let parts = parts();
    let m: f64 = parts.iter().map(|p| p.0).sum();
    let c: [f64; 3] = core::array::from_fn(|k| parts.iter().map(|p| p.0 * p.1[k]).sum::<f64>() / m);
    // Own tensors in the world: the cube's is isotropic, the bar's diagonal (turned 90° about
    // x: its long side along z), the point's zero.
    let own = [
        [2.0 * 0.08 / 12.0; 3],
        [(0.36 + 0.01) / 12.0, 0.02 / 12.0, (0.01 + 0.36) / 12.0],
        [0.0; 3],
    ];
    let mut t = [[0.0; 3]; 3];
    for (p, j) in parts.iter().zip(own) {
        let r: [f64; 3] = core::array::from_fn(|k| p.1[k] - c[k]);
        let rr = r.iter().map(|x| x * x).sum::<f64>();
        for a in 0..3 {
            for b in 0..3 {
                let own = if a == b { j[a] } else { 0.0 };
                let delta = if a == b { rr } else { 0.0 };
                t[a][b] += own + p.0 * (delta - r[a] * r[b]);
            }
        }
    }
    let row = |r: [f64; 3]| format!("[{:e}, {:e}, {:e}]", r[0], r[1], r[2]);
    format!(
        r#"
version = 1
dim = 3
[[bodies]]
name = "head"
mass = {m}
inertia = {{ tensor = [{t0}, {t1}, {t2}] }}
position = {c}
velocity = [0, {vy}, {vz}]
angular_velocity = [{w}, 0, 0]
[[constraints]]
type = "hinge"
bodies = ["head"]
anchor = [0, 0, {PIVOT_Z}]
axis = [1, 0, 0]
[[effects]]
type = "gravity"
g = [0, 0, -{G}]
[[outputs]]
quantity = "position"
body = "head"
component = 1
[[outputs]]
quantity = "position"
body = "head"
component = 2
[integrator]
dt = {dt}
t_end = {t_end}
"#,
        t0 = row(t[0]),
        t1 = row(t[1]),
        t2 = row(t[2]),
        c = row(c),
        vy = -w * (c[2] - PIVOT_Z),
        vz = w * c[1],
    )
}

fn outputs(text: &str) -> (Vec<f64>, f64) {
    let mut c = Scene::from_toml(text, "weld.toml")
        .unwrap()
        .compile()
        .unwrap_or_else(|e| panic!("{e}"));
    let mut out = Vec::new();
    let s = run(c.simulation.as_mut(), &c.plan, &mut |s| {
        out = s.outputs.to_vec()
    });
    assert!(s.error.is_none(), "{:?}", s.error);
    (out, s.max_abs_g.unwrap())
}

/// Small swings of the welded pendulum: `θ = (w/ω₀) sin ω₀t`, `ω₀² = M g d / I_p`, `d` the
/// centre's depth below the hinge and `I_p = Σ (J_xx + m (y² + (z − z_p)²))` the moment about the
/// hinge's axis (parallel axes). The centre's `y` is `d sin θ`; the error falls at order 2 to the
/// small-angle model's `θ³` floor (`θ ≤ 3e-4`: below 1e-11 m).
#[test]
fn a_welded_pendulum_swings_as_the_compound_pendulum_of_its_parts() {
    let parts = parts();
    let m: f64 = parts.iter().map(|p| p.0).sum();
    let zc = parts.iter().map(|p| p.0 * p.1[2]).sum::<f64>() / m;
    let d = PIVOT_Z - zc;
    let ip: f64 = parts
        .iter()
        .map(|p| p.2 + p.0 * (p.1[1].powi(2) + (p.1[2] - PIVOT_Z).powi(2)))
        .sum();
    let w0 = (m * G * d / ip).sqrt();
    let (w, t_end) = (1e-3, 1.0);
    let want_y = d * (w / w0 * (w0 * t_end).sin()).sin();
    let hs = [0.02, 0.01, 0.005, 0.0025];
    let mut errs = Vec::new();
    for &h in &hs {
        let (out, rows) = outputs(&welded(h, t_end, w, ""));
        // The projection's level for unit-scale rows, as for every rigid scene.
        assert!(rows <= 64.0 * f64::EPSILON, "rows {rows:e}");
        errs.push((out[0] - want_y).abs());
    }
    let p = fitted_order(&hs, &errs, 1e-12);
    eprintln!("welded pendulum: ω₀ = {w0:.6}, errors {errs:?}, order {p:.3}");
    assert!((p - 2.0).abs() < 0.2, "order {p}");
}

/// Swinging wide (3 rad/s through the bottom, over a turn's quarter), the welded scene and the
/// one body written by hand go through the same states: the merge is the parallel-axis sum and
/// the hinge written in the bar's frame is the hinge at the pivot. Both run the same projected
/// steps on differently ordered principal axes, so they agree to the projection's tolerance
/// carried over the run, not bit for bit.
#[test]
fn a_welded_body_moves_as_the_same_body_written_by_hand() {
    let (a, _) = outputs(&welded(0.002, 2.0, 3.0, ""));
    let (b, _) = outputs(&by_hand(0.002, 2.0, 3.0));
    eprintln!("welded {a:?}, by hand {b:?}");
    for k in 0..2 {
        assert!((a[k] - b[k]).abs() < 1e-9, "{a:?} vs {b:?}");
    }
    // Switched off, the weld named "glue" leaves the tip loose: it falls away, and the swing
    // differs.
    let mut c = Scene::from_toml(&welded(0.002, 0.5, 3.0, ""), "weld.toml").unwrap();
    c.file.off.push("glue".to_owned());
    let c = c.compile().unwrap_or_else(|e| panic!("{e}"));
    // Welded: one body of four slots; unglued, the tip is a fifth slot.
    assert_eq!(
        c.simulation.state().len(),
        2 * 3 * 5,
        "the tip is its own body again"
    );
}

#[test]
fn what_cannot_be_welded_is_refused_where_it_is_written() {
    let base = welded(0.01, 0.1, 0.0, "");
    let cases = [
        (
            base.replace("bodies = [\"head\", \"bar\"]", "bodies = [\"head\"]"),
            SceneErrorKind::Value,
            "constraints[0].bodies",
            "two bodies",
        ),
        (
            base.replace(
                "bodies = [\"head\", \"bar\"]",
                "bodies = [\"head\", \"nobody\"]",
            ),
            SceneErrorKind::Reference,
            "constraints[0].bodies[1]",
            "not a body declared",
        ),
        (
            base.replace(
                "bodies = [\"head\", \"bar\"]",
                "bodies = [\"head\", \"head\"]",
            ),
            SceneErrorKind::Value,
            "constraints[0].bodies",
            "two different bodies",
        ),
        (
            // The bar spins about z while the cube does not: no one body moves so.
            base.replace(
                "velocity = [0, 0, 0]\nangular_velocity = [0, 0, 0]\n[[constraints]]",
                "velocity = [0, 0, 0]\nangular_velocity = [0, 0, 1]\n[[constraints]]",
            ),
            SceneErrorKind::Value,
            "bodies[2].velocity",
            "welding tip, head, bar",
        ),
        (
            format!(
                "{base}\n[[outputs]]\nquantity = \"position\"\nbody = \"bar\"\ncomponent = 0\n"
            ),
            SceneErrorKind::Reference,
            "outputs[2].body",
            "welded into 'head'",
        ),
        (
            base.replace(
                "[[constraints]]\ntype = \"hinge\"\nbodies = [\"bar\"]",
                "[[constraints]]\ntype = \"hinge\"\nbodies = [\"bar\", \"head\"]",
            ),
            SceneErrorKind::Value,
            "constraints[2].bodies",
            "welded bodies are one",
        ),
    ];
    for (text, kind, at, says) in cases {
        assert_ne!(text, base, "the case did not change the scene ({says})");
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
