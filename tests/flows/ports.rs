//! Inputs `x' = … + B u(t)`: fitted orders with time-dependent inputs, the energy balance
//! `H(x_T) − H(x_0) = −dissipated + supplied`, and held inputs set between steps.

use crate::common;

use common::fitted_order;
use lieflow::flow::{Ledger, coefficients, from_fn_at};
use lieflow::models::SphericalPendulum;
use lieflow::port::{ComponentInputs, Held, InputFlow, Signal};
use lieflow::prelude::*;
use nalgebra::SVector;

type V2 = SVector<f64, 2>;
type V6 = SVector<f64, 6>;

/// `q'' + c q' + ω² q = A sin(Ω t)`: `H = p²/2 + ω² q²/2`, `R = c` on `p`, the force on `p`.
#[derive(Clone, Copy)]
struct Oscillator {
    omega: f64,
    c: f64,
    amplitude: f64,
    forcing: f64,
}

impl Hamiltonian<V2> for Oscillator {
    fn energy(&self, x: &V2) -> f64 {
        0.5 * (x[1] * x[1] + self.omega * self.omega * x[0] * x[0])
    }
    fn gradient(&self, x: &V2, out: &mut V2) {
        out[0] = self.omega * self.omega * x[0];
        out[1] = x[1];
    }
}

impl Oscillator {
    /// The closed-form solution from `(q0, p0)` at `t = 0` (underdamped).
    fn exact(&self, t: f64, q0: f64, p0: f64) -> V2 {
        let (w, c, a_f, om) = (self.omega, self.c, self.amplitude, self.forcing);
        let d = (w * w - om * om).powi(2) + (c * om).powi(2);
        let a = a_f * (w * w - om * om) / d;
        let b = -a_f * c * om / d;
        let wd = (w * w - c * c / 4.0).sqrt();
        let c1 = q0 - b;
        let c2 = (p0 - a * om + c / 2.0 * c1) / wd;
        let e = (-c * t / 2.0).exp();
        let (s, co) = (wd * t).sin_cos();
        let q = e * (c1 * co + c2 * s) + a * (om * t).sin() + b * (om * t).cos();
        let p = e * (-c / 2.0 * (c1 * co + c2 * s) + wd * (-c1 * s + c2 * co))
            + a * om * (om * t).cos()
            - b * om * (om * t).sin();
        V2::new(q, p)
    }

    /// Strang `kick(h/2) input(h/2) drift(h) input(h/2) kick(h/2)` with the exact damped
    /// drift `q' = p, p' = −c p`, which books the kinetic energy it removes as dissipated.
    fn scheme(&self) -> impl Flow<V2> + use<> {
        let (w2, c) = (self.omega * self.omega, self.c);
        let kick = from_fn(move |h: f64, x: &mut V2| x[1] -= h * w2 * x[0]);
        let drift = from_fn_at(move |l: &mut Ledger<f64>, h: f64, x: &mut V2| {
            let p = x[1];
            let (e, travel) = if c == 0.0 {
                (1.0, h)
            } else {
                ((-c * h).exp(), -(-c * h).exp_m1() / c)
            };
            x[0] += p * travel;
            x[1] = p * e;
            l.dissipated += 0.5 * (p * p - x[1] * x[1]);
        });
        let drift = if c > 0.0 { drift.dissipative() } else { drift };
        let input = InputFlow::try_new(
            ComponentInputs::new(&[1]),
            vec![Signal::Sine {
                amplitude: self.amplitude,
                omega: self.forcing,
                phase: 0.0,
                offset: 0.0,
            }],
        )
        .unwrap()
        .supplying(*self);
        kick.strang(input.strang(drift))
    }
}

const DAMPED: Oscillator = Oscillator {
    omega: 2.0,
    c: 0.3,
    amplitude: 1.5,
    forcing: 1.3,
};

/// Runs `flow` to `t_end` with `n` steps; the state and the ledger.
fn run<V: Vector<Real = f64>, F: Flow<V>>(
    flow: F,
    x0: V,
    t_end: f64,
    n: usize,
) -> (V, Ledger<f64>) {
    let mut s = Stepper::new(flow, x0, 0.0, t_end / n as f64).unwrap();
    s.advance(n, &mut ()).unwrap();
    assert!((s.time() - t_end).abs() < 1e-12);
    let l = s.ledger();
    (s.state().clone(), l)
}

