//! Extrapolation of the symmetric projected step on the damped pendulum: fitted orders 4 to 12
//! in double-double against a double-double reference, no backward sub-step of the damping,
//! the constraint and hidden constraint at round-off after every macro step, the booked energy
//! balance at the scheme's order, and the refusals.

use crate::common;

use common::fitted_order;
use lieflow::flow::{Extrapolated, Ledger, LinearFlow};
use lieflow::models::DampedPendulum;
use lieflow::nonlinear::NewtonOptions;
use lieflow::prelude::*;
use nalgebra::SVector;
use std::cell::Cell;
use std::rc::Rc;
use twofloat::TwoFloat;

const C: f64 = 0.5;
const THETA0: f64 = std::f64::consts::FRAC_PI_2;

/// The exact damped free flight, counting its sub-steps (and the negative ones) and booking
/// the energy it removes, `H(before) − H(after)` (exact: the unconstrained damped flow loses
/// `c |p|²` per unit time and nothing else).
struct Counted<T> {
    inner: LinearFlow<T>,
    model: DampedPendulum<T>,
    steps: Rc<Cell<u64>>,
    negative: Rc<Cell<u64>>,
}

impl<T: lieflow::Real, V: Vector<Real = T>> Flow<V> for Counted<T>
where
    LinearFlow<T>: Flow<V>,
{
    fn step(&mut self, h: T, x: &mut V) -> Result<(), StepError> {
        self.step_at(&mut Ledger::default(), h, x)
    }
    fn step_at(&mut self, ledger: &mut Ledger<T>, h: T, x: &mut V) -> Result<(), StepError> {
        self.steps.set(self.steps.get() + 1);
        if h < T::zero() {
            self.negative.set(self.negative.get() + 1);
        }
        let before = self.model.energy(x);
        self.inner.step(h, x)?;
        ledger.dissipated = ledger.dissipated + before - self.model.energy(x);
        ledger.t = ledger.t + h;
        Ok(())
    }
    fn order(&self) -> u32 {
        <LinearFlow<T> as Flow<V>>::order(&self.inner)
    }
    fn is_symmetric(&self) -> bool {
        true
    }
    fn dissipates(&self) -> bool {
        true
    }
}

struct Counters {
    steps: Rc<Cell<u64>>,
    negative: Rc<Cell<u64>>,
}

/// The extrapolated projected step of `order` for the pendulum in scalar `T` (`tol` the
/// Newton tolerance), and the counters of its damping sub-flow.
#[allow(clippy::type_complexity)]
fn scheme<T: lieflow::Real>(
    order: u32,
    x0: &SVector<T, 4>,
    options: ProjectionOptions<T>,
) -> (Box<dyn Flow<SVector<T, 4>>>, Counters) {
    let model = DampedPendulum::try_new(T::lit(C)).unwrap();
    let steps = Rc::new(Cell::new(0));
    let negative = Rc::new(Cell::new(0));
    let counted = Counted {
        inner: model.free_flow().unwrap(),
        model,
        steps: steps.clone(),
        negative: negative.clone(),
    };
    let projected = counted.projected(model.system(), x0, options).unwrap();
    let flow: Box<dyn Flow<SVector<T, 4>>> = if order == 2 {
        Box::new(projected)
    } else {
        Box::new(
            projected
                .extrapolated(order)
                .unwrap()
                .reprojected(model.system(), x0, options)
                .unwrap(),
        )
    };
    (flow, Counters { steps, negative })
}

mod double_double {
    use super::*;
    type T = TwoFloat;
    type V = SVector<T, 4>;

