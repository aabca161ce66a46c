//! Reversible variable steps (`lieflow::flow::ReversibleSteps`) on Kepler's problem: N steps
//! forward and N back return to the start to round-off where the error controller does not;
//! over 10⁴ orbits of the e = 0.9 orbit the energy does not drift, at fewer force evaluations
//! than a fixed step of the same energy error; the tolerance sets the step scale as the
//! scheme's order says; a continuation from saved memory is bit-identical; dissipative and
//! non-symmetric schemes are refused by name.

use lieflow::flow::{
    AdaptiveExtrapolation, AdaptiveOptions, Flow, FlowExt, Ledger, ReversibleSteps, StepDensity,
    Tolerances, from_fn, from_fn_with_order, step_density,
};
use lieflow::models::DampedPendulum;
use lieflow::prelude::*;
use nalgebra::SVector;
use std::f64::consts::PI;

type V = SVector<f64, 4>;

/// Kepler in the plane, unit mass and `GM = 1`, `a = 1` (period 2π, energy −1/2), at the
/// pericentre of the orbit of eccentricity `e`.
fn pericentre(e: f64) -> V {
    V::new(1.0 - e, 0.0, 0.0, ((1.0 + e) / (1.0 - e)).sqrt())
}

fn energy(x: &V) -> f64 {
    0.5 * (x[2] * x[2] + x[3] * x[3]) - 1.0 / (x[0] * x[0] + x[1] * x[1]).sqrt()
}

/// Störmer–Verlet: kick `p −= h q/|q|³` (h/2), drift `q += h p`, kick (h/2).
fn verlet() -> impl Flow<V> {
    let kick = from_fn(|h: f64, x: &mut V| {
        let r2 = x[0] * x[0] + x[1] * x[1];
        let c = h / (r2 * r2.sqrt());
        x[2] -= c * x[0];
        x[3] -= c * x[1];
    })
    .kick();
    let drift = from_fn(|h: f64, x: &mut V| {
        x[0] += h * x[2];
        x[1] += h * x[3];
    });
    kick.strang(drift)
}

/// Steps shrinking like the period at the current radius: `ρ = |q|^{−3/2}`,
/// `G = d/dt log ρ = −(3/2) qᵀp / qᵀq`.
fn kepler_density() -> impl StepDensity<V> {
    step_density(
        |x: &V| (x[0] * x[0] + x[1] * x[1]).powf(-0.75),
        |x: &V| -1.5 * (x[0] * x[2] + x[1] * x[3]) / (x[0] * x[0] + x[1] * x[1]),
    )
}

fn options(tol: f64) -> AdaptiveOptions<f64> {
    AdaptiveOptions::new(Tolerances::new(tol, tol).unwrap())
}

fn reversible(tol: f64) -> impl Flow<V> {
    ReversibleSteps::try_new(verlet(), kepler_density(), options(tol)).unwrap()
}

/// `n` own steps in the direction of `sign`; returns the time reached.
fn own_steps(flow: &mut impl Flow<V>, ledger: &mut Ledger<f64>, n: usize, sign: f64, x: &mut V) {
    for _ in 0..n {
        flow.step_own(ledger, sign * 1e9, x)
            .expect("an adaptive flow")
            .unwrap();
    }
}

fn distance(a: &V, b: &V) -> f64 {
    (a - b).amax()
}

