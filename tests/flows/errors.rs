//! Every failure is a typed error that says what and where, and leaves no NaN behind.

use lieflow::error::{IntegrateError, NewtonError, SetupError, StepError};
use lieflow::models::{SphericalPendulum, paper};
use lieflow::nonlinear::{JacobianUpdate, NewtonOptions};
use lieflow::prelude::*;
use lieflow::system::Constant;
use nalgebra::SVector;

type V4 = SVector<f64, 4>;
type V6 = SVector<f64, 6>;

fn assert_send_sync_static<T: Send + Sync + 'static + std::error::Error>() {}

#[test]
fn errors_are_send_sync_static() {
    assert_send_sync_static::<lieflow::LinearSolveError>();
    assert_send_sync_static::<NewtonError>();
    assert_send_sync_static::<StepError>();
    assert_send_sync_static::<SetupError>();
    assert_send_sync_static::<IntegrateError>();
}

#[test]
fn newton_failure_is_reported_and_the_state_is_kept() {
    let x0: V4 = paper::initial_state();
    let newton = NewtonOptions::default()
        .with_max_iterations(1)
        .with_jacobian(JacobianUpdate::EveryIteration);
    let mut f = paper::drift()
        .projected(
            paper::system(),
            &x0,
            ProjectionOptions::default().with_newton(newton),
        )
        .unwrap();
    let mut x = x0;
    let err = f.step(0.1, &mut x).unwrap_err();
    match &err {
        StepError::Newton {
            stage,
            source:
                NewtonError::NotConverged {
                    iterations,
                    residual,
                },
        } => {
            assert!(stage.contains("lambda_k"), "{stage}");
            assert_eq!(*iterations, 1);
            assert!(*residual > 0.0 && residual.is_finite());
        }
        other => panic!("unexpected error {other:?}"),
    }
    assert!(err.to_string().contains("did not converge"), "{err}");
    assert_eq!(x, x0, "the state must be unchanged after a failed step");

    // Through the driver: the step index and time are named.
    let mut x = x0;
    let e = integrate(&mut f, &mut x, 0.0, 0.1, 10, &mut ()).unwrap_err();
    assert!(matches!(e, IntegrateError::Step { step: 0, .. }), "{e:?}");
    assert_eq!(x, x0);
}

/// `M` with a zero last row and column: `x₃` is a Casimir, so `g = x₃ − ½` is already invariant.
#[test]
fn a_constraint_that_is_a_casimir_is_refused() {
    struct Plane;
    impl HolonomicConstraint<SVector<f64, 3>> for Plane {
        fn dim(&self) -> usize {
            1
        }
        fn residual(&self, x: &SVector<f64, 3>, out: &mut [f64]) {
            out[0] = x[2] - 0.5;
        }
        fn jacobian_apply(&self, _x: &SVector<f64, 3>, v: &SVector<f64, 3>, out: &mut [f64]) {
            out[0] = v[2];
        }
        fn jacobian_transpose_apply_add(
            &self,
            _x: &SVector<f64, 3>,
            mu: &[f64],
            alpha: f64,
            out: &mut SVector<f64, 3>,
        ) {
            out[2] += alpha * mu[0];
        }
    }
    struct Quadratic;
    impl Hamiltonian<SVector<f64, 3>> for Quadratic {
        fn energy(&self, x: &SVector<f64, 3>) -> f64 {
            0.5 * x.norm_squared()
        }
        fn gradient(&self, x: &SVector<f64, 3>, out: &mut SVector<f64, 3>) {
            *out = *x;
        }
    }
    let m = Constant::from_rows(&[[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 0.0]]);
    let x0 = SVector::<f64, 3>::new(1.0, 0.0, 0.5);
    let id = from_fn(|_h: f64, _x: &mut SVector<f64, 3>| {});
    let err = id
        .projected(
            System::new(m, Quadratic, Plane),
            &x0,
            ProjectionOptions::default(),
        )
        .unwrap_err();
    assert!(
        matches!(
            err,
            SetupError::SingularMultiplierMatrix {
                bracket: "<phi,g>",
                ..
            }
        ),
        "{err:?}"
    );
    assert!(err.to_string().contains("Casimir"), "{err}");
}

