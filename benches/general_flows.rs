//! What generality costs: ns/step of the general implicit flows against a closed-form splitting
//! on a model where both apply — the free rigid body (Lie–Poisson). `H = Σ yᵢ²/(2Iᵢ)` splits
//! into three sub-Hamiltonians whose flows are exact rotations about the body axes; their Strang
//! composition is symmetric, order 2, and conserves the Casimir exactly (but not the energy).
//! The implicit midpoint rule and the discrete gradient conserve both, at the price of a Newton
//! solve per step. Second group: the damped pendulum (constrained, dissipative), projection
//! around the exact affine flow against the constrained discrete gradient, beside the
//! hand-written index-1 right-hand side an explicit peer evaluates instead. Third group: the
//! projected implicit midpoint rule on planar pendulum chains of 4, 5, 8 and 20 links, as one
//! Newton system (`ProjectedMidpoint`: its small path for 4 constraints, its general path
//! above) against the nested form (`Projected` around `ImplicitMidpoint`), the same map.
//!
//! ```text
//! cargo bench --bench general_flows
//! ```

use criterion::{Criterion, criterion_group, criterion_main};
use faer::Col;
use lieflow::flow::{ConstrainedDiscreteGradient, DiscreteGradient, ImplicitMidpoint};
use lieflow::models::{DampedPendulum, PendulumChain, RigidBody};
use lieflow::nonlinear::NewtonOptions;
use lieflow::prelude::*;
use nalgebra::SVector;
use std::hint::black_box;

type V = SVector<f64, 3>;
type V4 = SVector<f64, 4>;

/// The exact flow of `H_i = y_i²/(2 I_i)`: a rotation of the other two components by
/// the angle `h y_i / I_i` (`y' = y × ∇H_i`).
fn rotation(axis: usize, inertia: f64) -> impl Flow<V> + Clone {
    from_fn(move |h: f64, y: &mut V| {
        let (j, k) = ((axis + 1) % 3, (axis + 2) % 3);
        let (s, c) = (h * y[axis] / inertia).sin_cos();
        let (yj, yk) = (y[j], y[k]);
        y[j] = c * yj + s * yk;
        y[k] = -s * yj + c * yk;
    })
}

fn bench(c: &mut Criterion) {
    let body = RigidBody::<f64>::gni();
    let i = body.inertia;
    let y0: V = RigidBody::gni_initial_state();
    let h = 0.1;
    let mut group = c.benchmark_group("rigid_body_step");

    let mut split = rotation(0, i[0]).strang(rotation(1, i[1]).strang(rotation(2, i[2])));
    let mut y = y0;
    group.bench_function("splitting_exact_rotations", |b| {
        b.iter(|| split.step(black_box(h), &mut y).unwrap())
    });

    let mut mid =
        ImplicitMidpoint::<V, _, _>::try_new(body.structure(), body, &y0, NewtonOptions::default())
            .unwrap();
    let mut y = y0;
    group.bench_function("implicit_midpoint", |b| {
        b.iter(|| mid.step(black_box(h), &mut y).unwrap())
    });

    let mut dg =
        DiscreteGradient::<V, _, _>::try_new(body.structure(), body, &y0, NewtonOptions::default())
            .unwrap();
    let mut y = y0;
    group.bench_function("discrete_gradient", |b| {
        b.iter(|| dg.step(black_box(h), &mut y).unwrap())
    });
    group.finish();

    // The damped pendulum (constrained, M = J − R): projection around the exact affine flow of
    // the free damped particle against the constrained discrete gradient. Each iteration runs
    // 100 steps of h = 0.1 from the same state (so the pendulum does not come to rest).
    let model = DampedPendulum::try_new(0.1).unwrap();
    let x0: V4 = model.state(std::f64::consts::FRAC_PI_2, 0.0);
    let mut group = c.benchmark_group("damped_pendulum_100_steps");
    let mut proj = model
        .free_flow()
        .unwrap()
        .projected(model.system(), &x0, ProjectionOptions::default())
        .unwrap();
    group.bench_function("projection_exact_linear_flow", |b| {
        b.iter(|| {
            let mut x = x0;
            for _ in 0..100 {
                proj.step(black_box(h), &mut x).unwrap();
            }
            x
        })
    });
    // What a projected step replaces in an explicit integrator: the hand-written index-1
    // right-hand side (the multiplier in closed form from d/dt (q·p) = 0), a DOP853 stage's
    // evaluation, 100 times from states along the same swing.
    let index1 = |x: &V4, c: f64| {
        let mu = (x[2] * x[2] + x[3] * x[3] - x[1]) / (x[0] * x[0] + x[1] * x[1]);
        V4::new(
            x[2],
            x[3],
            -x[0] * mu - c * x[2],
            -1.0 - x[1] * mu - c * x[3],
        )
    };
    group.bench_function("index1_right_hand_side_baseline", |b| {
        b.iter(|| {
            let mut x = x0;
            let mut acc = V4::zeros();
            for _ in 0..100 {
                let f = index1(black_box(&x), model.damping);
                acc += f;
                x[2] += 1e-3 * f[2];
            }
            acc
        })
    });
    let mut cdg: ConstrainedDiscreteGradient<V4, _, Col<f64>> =
        ConstrainedDiscreteGradient::try_new(model.system(), &x0, ProjectionOptions::default())
            .unwrap();
    group.bench_function("constrained_discrete_gradient", |b| {
        b.iter(|| {
            let mut x = x0;
            for _ in 0..100 {
                cdg.step(black_box(h), &mut x).unwrap();
            }
            x
        })
    });
    group.finish();

    // The projected implicit midpoint rule on chains (n = 4 links, m = links), h = 0.01: 100
    // steps per iteration from the same state.
    let mut group = c.benchmark_group("chain_projected_midpoint_100_steps");
    for links in [4, 5, 8, 20] {
        let chain = PendulumChain::<f64>::uniform(2, links).unwrap();
        let x0: Col<f64> = chain.at_rest(|i| 0.4 + 0.3 * i as f64);
        let options = chain.projection_options();
        let mut joint: ProjectedMidpoint<Col<f64>, _, _> =
            ProjectedMidpoint::try_new(chain.system(), chain.clone(), &x0, options).unwrap();
        let midpoint: ImplicitMidpoint<Col<f64>, _, _> = ImplicitMidpoint::try_new(
            chain.system().structure,
            chain.clone(),
            &x0,
            NewtonOptions::default(),
        )
        .unwrap();
        let mut nested = midpoint.projected(chain.system(), &x0, options).unwrap();
        let run = |flow: &mut dyn Flow<Col<f64>>| {
            let mut x = x0.clone();
            for _ in 0..100 {
                flow.step(black_box(0.01), &mut x).unwrap();
            }
            x
        };
        group.bench_function(format!("joint_{links}_links"), |b| {
            b.iter(|| run(&mut joint))
        });
        group.bench_function(format!("nested_{links}_links"), |b| {
            b.iter(|| run(&mut nested))
        });
    }
    group.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .warm_up_time(std::time::Duration::from_millis(500))
        .measurement_time(std::time::Duration::from_secs(2));
    targets = bench
}
criterion_main!(benches);