#[test]
fn forward_then_back_returns_to_the_start_to_round_off() {
    let x0 = pericentre(0.9);
    let n = 3000;
    // Reversible: n steps forward, n back.
    let mut flow = reversible(1e-7);
    let (mut x, mut ledger) = (x0, Ledger::default());
    own_steps(&mut flow, &mut ledger, n, 1.0, &mut x);
    let t_end = ledger.t;
    own_steps(&mut flow, &mut ledger, n, -1.0, &mut x);
    let miss = distance(&x, &x0);
    // Round-off: each step's rounding (a few ε on entries of size ≤ 5) carried back through
    // at most linear growth of perturbations over the span: N · 64 ε · |x|.
    let bound = n as f64 * 64.0 * f64::EPSILON * 5.0;
    // The error controller over the same span and back (it lands on 0 by clipping).
    let mut odex = AdaptiveExtrapolation::try_new(verlet(), (), options(1e-7)).unwrap();
    let mut y = x0;
    odex.step(t_end, &mut y).unwrap();
    odex.step(-t_end, &mut y).unwrap();
    let odex_miss = distance(&y, &x0);
    println!(
        "{n} steps to t = {t_end:.3} ({:.1} orbits) and back: reversible misses the start by {miss:.2e} \
         (t back to {:.1e}), the error controller by {odex_miss:.2e}; bound {bound:.1e}",
        t_end / (2.0 * PI),
        ledger.t
    );
    assert!(t_end > 2.0 * PI, "at least one orbit: t = {t_end}");
    assert!(miss <= bound, "reversible: {miss:e} > {bound:e}");
    assert!(ledger.t.abs() <= bound, "time back to {:e}", ledger.t);
    assert!(
        odex_miss > 1e3 * bound,
        "the error controller is not reversible: it should miss by far more than round-off, missed by {odex_miss:e}"
    );
}

/// The largest `|H − H₀|` over each orbit of `orbits` orbits, and the base steps taken.
fn energy_errors(flow: &mut impl Flow<V>, x0: &V, orbits: usize) -> (Vec<f64>, u64) {
    let (mut x, mut ledger) = (*x0, Ledger::default());
    let h0 = energy(x0);
    let mut worst = vec![0.0f64; orbits];
    let mut steps = 0u64;
    for (k, w) in worst.iter_mut().enumerate() {
        let end = 2.0 * PI * (k + 1) as f64;
        while ledger.t < end {
            let left = end - ledger.t;
            flow.step_own(&mut ledger, left, &mut x)
                .expect("an adaptive flow")
                .unwrap();
            steps += 1;
            *w = w.max((energy(&x) - h0).abs());
        }
    }
    (worst, steps)
}

/// Fixed Verlet steps, `n` per orbit: the largest `|H − H₀|` over `orbits` orbits.
fn fixed_energy_error(n: usize, x0: &V, orbits: usize) -> f64 {
    let mut flow = verlet();
    let (mut x, h0, h) = (*x0, energy(x0), 2.0 * PI / n as f64);
    let mut worst = 0.0f64;
    for _ in 0..n * orbits {
        flow.step(h, &mut x).unwrap();
        worst = worst.max((energy(&x) - h0).abs());
    }
    worst
}

#[test]
fn ten_thousand_orbits_of_the_eccentric_orbit_without_energy_drift() {
    let x0 = pericentre(0.9);
    let orbits = 10_000;
    let mut flow = reversible(1e-6);
    let (worst, steps) = energy_errors(&mut flow, &x0, orbits);
    let stats = flow.adaptive_stats().unwrap();
    let first = worst[..100].iter().fold(0.0f64, |a, &b| a.max(b));
    let last = worst[orbits - 100..].iter().fold(0.0f64, |a, &b| a.max(b));
    let per_orbit = steps as f64 / orbits as f64;
    // A fixed step with as many force evaluations per orbit (one Verlet step, one force).
    let same_work = fixed_energy_error(per_orbit.round() as usize, &x0, 10);
    // Verlet's energy error is O(h²): the fixed step of equal energy error.
    let needed = per_orbit * (same_work / first).sqrt();
    println!(
        "e = 0.9, {orbits} orbits: {per_orbit:.1} steps an orbit (h from {:.2e} to {:.2e}); max |ΔH| \
         over the first 100 orbits {first:.2e}, over the last 100 {last:.2e}; a fixed step with \
         the same work: {same_work:.2e}, equal error needs ≈ {needed:.0} steps an orbit",
        stats.smallest, stats.largest
    );
    // No drift: the energy error of the last orbits is that of the first (a drift linear in
    // time would multiply it by 100 here; round-off adds √N ε).
    assert!(last <= 1.5 * first, "energy drift: {first:e} → {last:e}");
    assert!(first < 1e-2, "energy error {first:e}");
    // Fewer evaluations than the fixed step of equal error: at equal work the fixed step's
    // error is larger.
    assert!(
        same_work > 4.0 * first,
        "the fixed step with {per_orbit:.0} steps an orbit reaches {same_work:e} ≤ 4 × {first:e}"
    );
}