    /// The index-reduced Cartesian ODE `q' = p`, `p' = −q μ − c p − e_y` with
    /// `μ = (|p|² − y)/|q|²` (from `d/dt (q·p) = 0`), by classical Runge–Kutta with `n` steps.
    fn rk4(t_end: f64, n: usize) -> V {
        let c = T::from(C);
        let f = |x: &V| {
            let mu = (x[2] * x[2] + x[3] * x[3] - x[1]) / (x[0] * x[0] + x[1] * x[1]);
            V::new(
                x[2],
                x[3],
                -x[0] * mu - c * x[2],
                -T::from(1.0) - x[1] * mu - c * x[3],
            )
        };
        let dt = T::from(t_end) / T::from(n as f64);
        let half = dt * T::from(0.5);
        let mut x = start();
        for _ in 0..n {
            let k1 = f(&x);
            let k2 = f(&(x + k1 * half));
            let k3 = f(&(x + k2 * half));
            let k4 = f(&(x + k3 * dt));
            x += (k1 + k2 * T::from(2.0) + k3 * T::from(2.0) + k4) * (dt / T::from(6.0));
        }
        x
    }

    /// `(16 RK4(2n) − RK4(n))/15`: Richardson on the reference, error `O(dt⁶)`.
    fn reference(t_end: f64, n: usize) -> V {
        (rk4(t_end, 2 * n) * T::from(16.0) - rk4(t_end, n)) / T::from(15.0)
    }

    fn start() -> V {
        let m = DampedPendulum::try_new(T::from(C)).unwrap();
        m.state(T::from(THETA0), T::from(0.0))
    }

    fn options() -> ProjectionOptions<T> {
        // twofloat's `epsilon()` is not its round-off: the tolerances are set explicitly, above
        // the ~1e-26 noise of its `exp` (in the damping factor e^{−c h}).
        let newton = NewtonOptions::default()
            .with_ftol(T::from(1e-24))
            .with_xtol(T::from(1e-31))
            .with_fd_step(T::from(1e-16));
        ProjectionOptions::default()
            .with_newton(newton)
            .with_manifold_tol(Some(T::from(1e-22)))
    }

    fn error(order: u32, h: f64, t_end: f64, r: &V) -> (f64, u64) {
        let mut x = start();
        let (mut flow, counters) = scheme(order, &x, options());
        for _ in 0..(t_end / h).round() as usize {
            flow.step(T::from(h), &mut x).unwrap();
        }
        let e = (0..4)
            .map(|i| f64::from((x[i] - r[i]).abs()))
            .fold(0.0, f64::max);
        (e, counters.negative.get())
    }

    fn check(order: u32, hs: &[f64]) {
        let t_end = 5.0;
        let r = reference(t_end, 20_000);
        let r2 = reference(t_end, 40_000);
        let ref_err = (0..4)
            .map(|i| f64::from((r[i] - r2[i]).abs()))
            .fold(0.0, f64::max);
        let runs: Vec<(f64, u64)> = hs.iter().map(|&h| error(order, h, t_end, &r)).collect();
        let errs: Vec<f64> = runs.iter().map(|r| r.0).collect();
        let p = fitted_order(hs, &errs, 1e3 * ref_err.max(1e-30));
        eprintln!(
            "extrapolated order {order} (double-double): reference error {ref_err:.1e}, errors {errs:?}, fitted order {p:.3}"
        );
        assert!(runs.iter().all(|r| r.1 == 0), "a backward damping step");
        assert!(
            (p - f64::from(order)).abs() <= 0.3,
            "order {order}: fitted {p:.3}"
        );
    }

    #[test]
    fn extrapolated_projected_strang_has_order_4() {
        check(4, &[0.5, 0.3125, 0.25, 0.15625, 0.125]);
    }

    #[test]
    fn extrapolated_projected_strang_has_order_6() {
        check(6, &[0.5, 0.3125, 0.25, 0.15625, 0.125]);
    }

    #[test]
    fn extrapolated_projected_strang_has_order_8() {
        check(8, &[0.5, 0.3125, 0.25, 0.15625, 0.125]);
    }

    #[test]
    fn extrapolated_projected_strang_has_order_10() {
        check(10, &[0.5, 0.3125, 0.25, 0.15625, 0.125]);
    }

    #[test]
    fn extrapolated_projected_strang_has_order_12() {
        // Steps from 0.5 to 0.36: at h = 0.25 the error is at the reference's floor.
        check(
            12,
            &[
                0.5,
                0.45454545454545453,
                0.4166666666666667,
                0.38461538461538464,
                0.35714285714285715,
            ],
        );
    }
}

