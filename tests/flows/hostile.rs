//! Hostile input: what a new user gets wrong — a state of the wrong length, a
//! duplicated constraint, bad model parameters, a state moved off the manifold between steps, a
//! damping part that is zero — gets a typed error that says what and where, and a failed step
//! leaves the state as it was.

use lieflow::error::{SetupError, StepError};
use lieflow::flow::ImplicitMidpoint;
use lieflow::models::{DampedPendulum, RigidBody, SphericalPendulum, SpringChain, paper};
use lieflow::nonlinear::NewtonOptions;
use lieflow::prelude::*;
use nalgebra::{DVector, SVector};

type V4 = SVector<f64, 4>;
type D = DVector<f64>;

#[test]
fn a_heap_state_of_the_wrong_length_is_a_typed_error_not_a_panic() {
    let x0: D = paper::initial_state();
    let mut projected = paper::drift()
        .projected(paper::system(), &x0, ProjectionOptions::default())
        .unwrap();
    let mut x = D::from_element(5, 0.1);
    let before = x.clone();
    assert_eq!(
        projected.step(0.1, &mut x),
        Err(StepError::StateLength {
            flow: "Projected",
            expected: 4,
            got: 5
        })
    );
    assert_eq!(x, before);

    let body = RigidBody::<f64>::gni();
    let y0: D = RigidBody::gni_initial_state();
    let mut midpoint =
        ImplicitMidpoint::<D, _, _>::try_new(body.structure(), body, &y0, NewtonOptions::default())
            .unwrap();
    let mut y = D::from_element(2, 1.0);
    assert!(
        matches!(
            midpoint.step(0.1, &mut y),
            Err(StepError::StateLength {
                expected: 3,
                got: 2,
                ..
            })
        ),
        "the implicit midpoint rule must refuse a state of length 2"
    );
    assert_eq!(y, D::from_element(2, 1.0));
}

/// `g = (x₁, x₃, x₁)` on canonical `R⁴`: `⟨g₁, g₂⟩ = e₁ᵀ J e₃ = 1`, so the case is
/// non-degenerate, and the third constraint repeats the first. Only the action of `G` is given
/// (no `jacobian_entries`): the bracket test must still name the redundant constraint.
#[test]
fn a_duplicated_constraint_without_jacobian_entries_is_named_as_redundant() {
    struct Repeated;
    impl HolonomicConstraint<V4> for Repeated {
        fn dim(&self) -> usize {
            3
        }
        fn residual(&self, x: &V4, out: &mut [f64]) {
            out.copy_from_slice(&[x[0], x[2], x[0]]);
        }
        fn jacobian_apply(&self, _x: &V4, v: &V4, out: &mut [f64]) {
            out.copy_from_slice(&[v[0], v[2], v[0]]);
        }
        fn jacobian_transpose_apply_add(&self, _x: &V4, mu: &[f64], alpha: f64, out: &mut V4) {
            out[0] += alpha * (mu[0] + mu[2]);
            out[2] += alpha * mu[1];
        }
    }
    struct Quadratic;
    impl Hamiltonian<V4> for Quadratic {
        fn energy(&self, x: &V4) -> f64 {
            0.5 * x.norm_squared()
        }
        fn gradient(&self, x: &V4, out: &mut V4) {
            *out = *x;
        }
    }
    let x0 = V4::new(0.0, 1.0, 0.0, 0.5);
    let sys = System::new(Canonical, Quadratic, Repeated);
    let err = from_fn(|_h: f64, _x: &mut V4| {})
        .projected(sys, &x0, ProjectionOptions::default())
        .unwrap_err();
    match err {
        SetupError::RankDeficient { constraint, ratio } => {
            assert_eq!(constraint, 2, "the repeat is the third constraint");
            assert!(ratio < 1e-12, "{ratio:e}");
        }
        other => panic!("expected RankDeficient, got {other:?}"),
    }
}

#[test]
fn bad_model_parameters_are_named() {
    let invalid = |e: SetupError| match e {
        SetupError::InvalidParameter { name, value, .. } => (name, value),
        other => panic!("expected InvalidParameter, got {other:?}"),
    };
    let (name, value) = invalid(SphericalPendulum::try_new(1.0, -2.0, 9.81).unwrap_err());
    assert_eq!((name.as_str(), value), ("length", -2.0));
    let (name, value) = invalid(SphericalPendulum::try_new(1.0, 1.0, -1.0).unwrap_err());
    assert_eq!((name.as_str(), value), ("gravity", -1.0));
    let (name, value) = invalid(RigidBody::try_new([1.0, f64::NAN, 2.0]).unwrap_err());
    assert_eq!(name, "moment of inertia 1");
    assert!(value.is_nan());
    let (name, value) = invalid(DampedPendulum::try_new(-0.5).unwrap_err());
    assert_eq!((name.as_str(), value), ("damping coefficient", -0.5));
    let (name, _) = invalid(SpringChain::try_new(0, 1.0, 0.0).unwrap_err());
    assert_eq!(name, "masses");
    let (name, value) = invalid(SpringChain::try_new(3, f64::INFINITY, 0.0).unwrap_err());
    assert_eq!((name.as_str(), value), ("stiffness", f64::INFINITY));
    let (name, _) = invalid(MomentumDamping::new(f64::NAN).unwrap_err());
    assert_eq!(name, "damping coefficient");
    let err = SphericalPendulum::try_new(0.0, 1.0, 9.81).unwrap_err();
    assert!(err.to_string().contains("mass = 0"), "{err}");
}

