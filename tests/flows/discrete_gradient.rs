//! The Gonzalez discrete-gradient flow: exact discrete energy balance for a non-quadratic `H`,
//! conservation for skew `M`, monotone decay for `M + Mᵀ ⪯ 0`, order 2, and no 0/0 as `x' → x`.

use crate::common;

use common::fitted_order;
use lieflow::flow::{DiscreteGradient, GonzalezRule, GradientRule, ImplicitMidpoint};
use lieflow::nonlinear::NewtonOptions;
use lieflow::prelude::*;
use nalgebra::SVector;

type V = SVector<f64, 2>;

/// The pendulum in its angle: `H = p²/2 − cos q` (not quadratic).
#[derive(Clone, Copy)]
struct Pendulum;
impl Hamiltonian<V> for Pendulum {
    fn energy(&self, x: &V) -> f64 {
        0.5 * x[1] * x[1] - x[0].cos()
    }
    fn gradient(&self, x: &V, out: &mut V) {
        *out = V::new(x[0].sin(), x[1]);
    }
}

fn damped(c: f64) -> JMinusR<Canonical, Constant<f64>> {
    JMinusR::new(Canonical, Constant::from_rows(&[[0.0, 0.0], [0.0, c]]))
}

fn x0() -> V {
    V::new(2.0, 0.0)
}

#[test]
fn energy_is_conserved_to_round_off_for_a_skew_structure() {
    let mut x = x0();
    let e0 = Pendulum.energy(&x);
    let mut dg =
        DiscreteGradient::<V, _, _>::try_new(Canonical, Pendulum, &x, NewtonOptions::default())
            .unwrap();
    let mut max = 0.0f64;
    for _ in 0..10_000 {
        dg.step(0.5, &mut x).unwrap();
        max = max.max((Pendulum.energy(&x) - e0).abs());
    }
    // The implicit midpoint rule, for comparison, only keeps an O(h²) oscillation.
    let mut y = x0();
    let mut mp =
        ImplicitMidpoint::<V, _, _>::try_new(Canonical, Pendulum, &y, NewtonOptions::default())
            .unwrap();
    let mut max_mp = 0.0f64;
    for _ in 0..10_000 {
        mp.step(0.5, &mut y).unwrap();
        max_mp = max_mp.max((Pendulum.energy(&y) - e0).abs());
    }
    eprintln!("h = 0.5, 1e4 steps: |dH| discrete gradient {max:e}, implicit midpoint {max_mp:e}");
    assert!(max <= 1e-13, "discrete gradient energy error {max:e}");
    assert!(
        max_mp > 1e-4,
        "the comparison should show the midpoint's O(h²) error"
    );
}

#[test]
fn discrete_energy_balance_holds_and_energy_never_increases_with_damping() {
    for &c in &[0.1, 1e6] {
        for &h in &[1e-3, 1e-2, 0.1, 1.0] {
            let m = damped(c);
            let mut x = x0();
            let mut dg = DiscreteGradient::<V, _, _>::try_new(
                m.clone(),
                Pendulum,
                &x,
                NewtonOptions::default(),
            )
            .unwrap();
            let mut increases = 0;
            let mut worst = 0.0f64;
            for _ in 0..2000 {
                let before = x;
                dg.step(h, &mut x).unwrap();
                let (e0, e1) = (Pendulum.energy(&before), Pendulum.energy(&x));
                // Balance: H(x') − H(x) = h ∇̄Hᵀ M(x̄) ∇̄H = −h c (∇̄H)₂².
                let delta = x - before;
                let xm = before + delta * 0.5;
                let (mut g, mut tmp) = (V::zeros(), V::zeros());
                let _noise = GonzalezRule::gradient(
                    &Pendulum,
                    &before,
                    delta.as_slice(),
                    &xm,
                    &mut tmp,
                    &mut g,
                );
                let rate = -c * g[1] * g[1];
                let err = ((e1 - e0) - h * rate).abs() / e0.abs().max(1.0);
                worst = worst.max(err);
                // An increase beyond the resolution of evaluating H itself (near the equilibrium
                // the true decrease −h c (∇̄H)₂² falls below the rounding of H ≈ −1).
                if e1 > e0 + 4.0 * f64::EPSILON * e0.abs().max(e1.abs()) {
                    increases += 1;
                }
            }
            eprintln!(
                "c = {c:e}, h = {h:e}: worst relative balance error {worst:e}, H increases {increases}"
            );
            assert!(worst <= 1e-12, "c = {c}, h = {h}: balance error {worst:e}");
            assert_eq!(increases, 0, "c = {c}, h = {h}: energy increased");
        }
    }
}

