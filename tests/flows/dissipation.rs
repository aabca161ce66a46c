//! Negative sub-steps on dissipative flows: refused with a typed error unless explicitly allowed.
//!
//! Model: the damped oscillator `q' = p, p' = −q − c p` (`H = (q² + p²)/2`, `M = J − R`,
//! `R = diag(0, c)`), split into the exact rotation of `H` and the exact damping flow
//! `p ← e^{−ch} p`. With `c = 1e6` and `h = 0.1` a backward damping sub-step multiplies `p` by
//! `e^{+1.7e5}`: infinity.

use lieflow::error::{IntegrateError, StepError};
use lieflow::prelude::*;
use nalgebra::SVector;

type V = SVector<f64, 2>;
const C: f64 = 1e6;

fn rotation() -> impl Flow<V> + Clone {
    from_fn(|h: f64, x: &mut V| {
        let (s, c) = h.sin_cos();
        *x = V::new(c * x[0] + s * x[1], -s * x[0] + c * x[1]);
    })
}

fn damping() -> impl Flow<V> + Clone {
    from_fn(|h: f64, x: &mut V| x[1] *= (-C * h).exp()).dissipative()
}

fn energy(x: &V) -> f64 {
    0.5 * x.norm_squared()
}

#[test]
fn strang_with_the_exact_damping_flow_decays_monotonically_under_stiff_damping() {
    let mut flow = damping().strang(rotation());
    assert!(flow.dissipates());
    let mut x = V::new(1.0, 0.5);
    let mut e = energy(&x);
    for _ in 0..1000 {
        flow.step(0.1, &mut x).unwrap();
        let e_new = energy(&x);
        assert!(
            e_new.is_finite() && e_new <= e,
            "energy went up: {e} -> {e_new}"
        );
        e = e_new;
    }
}

#[test]
fn a_triple_jump_on_a_dissipative_flow_is_refused() {
    let mut flow = damping().strang(rotation()).triple_jump();
    let x0 = V::new(1.0, 0.5);
    let mut x = x0;
    match flow.step(0.1, &mut x) {
        Err(StepError::BackwardDissipation {
            table,
            stage,
            gamma,
        }) => {
            assert_eq!(table, "triple-jump");
            assert_eq!(stage, 1);
            assert!(gamma < 0.0);
        }
        other => panic!("expected BackwardDissipation, got {other:?}"),
    }
    assert_eq!(x, x0);
    // A conservative flow composes as before.
    let mut x = x0;
    rotation()
        .strang(rotation())
        .triple_jump()
        .step(0.1, &mut x)
        .unwrap();
}

#[test]
fn allowing_backward_dissipation_shows_why_it_is_refused() {
    let mut flow = damping()
        .strang(rotation())
        .triple_jump()
        .allow_backward_dissipation();
    let mut x = V::new(1.0, 0.5);
    let err = integrate(&mut flow, &mut x, 0.0, 0.1, 10, &mut ()).unwrap_err();
    assert!(
        matches!(
            err,
            IntegrateError::Step {
                step: 0,
                source: StepError::NonFinite { .. },
                ..
            }
        ),
        "{err:?}"
    );
    assert!(x.iter().all(|v| v.is_finite()));
}