/// The same sphere constraint twice: `⟨φ, g⟩` has rank 1.
#[test]
fn redundant_constraints_are_refused() {
    struct Twice<C>(C);
    impl<C: HolonomicConstraint<V6>> HolonomicConstraint<V6> for Twice<C> {
        fn dim(&self) -> usize {
            2
        }
        fn residual(&self, x: &V6, out: &mut [f64]) {
            self.0.residual(x, &mut out[..1]);
            self.0.residual(x, &mut out[1..]);
        }
        fn jacobian_apply(&self, x: &V6, v: &V6, out: &mut [f64]) {
            self.0.jacobian_apply(x, v, &mut out[..1]);
            self.0.jacobian_apply(x, v, &mut out[1..]);
        }
        fn jacobian_transpose_apply_add(&self, x: &V6, mu: &[f64], alpha: f64, out: &mut V6) {
            self.0.jacobian_transpose_apply_add(x, &mu[..1], alpha, out);
            self.0.jacobian_transpose_apply_add(x, &mu[1..], alpha, out);
        }
    }
    let model = SphericalPendulum::try_new(1.0, 1.0, 9.81).unwrap();
    let x0: V6 = model.state(1.0, 1.0);
    let s = model.system();
    let sys = System::new(s.structure, s.hamiltonian, Twice(s.constraint));
    let err = model
        .kick()
        .strang(model.drift())
        .projected(sys, &x0, ProjectionOptions::default())
        .unwrap_err();
    match err {
        SetupError::SingularMultiplierMatrix {
            bracket,
            pivot,
            ratio,
        } => {
            assert_eq!(bracket, "<phi,g>");
            assert_eq!(pivot, 1);
            assert!(ratio < 1e-8, "{ratio:e}");
        }
        other => panic!("unexpected {other:?}"),
    }
}

#[test]
fn non_finite_states_are_refused_where_they_enter() {
    let mut bad: V4 = paper::initial_state();
    bad[3] = f64::NAN;
    let err = paper::drift()
        .projected(paper::system(), &bad, ProjectionOptions::default())
        .unwrap_err();
    assert_eq!(err, SetupError::NonFiniteState { component: 3 });

    let x0: V4 = paper::initial_state();
    let mut f = paper::drift()
        .projected(paper::system(), &x0, ProjectionOptions::default())
        .unwrap();
    let mut x = bad;
    x[3] = f64::INFINITY;
    let before = x;
    assert_eq!(
        f.step(0.1, &mut x),
        Err(StepError::NonFinite { component: 3 })
    );
    assert_eq!(x[3], before[3]);
    assert!(matches!(
        f.step(f64::NAN, &mut x0.clone()),
        Err(StepError::BadStepSize { .. })
    ));

    let mut x = bad;
    assert_eq!(
        integrate(&mut f, &mut x, 0.0, 0.1, 10, &mut ()).unwrap_err(),
        IntegrateError::NonFiniteInitialState { component: 3 }
    );
}

#[test]
fn a_flow_that_blows_up_is_stopped_with_the_last_good_state() {
    // A closed-form flow cannot report failure itself; the driver catches the NaN it makes.
    let mut calls = 0;
    let mut flow = from_fn(move |h: f64, x: &mut V4| {
        calls += 1;
        x[0] += h;
        if calls == 5 {
            x[1] = f64::NAN;
        }
    });
    let mut x: V4 = paper::initial_state();
    let err = integrate(&mut flow, &mut x, 0.0, 0.5, 10, &mut ()).unwrap_err();
    match err {
        IntegrateError::Step { step, t, source } => {
            assert_eq!(step, 4);
            assert!((t - 2.0).abs() < 1e-15);
            assert_eq!(source, StepError::NonFinite { component: 1 });
        }
        other => panic!("unexpected {other:?}"),
    }
    assert!(
        x.iter().all(|v| v.is_finite()),
        "state left with NaN: {x:?}"
    );
    assert!(
        (x[0] - 3.0).abs() < 1e-15,
        "state is the one at t = 2: {x:?}"
    );
}

/// Fails on negative step sizes, steps the inner flow otherwise.
struct ForwardOnly<F>(F);
impl<F: Flow<V4>> Flow<V4> for ForwardOnly<F> {
    fn step(&mut self, h: f64, x: &mut V4) -> Result<(), StepError> {
        if h < 0.0 {
            return Err(StepError::BadStepSize { h });
        }
        self.0.step(h, x)
    }
    fn order(&self) -> u32 {
        self.0.order()
    }
    fn is_symmetric(&self) -> bool {
        self.0.is_symmetric()
    }
}