/// The damped pendulum `q'' = −sin q − c q'` from `x0()` by RK4 with 200 000 steps
/// (independent of the schemes under test).
fn reference(c: f64, t_end: f64) -> V {
    let f = |x: &V| V::new(x[1], -x[0].sin() - c * x[1]);
    let n = 200_000;
    let dt = t_end / n as f64;
    let mut r = x0();
    for _ in 0..n {
        let k1 = f(&r);
        let k2 = f(&(r + k1 * (0.5 * dt)));
        let k3 = f(&(r + k2 * (0.5 * dt)));
        let k4 = f(&(r + k3 * dt));
        r += (k1 + k2 * 2.0 + k3 * 2.0 + k4) * (dt / 6.0);
    }
    r
}

#[test]
fn discrete_gradient_is_order_2() {
    let t_end = 5.0;
    let m = damped(0.1);
    let r = reference(0.1, t_end);
    let hs = [0.2, 0.1, 0.05, 0.025];
    let errs: Vec<f64> = hs
        .iter()
        .map(|&h| {
            let mut x = x0();
            let mut dg = DiscreteGradient::<V, _, _>::try_new(
                m.clone(),
                Pendulum,
                &x,
                NewtonOptions::default(),
            )
            .unwrap();
            for _ in 0..(t_end / h).round() as usize {
                dg.step(h, &mut x).unwrap();
            }
            (x - r).amax()
        })
        .collect();
    let p = fitted_order(&hs, &errs, 1e-12);
    eprintln!("discrete gradient errors {errs:?}, order {p:.3}");
    assert!((p - 2.0).abs() <= 0.3);
}

#[test]
fn tiny_steps_do_not_hit_the_zero_over_zero() {
    // As x' → x the correction (H(x') − H(x) − ∇H·Δ)/|Δ|² is a ratio of round-off; the step
    // must still agree with the vector field: x' = x + h f(x) + O(h²).
    let m = damped(0.1);
    for &h in &[1e-6, 1e-9, 1e-12] {
        let mut x = V::new(0.7, 0.3);
        let start = x;
        let mut dg =
            DiscreteGradient::<V, _, _>::try_new(m.clone(), Pendulum, &x, NewtonOptions::default())
                .unwrap();
        dg.step(h, &mut x).unwrap();
        let euler = start + V::new(start[1], -start[0].sin() - 0.1 * start[1]) * h;
        let d = (x - euler).amax();
        assert!(d <= 1e-15 + h * h, "h = {h:e}: off by {d:e}");
    }
}

#[test]
fn discrete_gradient_is_symmetric_and_reports_dissipation() {
    let x0 = x0();
    let mut dg =
        DiscreteGradient::<V, _, _>::try_new(damped(0.1), Pendulum, &x0, NewtonOptions::default())
            .unwrap();
    assert!(dg.dissipates() && dg.is_symmetric());
    let mut x = x0;
    dg.step(0.1, &mut x).unwrap();
    dg.step(-0.1, &mut x).unwrap();
    assert!((x - x0).amax() <= 1e-13);
    // Compositions with negative steps refuse it.
    let mut tj = dg.triple_jump();
    assert!(matches!(
        tj.step(0.1, &mut x),
        Err(StepError::BackwardDissipation { .. })
    ));
}

/// Without dissipation the symmetric discrete gradient composes to order 4 by the triple jump.
#[test]
fn discrete_gradient_triple_jump_is_order_4_without_dissipation() {
    let t_end = 5.0;
    let r = reference(0.0, t_end);
    let hs = [0.2, 0.1, 0.05, 0.025];
    let errs: Vec<f64> = hs
        .iter()
        .map(|&h| {
            let mut x = x0();
            let mut tj = DiscreteGradient::<V, _, _>::try_new(
                Canonical,
                Pendulum,
                &x,
                NewtonOptions::default(),
            )
            .unwrap()
            .triple_jump();
            for _ in 0..(t_end / h).round() as usize {
                tj.step(h, &mut x).unwrap();
            }
            (x - r).amax()
        })
        .collect();
    let p = fitted_order(&hs, &errs, 1e-12);
    eprintln!("discrete gradient triple jump errors {errs:?}, order {p:.3}");
    assert!((p - 4.0).abs() <= 0.3, "order {p}");
}