#[test]
fn the_tolerance_sets_the_step_scale_by_the_order() {
    let x0 = pericentre(0.6);
    let count = |tol: f64| {
        let mut flow = reversible(tol);
        let mut x = x0;
        flow.step(2.0 * PI, &mut x).unwrap();
        flow.adaptive_stats().unwrap().accepted as f64
    };
    // Local error O(h³) at the calibration: h₀ ∝ tol^{1/3}, so 100× tighter is 100^{1/3} =
    // 4.64× more steps, within the calibration window's factor (1/0.5)^{1/3} = 1.26 either way.
    let (coarse, fine) = (count(1e-6), count(1e-8));
    let ratio = fine / coarse;
    println!("steps an orbit (e = 0.6): {coarse} at 1e-6, {fine} at 1e-8: ratio {ratio:.3}");
    let expected = 100f64.cbrt();
    assert!(
        (expected / 1.27..=expected * 1.27).contains(&ratio),
        "{ratio} vs {expected}"
    );
}

#[test]
fn the_interval_is_met_exactly_and_a_continuation_is_bit_identical() {
    let x0 = pericentre(0.9);
    let mut flow = reversible(1e-6);
    let mut ledger = Ledger::default();
    let mut x = x0;
    for _ in 0..7 {
        flow.step_at(&mut ledger, 0.3, &mut x).unwrap();
    }
    let t = (0..7).fold(0.0, |t, _| t + 0.3);
    assert_eq!(ledger.t, t, "each interval lands on t + h");
    let mut memory = Vec::new();
    flow.save_memory(&mut memory);
    let (xs, ls) = (x, ledger);
    own_steps(&mut flow, &mut ledger, 40, 1.0, &mut x);
    let first = x;
    let mut again = reversible(1e-6);
    again.restore_memory(&mut memory.as_slice());
    let (mut y, mut l) = (xs, ls);
    own_steps(&mut again, &mut l, 40, 1.0, &mut y);
    assert_eq!(first, y, "continuation");
    assert_eq!(ledger.t, l.t);
    // The energy after the clipped steps is that of the orbit to the scheme's accuracy.
    assert!((energy(&x) - energy(&x0)).abs() < 1e-2);
}

#[test]
fn dissipative_and_non_symmetric_schemes_are_refused_by_name() {
    let model = DampedPendulum::try_new(0.2).unwrap();
    let x0: V = model.state(1.0, 0.0);
    let damped = model
        .free_flow()
        .and_then(|f| f.projected(model.system(), &x0, ProjectionOptions::default()))
        .unwrap();
    let refused = |r: Result<_, SetupError>| match r {
        Ok(_) => panic!("accepted"),
        Err(e) => e.to_string(),
    };
    let e = refused(ReversibleSteps::try_new(damped, kepler_density(), options(1e-6)).map(|_| ()));
    assert!(e.contains("dissipates"), "{e}");
    let euler = from_fn_with_order(|h: f64, x: &mut V| x[0] += h * x[2], 1, false);
    let e = refused(ReversibleSteps::try_new(euler, kepler_density(), options(1e-6)).map(|_| ()));
    assert!(e.contains("symmetric"), "{e}");
    let e = refused(
        ReversibleSteps::try_new(verlet(), kepler_density(), options(1e-6))
            .and_then(|f| f.with_parameter(-1.0))
            .map(|_| ()),
    );
    assert!(e.contains("epsilon"), "{e}");
}