/// In `f64`: `g` and `φ` at round-off after every macro step, every sub-step forward, and the
/// booked balance `H(T) − H(0) + D` converging at the scheme's order.
#[test]
fn macro_steps_stay_on_the_manifold_and_book_the_balance_at_order() {
    type V = SVector<f64, 4>;
    let model = DampedPendulum::try_new(C).unwrap();
    let x0: V = model.state(THETA0, 0.0);
    let t_end = 5.0;
    for order in [4, 6, 8] {
        let mut balances = Vec::new();
        let hs = [0.5, 0.25, 0.125];
        for &h in &hs {
            let (mut flow, counters) = scheme(order, &x0, ProjectionOptions::default());
            let mut x = x0;
            let mut ledger = Ledger::at(0.0);
            let (mut max_g, mut max_phi) = (0.0f64, 0.0f64);
            let steps = (t_end / h) as usize;
            for _ in 0..steps {
                flow.step_at(&mut ledger, h, &mut x).unwrap();
                max_g = max_g.max((0.5 * (x[0] * x[0] + x[1] * x[1] - 1.0)).abs());
                max_phi = max_phi.max(model.hidden_constraint(&x).abs());
            }
            // Round-off of g = (|q|² − 1)/2 and φ = q·p with |q| = 1, |p| ≤ 2.
            assert!(max_g <= 4.0 * f64::EPSILON, "order {order}: |g| {max_g:e}");
            assert!(
                max_phi <= 16.0 * f64::EPSILON,
                "order {order}: |phi| {max_phi:e}"
            );
            assert_eq!(counters.negative.get(), 0);
            // Each base step runs the damping flow once per Newton residual, at least once.
            let rows = u64::from(order / 2);
            assert!(counters.steps.get() >= steps as u64 * rows * (rows + 1) / 2);
            assert!((ledger.t - t_end).abs() <= 1e-13, "time {}", ledger.t);
            let balance = model.energy(&x) - model.energy(&x0) + ledger.dissipated;
            balances.push(balance.abs());
        }
        let ratio = balances[1] / balances[2];
        eprintln!("order {order}: balance defects {balances:?}");
        // Halving h divides the balance defect by ~2^order (at least 2^(order − 1) here).
        assert!(
            ratio >= f64::from(1u32 << (order - 1)) || balances[2] <= 1e-13,
            "order {order}: balance ratio {ratio:.1}"
        );
    }
}

#[test]
fn extrapolation_refuses_what_it_cannot_raise() {
    type V = SVector<f64, 4>;
    let model = DampedPendulum::try_new(C).unwrap();
    let free = || model.free_flow().unwrap();
    // Not symmetric.
    let lie = FlowExt::<V>::then(free(), free());
    assert!(matches!(
        lie.extrapolated(4),
        Err(SetupError::Scheme { .. })
    ));
    // Odd, too low, too high.
    for order in [3, 2, 20] {
        let strang = FlowExt::<V>::strang(free(), free());
        let e = strang.extrapolated(order).unwrap_err();
        assert!(e.to_string().contains("even orders 4 to 16"), "{e}");
    }
    // An exact flow has no error to extrapolate.
    assert!(FlowExt::<V>::extrapolated(free(), 4).is_err());
    // Sequences.
    let strang = FlowExt::<V>::strang(free(), free());
    assert!(Extrapolated::with_steps(strang, &[1, 1]).is_err());
    let strang = FlowExt::<V>::strang(free(), free());
    let romberg = Extrapolated::with_steps(strang, &[1, 2, 4, 8]).unwrap();
    assert_eq!(Flow::<V>::order(&romberg), 8);
    assert!((romberg.amplification() - 1.0).abs() < 2.0);
}

/// A flow that forwards the projection's single steps and nothing else, so that an
/// extrapolation row takes its `n` base steps one `step_at` at a time (the default
/// `Flow::step_repeated`) instead of the projection's fused half-steps.
struct StepByStep<F>(F);

