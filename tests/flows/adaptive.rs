//! Tolerance-driven integration (`lieflow::flow::AdaptiveExtrapolation`): the achieved error
//! follows the tolerance, the constraints are at round-off after every accepted step, every
//! sub-step runs forward, the order rises as the tolerance falls, rejected and failed steps
//! leave nothing behind, and a continuation from saved memory is bit-identical.

use crate::common::log_slope as slope;
use lieflow::flow::{
    AcceptStep, AdaptiveExtrapolation, AdaptiveOptions, Flow, FlowExt, Ledger, ManifoldProjection,
    Tolerances,
};
use lieflow::models::DampedPendulum;
use lieflow::prelude::*;
use nalgebra::SVector;

pub(crate) type V = SVector<f64, 4>;
pub(crate) const THETA0: f64 = std::f64::consts::FRAC_PI_2;
const C: f64 = 0.1;

/// The projection after each accepted step, recording the residuals it leaves.
pub(crate) struct Watched<P> {
    inner: P,
    worst_g: f64,
    worst_phi: f64,
    accepted: usize,
}

impl<P: AcceptStep<V>> AcceptStep<V> for Watched<P> {
    fn accept(&mut self, x: &mut V) -> Result<(), StepError> {
        self.inner.accept(x)?;
        self.worst_g = self
            .worst_g
            .max((0.5 * (x[0] * x[0] + x[1] * x[1] - 1.0)).abs());
        self.worst_phi = self.worst_phi.max((x[0] * x[2] + x[1] * x[3]).abs());
        self.accepted += 1;
        Ok(())
    }
}

/// The base step, counting its sub-steps by sign.
pub(crate) struct Signed<F> {
    inner: F,
    negative: u64,
    positive: u64,
}

impl<F: Flow<V>> Flow<V> for Signed<F> {
    fn step(&mut self, h: f64, x: &mut V) -> Result<(), StepError> {
        self.step_at(&mut Ledger::default(), h, x)
    }
    fn step_at(&mut self, l: &mut Ledger<f64>, h: f64, x: &mut V) -> Result<(), StepError> {
        if h < 0.0 {
            self.negative += 1;
        } else {
            self.positive += 1;
        }
        self.inner.step_at(l, h, x)
    }
    fn order(&self) -> u32 {
        self.inner.order()
    }
    fn is_symmetric(&self) -> bool {
        self.inner.is_symmetric()
    }
    fn dissipates(&self) -> bool {
        self.inner.dissipates()
    }
    fn save_memory(&mut self, out: &mut Vec<f64>) {
        self.inner.save_memory(out)
    }
    fn restore_memory(&mut self, from: &mut &[f64]) {
        self.inner.restore_memory(from)
    }
}

pub(crate) fn model() -> DampedPendulum<f64> {
    DampedPendulum::try_new(C).unwrap()
}

fn base(m: &DampedPendulum<f64>, x0: &V) -> Signed<impl Flow<V> + use<>> {
    Signed {
        inner: m
            .free_flow()
            .unwrap()
            .projected(m.system(), x0, ProjectionOptions::default())
            .unwrap(),
        negative: 0,
        positive: 0,
    }
}

pub(crate) type Adaptive = AdaptiveExtrapolation<
    V,
    Signed<Box<dyn Flow<V>>>,
    Watched<
        ManifoldProjection<
            V,
            lieflow::System<
                lieflow::models::damped_pendulum::DampedStructure<f64>,
                DampedPendulum<f64>,
                lieflow::models::paper::Circle,
            >,
        >,
    >,
>;

fn adaptive(tol: f64) -> (Adaptive, V) {
    adaptive_with(AdaptiveOptions::new(Tolerances::new(tol, tol).unwrap()))
}