#[test]
fn forced_damped_oscillator_converges_at_order_two_with_its_energy_balance() {
    let (t_end, x0) = (10.0, V2::new(1.0, 0.0));
    let exact = DAMPED.exact(t_end, 1.0, 0.0);
    let (mut hs, mut errs, mut balances) = (vec![], vec![], vec![]);
    for n in [100, 200, 400, 800, 1600] {
        let (x, l) = run(DAMPED.scheme(), x0, t_end, n);
        hs.push(t_end / n as f64);
        errs.push((x - exact).amax());
        let balance = DAMPED.energy(&x) - DAMPED.energy(&x0) + l.dissipated - l.supplied;
        balances.push(balance.abs());
        assert!(l.dissipated > 0.0 && l.supplied.is_finite());
    }
    let p = fitted_order(&hs, &errs, 1e-13);
    assert!((p - 2.0).abs() < 0.1, "order {p}, errors {errs:?}");
    // The balance's residual is the error of H(x_T), D and S: O(h²), not worse.
    let pb = fitted_order(&hs, &balances, 1e-13);
    eprintln!(
        "damped forced oscillator: order {p:.3}, balance order {pb:.3}, errors {errs:?}, balance {balances:?}"
    );
    assert!(pb > 1.9, "balance order {pb}, residuals {balances:?}");
}

#[test]
fn forced_oscillator_composed_reaches_orders_four_and_six() {
    let undamped = Oscillator { c: 0.0, ..DAMPED };
    let (t_end, x0) = (10.0, V2::new(1.0, 0.0));
    // c = 0: the closed form's damped formulas at c → 0 (wd = ω).
    let exact = undamped.exact(t_end, 1.0, 0.0);
    for (table, order, ns) in [
        (&coefficients::TRIPLE_JUMP, 4.0, [50, 100, 200, 400, 800]),
        (&coefficients::KAHAN_LI6, 6.0, [25, 50, 100, 200, 400]),
    ] {
        let (mut hs, mut errs, mut balances) = (vec![], vec![], vec![]);
        for n in ns {
            let (x, l) = run(undamped.scheme().composed(table), x0, t_end, n);
            hs.push(t_end / n as f64);
            errs.push((x - exact).amax());
            balances.push((undamped.energy(&x) - undamped.energy(&x0) - l.supplied).abs());
            assert_eq!(l.dissipated, 0.0);
        }
        let p = fitted_order(&hs, &errs, 1e-12);
        assert!(
            (p - order).abs() < 0.25,
            "{}: order {p}, errors {errs:?}",
            table.name
        );
        let pb = fitted_order(&hs, &balances, 1e-12);
        eprintln!(
            "forced oscillator, {}: order {p:.3}, balance order {pb:.3}",
            table.name
        );
        assert!(
            pb > order - 0.25,
            "{}: balance order {pb}: {balances:?}",
            table.name
        );
    }
}

/// The spherical pendulum (moving in the x–z plane) pushed along x by `A sin(Ω t)`.
fn forced_pendulum(
    table: Option<&'static lieflow::flow::CompositionTable>,
) -> (Box<dyn Flow<V6>>, V6) {
    let model = SphericalPendulum::try_new(1.0, 1.0, 9.81).unwrap();
    let theta: f64 = 0.8;
    let x0 = V6::from_column_slice(&[theta.sin(), 0.0, -theta.cos(), 0.0, 0.0, 0.0]);
    let input = InputFlow::try_new(
        ComponentInputs::new(&[3]),
        vec![Signal::Sine {
            amplitude: 2.0,
            omega: 3.0,
            phase: 0.3,
            offset: 0.0,
        }],
    )
    .unwrap()
    .supplying(model);
    let base = model
        .kick::<V6>()
        .strang(input.strang(model.drift::<V6>()))
        .projected(model.system(), &x0, ProjectionOptions::default())
        .unwrap();
    let flow: Box<dyn Flow<V6>> = match table {
        Some(t) => Box::new(base.composed(t)),
        None => Box::new(base),
    };
    (flow, x0)
}

