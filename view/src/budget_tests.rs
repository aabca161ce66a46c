//! The page's size budget and the frames' times, on a 1000-body chain in space.

use crate::page::page;
use crate::{FrameBudget, PageInfo, Recorder};
use lieflow::scene::{Sample, Scene};

const CHAIN: &str = r#"
version = 1
name = "1000-body chain"
dim = 3

[[chains]]
name = "chain"
links = 1000
anchor = [0.0, 0.0, 0.0]
direction = [0.5, 0.0, -0.8660254037844386]
length = 0.001
mass = 0.001

[[effects]]
type = "gravity"
g = [0.0, 0.0, -9.81]

[integrator]
dt = 1e-3
t_end = 10.0
"#;

fn sample(step: usize, t: f64, x: &[f64]) -> Sample<'_> {
    Sample {
        step,
        t,
        x,
        energy: Some(-1.0),
        g: None,
        phi: None,
        outputs: &[],
        dissipated: None,
        supplied: None,
        multipliers: &[],
    }
}

#[test]
fn a_1000_body_chain_over_ten_thousand_steps_stays_under_20_mb() {
    let compiled = Scene::from_toml(CHAIN, "chain.toml")
        .unwrap()
        .compile()
        .unwrap();
    let x0 = compiled.simulation.state().to_vec();
    let sketch = compiled.sketch.as_ref().unwrap();
    assert_eq!(sketch.bodies.len(), 1000);
    assert_eq!(sketch.links.len(), 1000, "a rod a link");
    let mut r = Recorder::new(
        Some(sketch),
        x0.len(),
        Vec::new(),
        (0.0, 10.0),
        &[],
        FrameBudget::default(),
    )
    .unwrap();
    let steps = 10_000;
    for k in 0..=steps {
        r.observe(&sample(k, k as f64 * 1e-3, &x0));
    }
    r.finish();
    assert_eq!(r.frames(), 1000);
    // Frame k is the first step at or after k · 10/999: within one step of it.
    for (k, &t) in r.times.iter().enumerate() {
        let due = 10.0 * k as f64 / 999.0;
        assert!(
            t >= due - 1e-9 && t < due + 1e-3 + 1e-9,
            "frame {k} at {t}, due {due}"
        );
    }
    let html = page(&r, &PageInfo::default());
    assert!(html.len() < 20_000_000, "{} bytes", html.len());
    // Positions: 1000 frames × 1000 slots × 3 × 4 bytes, base64 (4/3).
    assert!(html.len() > 16_000_000, "{} bytes", html.len());
    // Frame 0 holds the initial positions, as f32.
    let q0: Vec<f32> = x0[..3000].iter().map(|&v| v as f32).collect();
    assert_eq!(&r.positions[..3000], &q0[..]);
}

#[test]
fn a_short_run_keeps_every_step_and_an_early_stop_ends_the_frames() {
    let compiled = Scene::from_toml(CHAIN, "chain.toml")
        .unwrap()
        .compile()
        .unwrap();
    let x0 = compiled.simulation.state().to_vec();
    let budget = FrameBudget::default();
    let make = || {
        Recorder::new(
            compiled.sketch.as_ref(),
            x0.len(),
            Vec::new(),
            (0.0, 10.0),
            &["chain.999".to_owned()],
            budget,
        )
        .unwrap()
    };
    let mut r = make();
    for k in 0..=100 {
        r.observe(&sample(k, k as f64 * 0.1, &x0));
    }
    r.finish();
    assert_eq!(
        r.frames(),
        101,
        "every step of a run shorter than the budget"
    );
    assert_eq!(r.traces, vec![999]);
    // Stopped at t = 4.25 (step 17 of 0.25, between frames 424 and 425 of 1000): the last
    // frame is that state.
    let mut r = make();
    for k in 0..=17 {
        r.observe(&sample(k, k as f64 * 0.25, &x0));
    }
    r.finish();
    assert_eq!(*r.times.last().unwrap(), 4.25);
    assert_eq!(r.frames(), 18);
}

#[test]
fn refusals_name_the_cause() {
    let compiled = Scene::from_toml(CHAIN, "chain.toml")
        .unwrap()
        .compile()
        .unwrap();
    let n = compiled.simulation.state().len();
    let new = |sketch, traces: &[String], budget| {
        Recorder::new(sketch, n, Vec::new(), (0.0, 1.0), traces, budget).map(|_| ())
    };
    assert_eq!(
        new(None, &[], FrameBudget::default()),
        Err(crate::RecorderError::NoBodies)
    );
    let e = new(
        compiled.sketch.as_ref(),
        &["nope".to_owned()],
        FrameBudget::default(),
    )
    .unwrap_err();
    assert!(e.to_string().contains("'nope'"), "{e}");
    let tight = FrameBudget {
        max_frames: 1000,
        max_bytes: 12_000,
    };
    let e = new(compiled.sketch.as_ref(), &[], tight).unwrap_err();
    assert!(e.to_string().contains("fewer than two frames"), "{e}");
}