pub(crate) fn adaptive_with(options: AdaptiveOptions<f64>) -> (Adaptive, V) {
    let m = model();
    let x0: V = m.state(THETA0, 0.0);
    let b = base(&m, &x0);
    let b = Signed {
        inner: Box::new(b.inner) as Box<dyn Flow<V>>,
        negative: 0,
        positive: 0,
    };
    let finish = Watched {
        inner: ManifoldProjection::try_new(m.system(), &x0, ProjectionOptions::default()).unwrap(),
        worst_g: 0.0,
        worst_phi: 0.0,
        accepted: 0,
    };
    (
        AdaptiveExtrapolation::try_new(b, finish, options).unwrap(),
        x0,
    )
}

/// The Newton tolerance's accepted floor, `100 · 2ε`, at which the projection leaves a row.
const ROWS: f64 = 200.0 * f64::EPSILON;

#[test]
fn the_error_follows_the_tolerance_on_the_damped_pendulum() {
    // θ₀ = π/2, c = 0.1, over 10 s in the flow's own steps (`Stepper::advance_own_to`), rtol =
    // atol = tol from 1e-4 to 1e-12, against the angle equation by RK4 at 1e-4 (error below
    // 1e-14). The controller bounds each step's local error, so the global error tracks the
    // tolerance: a log–log slope within 0.8 … 1.2, each error below the sum of the local
    // bounds and above 1e-2 tol (measured: 1.3 … 10 tol).
    // After every accepted step the projection leaves g and φ at the Newton floor; no base
    // sub-step runs backwards; the mean order rises as the tolerance falls.
    let t_end = 10.0;
    let m = model();
    let want = m.reference(THETA0, 0.0, t_end, 1e-4);
    let tols = [1e-4, 1e-6, 1e-8, 1e-10, 1e-12];
    let mut errs = Vec::new();
    let mut orders = Vec::new();
    for &tol in &tols {
        let (flow, x0) = adaptive(tol);
        let mut stepper = Stepper::new(flow, x0, 0.0, 1.0).unwrap();
        let steps = stepper.advance_own_to(t_end, &mut ()).unwrap();
        assert_eq!(stepper.time(), t_end);
        let x = *stepper.state();
        let flow = stepper.flow();
        let s = flow.adaptive_stats().expect("an adaptive flow");
        assert_eq!(steps as u64, s.accepted);
        let err = (0..4).map(|k| (x[k] - want[k]).abs()).fold(0.0, f64::max);
        let mean_order = s
            .orders
            .iter()
            .enumerate()
            .map(|(k, &n)| 2.0 * k as f64 * n as f64)
            .sum::<f64>()
            / s.accepted as f64;
        eprintln!(
            "tol {tol:e}: error {err:.3e} ({:.2} tol), accepted {}, rejected {}, failed {}, base steps {}, mean order {mean_order:.2}, h in [{:.3e}, {:.3e}]",
            err / tol,
            s.accepted,
            s.rejected,
            s.failed,
            s.base_steps,
            s.smallest,
            s.largest
        );
        let (finish, base) = (flow.finish(), flow.base());
        assert_eq!(finish.accepted as u64, s.accepted);
        assert!(
            finish.worst_g <= ROWS && finish.worst_phi <= ROWS,
            "tol {tol:e}: g {:e}, φ {:e}",
            finish.worst_g,
            finish.worst_phi
        );
        assert_eq!(base.negative, 0);
        assert!(base.positive >= s.base_steps);
        // Each accepted step's local error is at most tol in the weighted RMS norm: at most
        // 2·(1 + |x|∞) tol ≤ 5 tol in the max-norm here (four components, |x| ≤ 1.5); the
        // damped pendulum does not amplify them, so the global error is below their sum —
        // and a controller that met the tolerance by luck alone would land far below it.
        let bound = 5.0 * s.accepted as f64 * tol;
        assert!(
            err <= bound && err >= 1e-2 * tol,
            "tol {tol:e}: error {err:e}, bound {bound:e}"
        );
        errs.push(err);
        orders.push(mean_order);
    }
    let p = slope(&tols, &errs);
    eprintln!("error against tolerance: slope {p:.3}; mean orders {orders:?}");
    assert!((0.8..=1.2).contains(&p), "slope {p}");
    assert!(orders.windows(2).all(|w| w[1] >= w[0] - 0.5), "{orders:?}");
    assert!(orders[4] >= orders[0] + 4.0, "{orders:?}");
}