#[test]
fn forced_pendulum_keeps_its_orders_and_the_constraint() {
    let t_end = 2.0;
    let model = SphericalPendulum::try_new(1.0, 1.0, 9.81).unwrap();
    // Reference: the order-8 composition at a step where its error is below 1e-14.
    let (flow, x0) = forced_pendulum(Some(&coefficients::KAHAN_LI8));
    let (reference, lref) = run(flow, x0, t_end, 800);
    for (table, order, ns) in [
        (None, 2.0, [100, 200, 400, 800, 1600]),
        (
            Some(&coefficients::TRIPLE_JUMP),
            4.0,
            [50, 100, 200, 400, 800],
        ),
    ] {
        let (mut hs, mut errs, mut balances) = (vec![], vec![], vec![]);
        for n in ns {
            let (flow, x0) = forced_pendulum(table);
            let mut s = Stepper::new(flow, x0, 0.0, t_end / n as f64).unwrap();
            let mut worst_g = 0.0f64;
            for _ in 0..n {
                s.step().unwrap();
                let q = s.state();
                worst_g =
                    worst_g.max(((q[0] * q[0] + q[1] * q[1] + q[2] * q[2]) - 1.0).abs() / 2.0);
            }
            assert!(worst_g < 1e-14, "max |g| {worst_g:e}");
            let l = s.ledger();
            hs.push(t_end / n as f64);
            errs.push((s.state() - reference).amax());
            let balance = model.energy(s.state()) - model.energy(&x0) - l.supplied;
            balances.push(balance.abs());
        }
        let p = fitted_order(&hs, &errs, 1e-12);
        assert!(
            (p - order).abs() < 0.25,
            "order {p} (expected {order}): {errs:?}"
        );
        let pb = fitted_order(&hs, &balances, 1e-12);
        eprintln!(
            "forced pendulum, order {order}: fitted {p:.3}, balance order {pb:.3}, errors {errs:?}"
        );
        assert!(pb > order - 0.25, "balance order {pb}: {balances:?}");
    }
    // The reference's own balance closes to its accuracy.
    let balance = model.energy(&reference) - model.energy(&x0) - lref.supplied;
    assert!(balance.abs() < 1e-11, "reference balance {balance:e}");
}

#[test]
fn held_inputs_are_integrated_as_zero_order_hold_set_between_steps() {
    // p' = u (no other force): p(T) = Σ u_k h exactly, whatever the splitting.
    let held = Held::new(0.0);
    let input =
        InputFlow::try_new(ComponentInputs::new(&[1]), vec![Signal::Held(held.clone())]).unwrap();
    let drift = from_fn(|h: f64, x: &mut V2| x[0] += h * x[1]);
    let mut s = Stepper::new(input.strang(drift), V2::zeros(), 0.0, 0.1).unwrap();
    let mut expected_p = 0.0;
    for k in 0..10 {
        let u = (k as f64).sin();
        held.set(u);
        s.step().unwrap();
        expected_p += u * 0.1;
    }
    assert!((s.state()[1] - expected_p).abs() < 1e-15);
}

#[test]
fn the_signal_count_must_match_the_input_map() {
    let e = InputFlow::<V2, _>::try_new(
        ComponentInputs::<f64>::new(&[0, 1]),
        vec![Signal::Constant(1.0)],
    )
    .unwrap_err();
    assert!(
        e.to_string()
            .contains("1 signals for an input map with 2 inputs"),
        "{e}"
    );
}

#[test]
fn an_input_that_does_not_carry_time_loses_the_order() {
    // The control: the same sine force read at the macro step's start time in every sub-step
    // (what a closure over a cell set once per step gives) is first order only.
    let osc = Oscillator { c: 0.0, ..DAMPED };
    let (t_end, x0) = (10.0, V2::new(1.0, 0.0));
    let exact = osc.exact(t_end, 1.0, 0.0);
    let (w2, om, amp) = (osc.omega * osc.omega, osc.forcing, osc.amplitude);
    let (mut hs, mut errs) = (vec![], vec![]);
    for n in [100, 200, 400, 800, 1600] {
        let kick = from_fn(move |h: f64, x: &mut V2| x[1] -= h * w2 * x[0]);
        let frozen = from_fn_at(move |l: &mut Ledger<f64>, h: f64, x: &mut V2| {
            x[1] += h * amp * (om * l.t).sin();
        });
        let drift = from_fn(|h: f64, x: &mut V2| x[0] += h * x[1]);
        let flow = kick.strang(frozen.strang(drift)).triple_jump();
        let (x, _) = run(flow, x0, t_end, n);
        hs.push(t_end / n as f64);
        errs.push((x - exact).amax());
    }
    let p = fitted_order(&hs, &errs, 1e-12);
    assert!((p - 1.0).abs() < 0.15, "order {p}: {errs:?}");
}