impl<V: Vector, F: Flow<V>> Flow<V> for StepByStep<F> {
    fn step(&mut self, h: V::Real, x: &mut V) -> Result<(), StepError> {
        self.0.step(h, x)
    }
    fn step_at(
        &mut self,
        ledger: &mut Ledger<V::Real>,
        h: V::Real,
        x: &mut V,
    ) -> Result<(), StepError> {
        self.0.step_at(ledger, h, x)
    }
    fn order(&self) -> u32 {
        self.0.order()
    }
    fn is_symmetric(&self) -> bool {
        self.0.is_symmetric()
    }
    fn dissipates(&self) -> bool {
        self.0.dissipates()
    }
    fn prepare(&mut self, x: &V) {
        self.0.prepare(x)
    }
    fn stats(&self) -> lieflow::flow::FlowStats {
        self.0.stats()
    }
    fn save_memory(&mut self, out: &mut Vec<V::Real>) {
        self.0.save_memory(out)
    }
    fn restore_memory(&mut self, from: &mut &[V::Real]) {
        self.0.restore_memory(from)
    }
}

/// An extrapolation row's `n` projected base steps run fused (the `λ_{k+1}` half-step of each
/// with the `λ_k` half-step of the next: one multiplier solve a base step, plus the row's last
/// `λ_{k+1}`) give the map of the `n` separate steps: both solve to round-off (`ftol = 2ε`), so
/// they agree to a few ulps a base step, amplified at most by the weights' `Σ |w_j|`; and the
/// fused rows take fewer multiplier solves (`Σ (n_j − 1)` fewer a macro step). Both are
/// reprojected after each macro step.
#[test]
fn fused_rows_take_the_same_steps_with_fewer_solves() {
    type V = SVector<f64, 4>;
    let model = DampedPendulum::try_new(C).unwrap();
    let x0: V = model.state(THETA0, 0.0);
    let options = ProjectionOptions::default();
    let (h, macro_steps) = (0.25, 20);
    for order in [4, 6, 8] {
        let projected = || {
            model
                .free_flow()
                .unwrap()
                .projected(model.system(), &x0, options)
                .unwrap()
        };
        // Reprojected after each macro step, as a scene runs it: the combination itself is on
        // the manifold only to the scheme's order, and the next step's entry check wants it.
        let fused = projected().extrapolated(order).unwrap();
        let amplification = fused.amplification();
        let mut fused = fused.reprojected(model.system(), &x0, options).unwrap();
        let mut single = StepByStep(projected())
            .extrapolated(order)
            .unwrap()
            .reprojected(model.system(), &x0, options)
            .unwrap();
        let (mut a, mut b) = (x0, x0);
        let (mut la, mut lb) = (Ledger::at(0.0), Ledger::at(0.0));
        let mut largest = 0.0f64;
        for _ in 0..macro_steps {
            fused.step_at(&mut la, h, &mut a).unwrap();
            single.step_at(&mut lb, h, &mut b).unwrap();
            largest = largest.max((a - b).amax());
        }
        let rows = u64::from(order / 2);
        let base_steps = macro_steps * rows * (rows + 1) / 2;
        // A few ulps of |x| ≤ 2 per base step, through the combination.
        let bound = 8.0 * f64::EPSILON * 2.0 * base_steps as f64 * amplification;
        assert!(largest <= bound, "order {order}: {largest:e} > {bound:e}");
        assert!((la.t - lb.t).abs() <= 1e-14 && (la.dissipated - lb.dissipated).abs() <= bound);
        let (sf, ss) = (
            fused.inner().stats().newton_solves,
            single.inner().stats().newton_solves,
        );
        let saved = macro_steps * (rows * (rows + 1) / 2 - rows);
        eprintln!("order {order}: |Δx| {largest:e} (bound {bound:e}), solves {sf} against {ss}");
        assert_eq!(ss - sf, saved, "order {order}: solves {sf} against {ss}");
    }
}