#[test]
fn communication_points_are_met_exactly_and_a_continuation_is_bit_identical() {
    // `step(1, x)` lands on each whole second (the last macro step clipped); saving the
    // flow's memory (the controller's proposal and column with the base step's warm starts)
    // and the state after 3 s and restoring them gives the same 4 s after, bit for bit.
    let (mut flow, x) = adaptive(1e-9);
    let ((a, la), (b, lb)) = continued_twice(&mut flow, x, |_, _| ());
    assert_eq!(a, b);
    assert_eq!(la, lb);
    assert_eq!(la.t, 7.0);
}

/// `flow` stepped from `x` by whole seconds to 3 s, its memory saved, then on to 7 s twice: as
/// it is, and from the restored memory and the state at 3 s, `between` called on the restored
/// flow (and that state) before it runs on. The two ends with their ledgers.
pub(crate) fn continued_twice(
    flow: &mut Adaptive,
    mut x: V,
    between: impl FnOnce(&mut Adaptive, &V),
) -> ((V, Ledger<f64>), (V, Ledger<f64>)) {
    let mut ledger = Ledger::at(0.0);
    for _ in 0..3 {
        flow.step_at(&mut ledger, 1.0, &mut x).unwrap();
    }
    assert_eq!(ledger.t, 3.0);
    let mut memory = Vec::new();
    flow.save_memory(&mut memory);
    let (saved, saved_ledger) = (x, ledger);
    let run_on = |flow: &mut Adaptive, mut x: V, mut l: Ledger<f64>| {
        for _ in 0..4 {
            flow.step_at(&mut l, 1.0, &mut x).unwrap();
        }
        (x, l)
    };
    let first = run_on(flow, x, ledger);
    let mut from = memory.as_slice();
    flow.restore_memory(&mut from);
    assert!(from.is_empty());
    between(flow, &saved);
    (first, run_on(flow, saved, saved_ledger))
}

#[test]
fn a_report_interval_the_proposal_spans_is_one_step() {
    // Steps to every 0.01 s with `h_max = 0.01` (a scene's report interval and its default
    // longest step), 1 s in all: the controller proposes more than 0.01 after its first step,
    // so each interval is one accepted step of 0.01 — not two halves of the ladder's rung
    // 2^{-6.75} = 0.0093 just below it — and the state agrees with a run in steps of 0.1
    // (its own h_max) within a few tolerances.
    let run = |interval: f64| {
        let mut options = AdaptiveOptions::new(Tolerances::new(1e-8, 1e-8).unwrap());
        options.h_max = Some(interval);
        let (mut flow, mut x) = adaptive_with(options);
        let mut ledger = Ledger::at(0.0);
        let n = (1.0 / interval).round() as usize;
        for _ in 0..n {
            flow.step_at(&mut ledger, interval, &mut x).unwrap();
        }
        (x, flow.adaptive_stats().unwrap())
    };
    let (x, fine) = run(0.01);
    let (y, _) = run(0.1);
    // The first step is estimated (below 0.01: no interval holds two), every later one
    // reaches its interval's end.
    assert_eq!(fine.accepted, 100, "{fine:?}");
    assert_eq!(fine.rejected, 0);
    assert!(fine.largest == 0.01, "{fine:?}");
    let gap = (0..4).map(|i| (x[i] - y[i]).abs()).fold(0.0, f64::max);
    assert!(gap <= 1e2 * 1e-8, "{gap:e}");
}

/// A base step that fails (a Newton failure, say) on sub-steps longer than `limit`.
struct Fussy<F> {
    inner: F,
    limit: f64,
    longest: f64,
}

