//! Damped scenes at high order: `order = 4 | 6 | 8` extrapolates the projected Strang step
//! (every sub-step forward). Fitted orders against a double-double reference on the damped
//! pendulum and on ten damped particles on a sphere, with the constraints at round-off; the
//! same for `scheme = "petrov-galerkin"` at orders 4 and 6. The reference runs through the
//! lab's double-double splitting, compiled once in the lab, not again in this test.

use lieflow::Real as _;
use lieflow::flow::coefficients::table_by_name;
use lieflow::scene::{Raise, RunSummary, Scene, run};
use lieflow_lab::precision::double_double_splitting;

const DAMPED_PENDULUM: &str = include_str!("../../scenes/damped_pendulum.toml");
const SHELL_DAMPED: &str = include_str!("../../scenes/shell_damped.toml");

/// `text` at `order`, with `scheme` when given (else the automatic choice: extrapolation).
fn with(text: &str, scheme: Option<&str>, order: u32, t_end: f64) -> Scene {
    let scheme = scheme.map_or(String::new(), |s| format!("\nscheme = \"{s}\""));
    let text = text.replace(
        "[integrator]",
        &format!("[integrator]\norder = {order}{scheme}"),
    );
    let mut s = Scene::from_toml(&text, "test.toml").unwrap_or_else(|e| panic!("{e}"));
    s.file.integrator.t_end = t_end;
    s
}

fn run_at(scene: &Scene, dt: f64) -> RunSummary {
    let mut s = scene.clone();
    s.file.integrator.dt = dt;
    let mut c = s.compile().unwrap_or_else(|e| panic!("{e}"));
    run(c.simulation.as_mut(), &c.plan, &mut |_| {})
}

/// Kahan–Li 8 around the scene's splitting in double-double (its backward sub-steps of the mild
/// damping are harmless for a reference), at `steps` and `2 steps`: the final state and the
/// gap of the two.
fn reference(scene: &Scene, t_end: f64, steps: usize) -> (Vec<f64>, f64) {
    let c = scene.compile().unwrap();
    let model = c.model.unwrap();
    let x0 = c.simulation.state().to_vec();
    let table = table_by_name("kahan-li8").unwrap();
    let at = |n: usize| {
        double_double_splitting(&model, &x0, t_end, n, Raise::Compose(table), true).unwrap()
    };
    let (a, b) = (at(steps), at(2 * steps));
    let gap = a
        .iter()
        .zip(b.iter())
        .fold(0.0f64, |m, (u, v)| m.max((*u - *v).abs().to_f64_lossy()));
    (b.iter().map(|v| v.to_f64_lossy()).collect(), gap)
}

fn fitted(hs: &[f64], errs: &[f64]) -> f64 {
    let n = hs.len() as f64;
    let xs: Vec<f64> = hs.iter().map(|h| h.ln()).collect();
    let ys: Vec<f64> = errs.iter().map(|e| e.ln()).collect();
    let (mx, my) = (xs.iter().sum::<f64>() / n, ys.iter().sum::<f64>() / n);
    let sxy: f64 = xs.iter().zip(&ys).map(|(x, y)| (x - mx) * (y - my)).sum();
    let sxx: f64 = xs.iter().map(|x| (x - mx) * (x - mx)).sum();
    sxy / sxx
}

/// Fits the order of `order` on `text` over the step counts `counts` (each dividing `t_end`).
fn check(
    name: &str,
    text: &str,
    scheme: Option<&str>,
    t_end: f64,
    reference_steps: usize,
    cases: &[(u32, &[usize])],
) {
    let (r, gap) = reference(&with(text, None, 2, t_end), t_end, reference_steps);
    assert!(gap < 1e-16, "{name}: reference gap {gap:e}");
    for &(order, counts) in cases {
        let scene = with(text, scheme, order, t_end);
        let hs: Vec<f64> = counts.iter().map(|&n| t_end / n as f64).collect();
        let mut errs = Vec::new();
        for &h in &hs {
            let s = run_at(&scene, h);
            assert_eq!(s.error, None);
            // g = (|u|² − ℓ²)/2 rounds at ~ε ℓ |u|; the manifold stays there.
            assert!(
                s.max_abs_g.unwrap() <= 1e-14,
                "{name}: |g| {:?}",
                s.max_abs_g
            );
            errs.push(
                s.x.iter()
                    .zip(&r)
                    .fold(0.0f64, |m, (a, b)| m.max((a - b).abs())),
            );
        }
        let p = fitted(&hs, &errs);
        eprintln!("{name}, order {order}: errors {errs:?}, fitted order {p:.3}");
        assert!(
            (p - f64::from(order)).abs() <= 0.3,
            "{name}, order {order}: fitted {p:.3}, errors {errs:?}"
        );
    }
}

#[test]
fn the_damped_pendulum_scene_reaches_orders_4_6_8() {
    check(
        "damped pendulum",
        DAMPED_PENDULUM,
        None,
        2.0,
        400,
        &[
            (4, &[20, 25, 32, 40, 50]),
            (6, &[10, 16, 20, 25, 32]),
            (8, &[8, 10, 16, 20]),
        ],
    );
}

#[test]
fn ten_damped_particles_on_a_sphere_reach_orders_4_6_8() {
    check(
        "damped particles on a sphere",
        SHELL_DAMPED,
        None,
        1.0,
        200,
        &[
            (4, &[10, 16, 20, 25, 32]),
            (6, &[5, 8, 10, 16, 20]),
            (8, &[4, 5, 8, 10]),
        ],
    );
}

#[test]
fn the_petrov_galerkin_scheme_reaches_orders_4_and_6_on_both_scenes() {
    check(
        "damped pendulum, Petrov–Galerkin",
        DAMPED_PENDULUM,
        Some("petrov-galerkin"),
        2.0,
        400,
        &[(4, &[10, 16, 20, 25, 32]), (6, &[5, 8, 10, 16, 20])],
    );
    check(
        "damped particles on a sphere, Petrov–Galerkin",
        SHELL_DAMPED,
        Some("petrov-galerkin"),
        1.0,
        200,
        &[(4, &[5, 8, 10, 16, 20]), (6, &[4, 5, 8, 10])],
    );
}

/// The discrete energy balance `H_{n+1} − H_n = −D_n`, `D_n ≥ 0`, holds at every step of the
/// scene: the booked dissipation closes the budget to accumulated round-off (`≤ N · 8ε · H`
/// for N steps, a few roundings of `H` and `D` per step) and `H` never rises.
#[test]
fn the_petrov_galerkin_scene_balances_energy_at_every_step() {
    for order in [2, 4, 6] {
        let scene = with(SHELL_DAMPED, Some("petrov-galerkin"), order, 5.0);
        let s = run_at(&scene, 0.01);
        assert_eq!(s.error, None);
        let (h0, d) = (s.energy_initial.unwrap(), s.dissipated.unwrap());
        let scale = h0.abs().max(d.abs());
        let bound = s.steps as f64 * 8.0 * f64::EPSILON * scale;
        let balance = s.max_energy_balance_error.unwrap();
        eprintln!(
            "order {order}: balance {balance:e} (bound {bound:e}), largest rise {:e}, dissipated {d}",
            s.max_energy_increase.unwrap()
        );
        assert!(balance <= bound, "order {order}: {balance:e} > {bound:e}");
        assert!(s.max_energy_increase.unwrap() <= 0.0);
        assert!(d > 0.0);
        assert!(s.max_abs_g.unwrap() <= 1e-14);
    }
}
