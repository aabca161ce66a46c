//! A joint's coordinate as an output and an event's quantity (`joint-position`,
//! `joint-velocity`): a disc spinning on a hinge reads its angle unwrapped across turns — `ω t`
//! to the scheme's order after three and a half turns, where a wrapped angle would be off by
//! whole turns — its rate `ω` to round-off, an event two turns in fires once at `4π/ω`, and a
//! checkpoint carries the unwrapping; a slider reads its displacement and rate.

use crate::common::fitted_order;
use lieflow::scene::{Scene, SceneErrorKind, run};
use std::f64::consts::PI;

const OMEGA: f64 = 10.0;

/// A disc (1 kg, r = 0.2, h = 0.05) on a hinge to the world along z, spinning at `ω`, no
/// gravity: it turns uniformly, `θ = ω t`.
fn spinning(dt: f64, t_end: f64, extra: &str) -> String {
    format!(
        r#"
version = 1
dim = 3
[[bodies]]
name = "disc"
mass = 1.0
inertia = {{ shape = "cylinder", radius = 0.2, height = 0.05 }}
position = [0, 0, 0]
angular_velocity = [0, 0, {OMEGA}]
[[constraints]]
type = "hinge"
name = "axle"
bodies = ["disc"]
anchor = [0, 0, 0]
axis = [0, 0, 1]
[[outputs]]
quantity = "joint-position"
constraint = "axle"
[[outputs]]
quantity = "joint-velocity"
constraint = "axle"
[integrator]
dt = {dt}
t_end = {t_end}
{extra}
"#
    )
}