impl<F: Flow<V>> Flow<V> for Fussy<F> {
    fn step(&mut self, h: f64, x: &mut V) -> Result<(), StepError> {
        self.step_at(&mut Ledger::default(), h, x)
    }
    fn step_at(&mut self, l: &mut Ledger<f64>, h: f64, x: &mut V) -> Result<(), StepError> {
        if h > self.limit {
            return Err(StepError::BadStepSize { h });
        }
        self.longest = self.longest.max(h);
        self.inner.step_at(l, h, x)
    }
    fn order(&self) -> u32 {
        2
    }
    fn is_symmetric(&self) -> bool {
        true
    }
    fn save_memory(&mut self, out: &mut Vec<f64>) {
        self.inner.save_memory(out)
    }
    fn restore_memory(&mut self, from: &mut &[f64]) {
        self.inner.restore_memory(from)
    }
}

#[test]
fn a_failing_sub_step_halves_the_step_and_a_step_below_h_min_fails_by_name() {
    let m = model();
    let x0: V = m.state(THETA0, 0.0);
    let fussy = |limit: f64| Fussy {
        inner: base(&m, &x0),
        limit,
        longest: 0.0,
    };
    let options = AdaptiveOptions::new(Tolerances::new(1e-8, 1e-8).unwrap());
    // Sub-steps longer than 0.02 fail: the macro step halves until its rows fit, and the run
    // ends on time with no sub-step past the limit.
    let mut flow = AdaptiveExtrapolation::try_new(fussy(0.02), (), options.clone()).unwrap();
    let mut x = x0;
    flow.step(2.0, &mut x).unwrap();
    let s = flow.adaptive_stats().expect("an adaptive flow");
    assert!(s.failed > 0 && s.accepted > 0, "{s:?}");
    assert!(flow.base().longest <= 0.02);
    // With h_min = 0.5 the same limit cannot be met: the call fails, names the time and the
    // cause, and leaves the state, the ledger and the memory as they were.
    let mut options = options;
    options.h_min = 0.5;
    let mut flow = AdaptiveExtrapolation::try_new(fussy(0.02), (), options).unwrap();
    let mut x = x0;
    let mut ledger = Ledger::at(3.0);
    let mut before = Vec::new();
    flow.save_memory(&mut before);
    let e = flow.step_at(&mut ledger, 2.0, &mut x).unwrap_err();
    let text = e.to_string();
    assert!(
        matches!(e, StepError::StepSizeTooSmall { t, .. } if t == 3.0),
        "{text}"
    );
    assert!(text.contains("t = 3") && text.contains("h_min"), "{text}");
    assert_eq!(x, x0);
    assert_eq!(ledger, Ledger::at(3.0));
    let mut after = Vec::new();
    flow.save_memory(&mut after);
    assert_eq!(before, after);
}

#[test]
fn what_cannot_be_controlled_is_refused() {
    let m = model();
    let x0: V = m.state(THETA0, 0.0);
    let options = || AdaptiveOptions::new(Tolerances::new(1e-8, 1e-8).unwrap());
    // A non-symmetric base: its error does not expand in h².
    let lie = FlowExt::<V>::then(m.free_flow().unwrap(), m.free_flow().unwrap());
    let Err(e) = AdaptiveExtrapolation::try_new(lie, (), options()) else {
        panic!("accepted")
    };
    assert!(e.to_string().contains("symmetric"), "{e}");
    let mut odd = options();
    odd.max_order = 7;
    let Err(e) = AdaptiveExtrapolation::try_new(base(&m, &x0), (), odd) else {
        panic!("accepted")
    };
    assert!(e.to_string().contains("max_order"), "{e}");
    let mut bad = options();
    bad.h_max = Some(0.0);
    assert!(AdaptiveExtrapolation::try_new(base(&m, &x0), (), bad).is_err());
}