#[test]
fn a_failing_stage_inside_a_composition_restores_the_state() {
    // Stage 1 of the triple jump (γ₁ > 0) succeeds and moves x; stage 2 (γ₂ < 0) fails.
    let x0: V4 = paper::initial_state();
    let projected = paper::drift()
        .projected(paper::system(), &x0, ProjectionOptions::default())
        .unwrap();
    let mut f = ForwardOnly(projected).triple_jump();
    let mut x = x0;
    let err = f.step(0.1, &mut x).unwrap_err();
    assert!(
        matches!(err, StepError::BadStepSize { h } if h < 0.0),
        "{err:?}"
    );
    assert_eq!(
        x, x0,
        "the composition must restore the state after stage 1 moved it"
    );
}

/// Counts its steps and fails once, at call number `fail_at`.
struct Flaky<F> {
    inner: F,
    fail_at: std::rc::Rc<std::cell::Cell<u32>>,
    calls: std::rc::Rc<std::cell::Cell<u32>>,
}
impl<F: Flow<V4>> Flow<V4> for Flaky<F> {
    fn step(&mut self, h: f64, x: &mut V4) -> Result<(), StepError> {
        self.calls.set(self.calls.get() + 1);
        if self.calls.get() == self.fail_at.get() {
            return Err(StepError::NonFinite { component: 0 });
        }
        self.inner.step(h, x)
    }
    fn order(&self) -> u32 {
        self.inner.order()
    }
    fn is_symmetric(&self) -> bool {
        self.inner.is_symmetric()
    }
}

#[test]
fn a_failed_step_does_not_poison_the_next_ones() {
    use std::cell::Cell;
    use std::rc::Rc;
    // The inner flow fails while Newton iterates on λ_k (its second residual), once.
    let fail_at = Rc::new(Cell::new(u32::MAX));
    let calls = Rc::new(Cell::new(0u32));
    let x0: V4 = paper::initial_state();
    let flaky = Flaky {
        inner: paper::drift(),
        fail_at: fail_at.clone(),
        calls: calls.clone(),
    };
    let mut f = flaky
        .projected(paper::system(), &x0, ProjectionOptions::default())
        .unwrap();
    let mut reference = paper::drift()
        .projected(paper::system(), &x0, ProjectionOptions::default())
        .unwrap();
    let (mut x, mut xr) = (x0, x0);
    for k in 0..200 {
        if k == 50 {
            fail_at.set(calls.get() + 2);
            let before = x;
            assert!(f.step(0.1, &mut x).is_err());
            assert_eq!(x, before);
        }
        f.step(0.1, &mut x).unwrap();
        reference.step(0.1, &mut xr).unwrap();
    }
    let d = (x - xr).amax();
    assert!(
        d <= 1e-13,
        "after a failed step the trajectory differs by {d:e}"
    );
}

#[test]
fn an_initial_state_off_the_manifold_is_refused() {
    let mut x: V4 = paper::initial_state();
    x[0] = 1.1;
    let err = paper::drift()
        .projected(paper::system(), &x, ProjectionOptions::default())
        .unwrap_err();
    assert!(
        matches!(err, SetupError::OffManifold { what: "g", .. }),
        "{err:?}"
    );
    let mut x: V4 = paper::initial_state();
    x[2] = 0.1; // φ = x₁x₃ + x₂x₄ = 0.1
    let err = paper::drift()
        .projected(paper::system(), &x, ProjectionOptions::default())
        .unwrap_err();
    assert!(
        matches!(err, SetupError::OffManifold { what: "phi", .. }),
        "{err:?}"
    );
    // Asked to skip the check, the first step projects onto g = 0, φ = 0.
    let mut f = paper::drift()
        .projected(
            paper::system(),
            &x,
            ProjectionOptions::default().with_manifold_tol(None),
        )
        .unwrap();
    f.step(0.1, &mut x).unwrap();
    let phi = x[0] * x[2] + x[1] * x[3];
    let g = 0.5 * (x[0] * x[0] + x[1] * x[1] - 1.0);
    assert!(g.abs() < 1e-14 && phi.abs() < 1e-14);
}
