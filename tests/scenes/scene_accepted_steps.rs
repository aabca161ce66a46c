//! A scene with a tolerance run at the controller's own steps (`RunPlan::own_steps`, the
//! command's `--accepted-steps`): one observed state per accepted step, no step bent to land
//! on a report time, the events located where a fixed step finds them, the run ending on
//! `t_end` exactly; a fixed-step scene takes its steps of `dt` as before.

use crate::scene_text::{damped_pendulum as pendulum, parse};
use lieflow::scene::{RunSummary, Scene, run};

/// Runs `scene` with the plan's `own_steps` set to `own`: the summary and every observed
/// `(step, t, max |g|)`.
fn run_observed(scene: &Scene, own: bool) -> (RunSummary, Vec<(usize, f64, Option<f64>)>) {
    let mut c = scene.compile().unwrap_or_else(|e| panic!("{e}"));
    c.plan.own_steps = own;
    let mut seen = Vec::new();
    let s = run(c.simulation.as_mut(), &c.plan, &mut |s| {
        seen.push((s.step, s.t, s.g));
    });
    (s, seen)
}

#[test]
fn a_run_at_the_controller_s_steps_observes_each_accepted_step_and_finds_the_events() {
    // scenes/forced_pendulum.toml (a rod, damping, a motor, nine passes through the bottom
    // and a stop when the bob rises) at tol 1e-9 with a report interval of 0.05 s that the
    // run does not use, and a longest step of 0.045 s (by default the longest step is the
    // report interval, on whose multiples steps of that length would end; the events, looked
    // for at the ends of accepted steps, need steps shorter than the bob's excursion above
    // the stop's plane, 0.15 s from t = 10.35). The events are located by partial steps
    // within the accepted step they fall in, at the times a fixed order-8 run at dt = 2e-3
    // finds (error below 1e-12), to 1e-8 (as the report-interval run, `scene_tolerance`).
    let text = include_str!("../../scenes/forced_pendulum.toml");
    let scene = parse(&text.replace("dt = 0.001", "dt = 0.05\ntol = 1e-9\nh_max = 0.045"));
    let (own, seen) = run_observed(&scene, true);
    let (fixed, _) = run_observed(
        &parse(&text.replace("dt = 0.001", "dt = 0.002\norder = 8")),
        false,
    );
    assert!(
        own.error.is_none() && fixed.error.is_none(),
        "{:?}",
        own.error
    );
    let a = own.adaptive.as_ref().expect("the controller's report");
    // One observation per accepted step (and the initial state), numbered from 1, at
    // increasing times; the summary counts them. (The controller's count also holds the
    // steps of the event location's partial steps, each itself adaptive.)
    assert_eq!(seen.len(), own.steps + 1);
    assert!(own.steps as u64 <= a.accepted);
    assert_eq!(own.steps_planned, own.steps);
    assert_eq!(own.last_step, None);
    for (k, w) in seen.windows(2).enumerate() {
        assert_eq!(w[1].0, k + 1);
        assert!(
            w[1].1 > w[0].1,
            "step {}: t {} after {}",
            k + 1,
            w[1].1,
            w[0].1
        );
        // Every accepted step ends on the constraint at round-off.
        assert!(w[1].2.unwrap() <= 64.0 * f64::EPSILON, "{:?}", w[1]);
    }
    // The steps are the controller's: of many lengths, none of them the report interval's
    // landing (a run to every 0.05 s would have a step end on each multiple of 0.05).
    let lengths: Vec<f64> = seen.windows(2).map(|w| w[1].1 - w[0].1).collect();
    let (short, long) = lengths
        .iter()
        .fold((f64::INFINITY, 0.0_f64), |(a, b), &h| (a.min(h), b.max(h)));
    assert!(long > 2.0 * short, "steps {short} … {long}");
    let on_reports = seen[1..]
        .iter()
        .filter(|(_, t, _)| ((t / 0.05).round() * 0.05 - t).abs() < 1e-12)
        .count();
    assert!(
        on_reports < seen.len() / 4,
        "{on_reports} of {} rows",
        seen.len()
    );
    assert_eq!(own.stopped_by.as_deref(), Some("high"));
    assert_eq!(own.events.len(), fixed.events.len());
    for (a, f) in own.events.iter().zip(&fixed.events) {
        assert_eq!(a.name, f.name);
        assert!((a.t - f.t).abs() <= 1e-8, "{}: {} vs {}", a.name, a.t, f.t);
    }
    let (a, f) = (own.supplied.unwrap(), fixed.supplied.unwrap());
    assert!((a - f).abs() <= 1e-8 * f.abs(), "{a} vs {f}");
}