fn compile(text: &str) -> lieflow::scene::Compiled {
    Scene::from_toml(text, "joint.toml")
        .unwrap()
        .compile()
        .unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn a_spinning_hinge_reads_its_angle_unwrapped_across_turns() {
    let t_end = 2.2; // 3.5 turns
    let hs = [0.01, 0.005, 0.0025, 0.00125];
    let mut errs = Vec::new();
    for &h in &hs {
        let mut c = compile(&spinning(h, t_end, ""));
        assert_eq!(c.assembly.outputs, ["angle_axle", "angle_rate_axle"]);
        let (mut out, mut rate_err) = (Vec::new(), 0.0f64);
        let s = run(c.simulation.as_mut(), &c.plan, &mut |s| {
            out = s.outputs.to_vec();
            rate_err = rate_err.max((out[1] - OMEGA).abs());
        });
        assert!(s.error.is_none(), "{:?}", s.error);
        // The rate: ∇θ · q̇ of a uniform spin, exact but for the rounding of the directors.
        assert!(rate_err < 1e-12 * OMEGA, "rate off by {rate_err:e}");
        errs.push((out[0] - OMEGA * t_end).abs());
    }
    let p = fitted_order(&hs, &errs, 1e-12);
    eprintln!("unwrapped angle after 3.5 turns: errors {errs:?}, order {p:.3}");
    assert!((p - 2.0).abs() < 0.2, "order {p}");
    // Half a turn is far more than any of these errors: the turns are all counted.
    assert!(errs[0] < 0.1 * PI, "{errs:?}");
}

#[test]
fn an_event_two_turns_in_fires_once_and_a_checkpoint_keeps_the_turns() {
    let events = r#"
[[events]]
name = "two turns"
quantity = "joint-position"
constraint = "axle"
value = 12.566370614359172
direction = "rising"
action = "record"
"#;
    let h = 0.001;
    let mut c = compile(&spinning(h, 2.2, events));
    let s = run(c.simulation.as_mut(), &c.plan, &mut |_| {});
    assert!(s.error.is_none(), "{:?}", s.error);
    let log = c.simulation.events();
    assert_eq!(log.len(), 1, "{log:?}");
    // Located on the step's dense output: within the phase error of the step, ~(hω)² ω t.
    let want = 4.0 * PI / OMEGA;
    assert!(
        (log[0].t - want).abs() < 1e-4 * want,
        "{} vs {want}",
        log[0].t
    );

    // A checkpoint a turn and a half in: restored after the run went on, the continuation
    // reads the same unwrapped angles, bit for bit.
    let mut c = compile(&spinning(h, 2.2, ""));
    let sim = c.simulation.as_mut();
    sim.advance_to(0.95).unwrap();
    let saved = sim.save();
    sim.advance_to(2.0).unwrap();
    let mut first = Vec::new();
    sim.outputs(&mut first);
    sim.restore(&saved).unwrap();
    sim.advance_to(2.0).unwrap();
    let mut again = Vec::new();
    sim.outputs(&mut again);
    assert!(first[0] > 3.0 * PI, "{first:?}");
    assert_eq!(first, again);
}

/// Two boxes on a slider along x, the second moving away at 0.3 m/s: the displacement of the
/// first from the second is `−0.3 t`, its rate −0.3, to round-off.
#[test]
fn a_slider_reads_its_displacement_and_rate() {
    let text = r#"
version = 1
dim = 3
[[bodies]]
name = "a"
mass = 1.0
inertia = { shape = "box", size = [0.2, 0.1, 0.1] }
position = [0, 0, 0]
[[bodies]]
name = "b"
mass = 2.0
inertia = { shape = "box", size = [0.2, 0.1, 0.1] }
position = [0.5, 0, 0]
velocity = [0.3, 0, 0]
[[constraints]]
type = "slider"
name = "rail"
bodies = ["a", "b"]
axis = [1, 0, 0]
[[outputs]]
quantity = "joint-position"
constraint = "rail"
[[outputs]]
quantity = "joint-velocity"
constraint = "rail"
[integrator]
dt = 0.01
t_end = 1.0
"#;
    let mut c = compile(text);
    assert_eq!(
        c.assembly.outputs,
        ["displacement_rail", "displacement_rate_rail"]
    );
    let mut out = Vec::new();
    let s = run(c.simulation.as_mut(), &c.plan, &mut |s| {
        out = s.outputs.to_vec()
    });
    assert!(s.error.is_none(), "{:?}", s.error);
    // Nothing acts along the rail: b moves away from a at 0.3 m/s.
    assert!((out[0] + 0.3).abs() < 1e-13, "{out:?}");
    assert!((out[1] + 0.3).abs() < 1e-13, "{out:?}");
}

#[test]
fn a_joint_coordinate_names_a_named_hinge_or_slider() {
    let base = spinning(0.01, 0.1, "");
    for (text, kind, says) in [
        (
            base.replace(
                "constraint = \"axle\"\n[[outputs]]",
                "constraint = \"wheel\"\n[[outputs]]",
            ),
            SceneErrorKind::Reference,
            "'wheel' is not a named hinge or slider (named: axle)",
        ),
        (
            base.replace("constraint = \"axle\"\n[[outputs]]", "[[outputs]]"),
            SceneErrorKind::Value,
            "names its joint",
        ),
    ] {
        assert_ne!(text, base);
        let e = match Scene::from_toml(&text, "bad.toml").and_then(|s| s.compile().map(|_| ())) {
            Err(e) => e,
            Ok(()) => panic!("accepted:\n{text}"),
        };
        assert_eq!(e.kind, kind, "{e}");
        assert!(e.to_string().contains("outputs[0].constraint"), "{e}");
        assert!(e.to_string().contains(says), "{e}");
    }
}

#[test]
fn an_adaptive_run_unwraps_the_angle_at_its_accepted_steps() {
    // One report interval over the whole run (3.5 turns): the angle is unwrapped at each of
    // the controller's accepted steps, not at the two ends of the interval, where it would be
    // off by whole turns.
    let t_end = 2.2;
    let mut c = compile(&spinning(t_end, t_end, "tol = 1e-8"));
    let mut out = Vec::new();
    let s = run(c.simulation.as_mut(), &c.plan, &mut |s| {
        out = s.outputs.to_vec()
    });
    assert!(s.error.is_none(), "{:?}", s.error);
    let a = s.adaptive.as_ref().expect("the controller's report");
    eprintln!(
        "adaptive spin: angle {} (want {}), {} accepted steps, largest {:?}",
        out[0],
        OMEGA * t_end,
        a.accepted,
        a.largest_step
    );
    assert!((out[0] - OMEGA * t_end).abs() < 1e-6, "{out:?}");
}