#[test]
fn a_state_moved_off_the_manifold_between_steps_is_refused_not_silently_projected() {
    let x0: V4 = paper::initial_state();
    let mut flow = paper::drift()
        .projected(paper::system(), &x0, ProjectionOptions::default())
        .unwrap();
    let mut x = x0;
    flow.step(0.1, &mut x).unwrap();
    // The caller moves the state: g = ½(x₁² + x₂² − 1) is now far from 0.
    x[0] += 0.3;
    let before = x;
    match flow.step(0.1, &mut x) {
        Err(StepError::OffManifold { what, residual, .. }) => {
            assert_eq!(what, "g");
            assert!(residual > 0.1, "{residual:e}");
        }
        other => panic!("expected OffManifold, got {other:?}"),
    }
    assert_eq!(x, before, "a refused step must leave the state");
    // A change within the tolerance (√ε) is a state on the manifold.
    x[0] -= 0.3;
    let on = x;
    let mut y = on;
    y[0] += 1e-12;
    flow.step(0.1, &mut y).unwrap();
    // The hidden constraint φ is checked too (the paper's case is degenerate).
    let mut z = on;
    z[2] += 0.05;
    assert!(matches!(
        flow.step(0.1, &mut z),
        Err(StepError::OffManifold { what: "phi", .. })
    ));
    // Explicitly allowed, the step projects the state back.
    let mut lenient = paper::drift()
        .projected(
            paper::system(),
            &x0,
            ProjectionOptions::default().with_manifold_tol(None),
        )
        .unwrap();
    let mut w = before;
    lenient.step(0.1, &mut w).unwrap();
    assert!((0.5 * (w[0] * w[0] + w[1] * w[1] - 1.0)).abs() < 1e-14);
}

#[test]
fn a_zero_damping_part_is_not_dissipative() {
    type Damped = JMinusR<Canonical, MomentumDamping<f64>>;
    let zero: Damped = JMinusR::new(Canonical, MomentumDamping::new(0.0).unwrap());
    let some: Damped = JMinusR::new(Canonical, MomentumDamping::new(0.1).unwrap());
    assert!(!StructureMatrix::<V4>::is_dissipative(&zero));
    assert!(StructureMatrix::<V4>::is_dissipative(&some));
    let rotation = Constant::from_rows(&[[0.0, 1.0], [-1.0, 0.0]]);
    let friction = Constant::from_rows(&[[0.0, 1.0], [-1.0, -0.2]]);
    let nothing = Constant::from_rows(&[[0.0; 2]; 2]);
    type V2 = SVector<f64, 2>;
    assert!(!StructureMatrix::<V2>::is_dissipative(&rotation));
    assert!(StructureMatrix::<V2>::is_dissipative(&friction));
    assert!(!StructureMatrix::<V2>::is_dissipative(&JMinusR::new(
        rotation.clone(),
        nothing
    )));
    assert!(StructureMatrix::<V2>::is_dissipative(&JMinusR::new(
        rotation.clone(),
        rotation
    )));
    // An indefinite symmetric part (the paper's matrix) is not dissipation, nor is an
    // energy-creating one.
    let paper = Constant::from_rows(&[
        [0.0, 0.0, 1.0, 0.0],
        [0.0, 0.0, 0.0, 1.0],
        [-1.0, 0.0, 0.0, 0.0],
        [0.0, -2.0, 0.0, 0.0],
    ]);
    assert!(!StructureMatrix::<V4>::is_dissipative(&paper));
    let pumping = Constant::from_rows(&[[0.0, 1.0], [-1.0, 0.2]]);
    assert!(!StructureMatrix::<V2>::is_dissipative(&pumping));

    // The undamped "damped" pendulum composes to order 4 with backward sub-steps.
    let model = DampedPendulum::try_new(0.0).unwrap();
    let x0 = V4::new(1.0, 0.0, 0.0, 0.0);
    let mut tj = model
        .free_flow()
        .unwrap()
        .projected(model.system(), &x0, ProjectionOptions::default())
        .unwrap()
        .triple_jump();
    let mut x = x0;
    for _ in 0..10 {
        tj.step(0.05, &mut x).unwrap();
    }
    assert!((x[0] * x[0] + x[1] * x[1] - 1.0).abs() < 1e-13);
}