#[test]
fn a_run_at_the_controller_s_steps_ends_on_t_end_within_its_tolerance() {
    // The damped pendulum at tol 1e-8 to t = 10, reporting every 1 s or not at all: both
    // runs end on t_end exactly, each within its tolerance of the other (the controller
    // keeps each local error below tol; over the run the difference is a few tol,
    // `scene_tolerance` measures it against a reference), and the one at its own steps takes
    // no more accepted steps than the one bent onto ten report times.
    let scene = parse(&pendulum(1.0, "tol = 1e-8"));
    let (own, seen) = run_observed(&scene, true);
    let (reported, _) = run_observed(&scene, false);
    assert!(own.error.is_none() && reported.error.is_none());
    assert_eq!(own.t, 10.0);
    assert_eq!(own.steps as u64, own.adaptive.as_ref().unwrap().accepted);
    assert_eq!(seen.last().unwrap().1, 10.0);
    let gap = own
        .x
        .iter()
        .zip(&reported.x)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(gap <= 1e2 * 1e-8, "{gap:e}");
    let (a, r) = (
        own.adaptive.as_ref().unwrap().accepted,
        reported.adaptive.as_ref().unwrap().accepted,
    );
    eprintln!(
        "damped pendulum, tol 1e-8: {a} accepted steps at its own steps, {r} reporting every 1 s"
    );
    assert!(a <= r, "{a} vs {r}");
}

#[test]
fn a_fixed_step_scene_asked_for_its_own_steps_takes_the_steps_of_dt() {
    let scene = parse(&pendulum(0.01, ""));
    let (own, seen) = run_observed(&scene, true);
    let (plain, _) = run_observed(&scene, false);
    assert_eq!(own.steps, 1000);
    assert_eq!(seen.len(), 1001);
    assert_eq!(own.x, plain.x);
    assert_eq!(own.steps_planned, plain.steps_planned);
}

/// Runs `text`: the summary and the event log `(name, t)`.
fn run_events(text: &str) -> (RunSummary, Vec<(String, f64)>) {
    let mut c = parse(text).compile().unwrap_or_else(|e| panic!("{e}"));
    let s = run(c.simulation.as_mut(), &c.plan, &mut |_| {});
    let log = c
        .simulation
        .events()
        .iter()
        .map(|e| (e.name.clone(), e.t))
        .collect();
    (s, log)
}

#[test]
fn events_are_located_at_the_accepted_steps_within_a_long_report_interval() {
    // The forced pendulum reports once, at t_end = 20 s: its ten crossings (nine "bottom",
    // then "high", which stops the run at 10.35 s) lie inside that one interval. They are
    // located at the controller's accepted steps, where a fixed order-12 run at 1 ms finds them
    // (to the tolerance's 1e-8 and the location's 1e-13); watched at the interval's two ends only,
    // none was seen and the run went on to 20 s.
    let text = include_str!("../../scenes/forced_pendulum.toml");
    let (fine, fine_log) = run_events(&text.replace("dt = 0.001", "dt = 0.001\norder = 12"));
    let (s, log) = run_events(&text.replace("dt = 0.001", "dt = 20.0\ntol = 1e-8"));
    assert!(s.error.is_none() && fine.error.is_none(), "{:?}", s.error);
    assert_eq!(s.stopped_by.as_deref(), Some("high"));
    assert_eq!(log.len(), fine_log.len(), "{log:?}");
    for (a, b) in log.iter().zip(&fine_log) {
        assert_eq!(a.0, b.0);
        assert!(
            (a.1 - b.1).abs() < 1e-6,
            "{} at {} against {}",
            a.0,
            a.1,
            b.1
        );
    }
    assert!((s.t - fine.t).abs() < 1e-6, "{} against {}", s.t, fine.t);
}
