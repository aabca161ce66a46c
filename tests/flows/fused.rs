//! A composition of a decoupled projection runs its stages fused (one multiplier solve per
//! stage: the second half-step of a stage and the first of the next act along the same
//! direction and combine). It must be the same map as the stage-by-stage composition, keep the
//! constraints at round-off, stay symmetric, and leave the state unchanged when a stage fails.

use lieflow::flow::CompositionTable;
use lieflow::flow::coefficients::{KAHAN_LI8, TRIPLE_JUMP, YOSHIDA6};
use lieflow::models::{PendulumChain, paper};
use lieflow::prelude::*;
use nalgebra::SVector;

use crate::common;

type V = SVector<f64, 4>;

use common::PaperNoHessian as NoHessian;

/// The stage-by-stage composition: `step(γ_i h)` on the projected flow itself.
fn staged<F: Flow<V>>(flow: &mut F, table: &CompositionTable, h: f64, x: &mut V) {
    for i in 0..table.stages {
        flow.step(table.gamma(i) * h, x).unwrap();
    }
}

fn compare<H: Hamiltonian<V>>(make: impl Fn() -> H, table: &'static CompositionTable) -> f64 {
    let x0: V = paper::initial_state();
    let build = || {
        paper::drift()
            .projected(
                System::new(paper::Structure, make(), paper::Circle),
                &x0,
                ProjectionOptions::default(),
            )
            .unwrap()
    };
    let mut fused = build().composed(table);
    let mut by_stage = build();
    let (mut a, mut b) = (x0, x0);
    let (mut max_g, mut max_phi) = (0.0f64, 0.0f64);
    for _ in 0..500 {
        fused.step(0.1, &mut a).unwrap();
        staged(&mut by_stage, table, 0.1, &mut b);
        max_g = max_g.max((0.5 * (a[0] * a[0] + a[1] * a[1] - 1.0)).abs());
        max_phi = max_phi.max((a[0] * a[2] + a[1] * a[3]).abs());
    }
    // Round-off, at most Newton's noise floor (100 ftol, ftol = 2ε).
    assert!(
        max_g <= 200.0 * f64::EPSILON,
        "{}: |g| {max_g:e}",
        table.name
    );
    assert!(
        max_phi <= 200.0 * f64::EPSILON,
        "{}: |phi| {max_phi:e}",
        table.name
    );
    // One multiplier solve per stage plus the last stage's λ_{k+1}.
    let s = fused.stats();
    assert_eq!(s.projected_steps, 500 * table.stages as u64);
    assert_eq!(s.newton_solves, 500 * (table.stages as u64 + 1), "{s:?}");
    (a - b).amax()
}

#[test]
fn fused_composition_is_the_stage_by_stage_map() {
    // The two differ by where Newton stops (|g| ≤ 2ε per solve, on different unknowns): the
    // difference stays at round-off accumulated over 500 steps of a non-chaotic trajectory.
    for table in [&TRIPLE_JUMP, &YOSHIDA6, &KAHAN_LI8] {
        let small = compare(|| paper::Energy, table);
        let general = compare(|| NoHessian, table);
        println!(
            "{}: small path {small:.1e}, general path {general:.1e}",
            table.name
        );
        assert!(
            small < 1e-12,
            "{}: small path differs by {small:e}",
            table.name
        );
        assert!(
            general < 1e-12,
            "{}: general path differs by {general:e}",
            table.name
        );
    }
}

#[test]
fn fused_composition_is_symmetric() {
    let x0: V = paper::initial_state();
    let mut flow = paper::drift()
        .projected(paper::system(), &x0, ProjectionOptions::default())
        .unwrap()
        .composed(&KAHAN_LI8);
    let mut x = x0;
    for _ in 0..10 {
        flow.step(0.3, &mut x).unwrap();
    }
    for _ in 0..10 {
        flow.step(-0.3, &mut x).unwrap();
    }
    let d = (x - x0).amax();
    // Each step is symmetric up to the Newton tolerance: 20 steps of 17 stages, ~1e-15 each.
    assert!(d < 1e-13, "back and forth differs by {d:e}");
}

/// A drift that fails on its `fail_at`-th call (1-based), to break a composition mid-way.
struct FailingDrift {
    calls: usize,
    fail_at: usize,
}

impl Flow<V> for FailingDrift {
    fn step(&mut self, h: f64, x: &mut V) -> Result<(), StepError> {
        self.calls += 1;
        if self.calls == self.fail_at {
            return Err(StepError::BadStepSize { h });
        }
        x[0] += h * x[2];
        x[1] += h * x[3];
        Ok(())
    }
    fn order(&self) -> u32 {
        lieflow::flow::EXACT
    }
    fn is_symmetric(&self) -> bool {
        true
    }
}

#[test]
fn a_failed_stage_leaves_the_state_unchanged() {
    let x0: V = paper::initial_state();
    // The 10th inner step is in the middle of the first composed step (17 stages, each
    // evaluating the inner flow about twice).
    let mut flow = FailingDrift {
        calls: 0,
        fail_at: 10,
    }
    .projected(paper::system(), &x0, ProjectionOptions::default())
    .unwrap()
    .composed(&KAHAN_LI8);
    let mut x = x0;
    let err = flow.step(0.1, &mut x).unwrap_err();
    assert!(matches!(err, StepError::BadStepSize { .. }), "{err:?}");
    assert_eq!(x, x0, "a failed composed step must not move the state");
    assert_eq!(flow.stats().projected_steps, 0);
    // The next step works and stays on the manifold.
    flow.step(0.1, &mut x).unwrap();
    assert!((0.5 * (x[0] * x[0] + x[1] * x[1] - 1.0)).abs() <= 200.0 * f64::EPSILON);
}

#[test]
fn fused_chain_composition_matches_stage_by_stage() {
    // The general (banded) path on a chain of 50 links, triple jump of RATTLE.
    type W = faer::Col<f64>;
    let model = PendulumChain::<f64>::uniform(2, 50).unwrap();
    let x0: W = model.at_rest(|i| 0.5 + 0.1 * (i as f64 * 0.3).sin());
    let build = || {
        model
            .kick::<W>()
            .strang(model.drift())
            .projected(model.system(), &x0, model.projection_options())
            .unwrap()
    };
    let mut fused = build().composed(&TRIPLE_JUMP);
    let mut by_stage = build();
    let (mut a, mut b) = (x0.clone(), x0.clone());
    let h = 1e-3;
    for _ in 0..50 {
        fused.step(h, &mut a).unwrap();
        for i in 0..TRIPLE_JUMP.stages {
            by_stage.step(TRIPLE_JUMP.gamma(i) * h, &mut b).unwrap();
        }
    }
    let d = a
        .as_slice()
        .iter()
        .zip(b.as_slice())
        .fold(0.0f64, |m, (u, v)| m.max((u - v).abs()));
    // Newton stops at ftol = 16 ε l L per solve; the maps agree to that over 50 steps.
    assert!(
        d < 1e-12,
        "fused and staged chain compositions differ by {d:e}"
    );
    let sys = model.system();
    let mut g = vec![0.0; model.constraints()];
    sys.constraint.residual(&a, &mut g);
    let max_g = g.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(max_g < 1e-15, "|g| = {max_g:e}");
}
