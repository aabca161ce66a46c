//! What a rigid body's projected step costs in Newton work: with the multiplier Jacobians
//! summed in closed form from the rows' entries (`G(y) W⁻¹ G(x)ᵀ`, RATTLE's Newton matrices),
//! the `λ_{k+1}` system is affine and takes one update with a fresh Jacobian (after at most one
//! trial with the last step's), and Newton on the quadratic `λ_k` system from its warm start
//! needs at most two updates with the Jacobian of its start (the warm start's error `δ` leaves
//! `O(δ²)` after the first, round-off after the second): at most one factorization a system. The grouped products it replaces took 7.5 iterations and 2.6
//! factorizations a step on the same top.

use lieflow::flow::{Flow, FlowExt};
use lieflow::rigid::{Ball, BodyRef, Inertia, Multibody, RigidBody, Rotation, cross};
use lieflow::system::HolonomicConstraint;

type V = faer::Col<f64>;

/// The heavy top of `examples/spinning_top.rs` (a cylinder on a ball joint, tilted 0.5 rad,
/// spinning at 60 rad/s); with `pivot = false` the same body flying free.
fn top(pivot: bool) -> Multibody {
    let (m, l, theta, spin) = (1.0, 0.1, 0.5f64, 60.0);
    let inertia = Inertia::solid_cylinder(m, 0.1, 0.2).unwrap();
    let tilt = Rotation::from_axis_angle([0.0, 1.0, 0.0], theta).unwrap();
    let axis = tilt.column(2);
    let omega: [f64; 3] = core::array::from_fn(|k| 0.9 * [0.0, 0.0, 1.0][k] + spin * axis[k]);
    let mut model = Multibody::new([0.0, 0.0, if pivot { -9.81 } else { 0.0 }]);
    let mut body = RigidBody::at_rest(m, inertia, axis.map(|a| l * a));
    body.orientation = tilt;
    body.angular_velocity = omega;
    body.velocity = cross(omega, body.position);
    let b = model.add_rigid(body).unwrap();
    if pivot {
        model
            .add_joint(&Ball {
                a: BodyRef::Body(b),
                anchor_a: [0.0, 0.0, -l],
                b: BodyRef::World,
                anchor_b: [0.0; 3],
            })
            .unwrap();
    }
    model
}

#[test]
fn a_rigid_body_s_step_factors_once_a_multiplier_system() {
    // The heavy top: nine rows in six colour groups (a free body's six rows colour in three,
    // where the grouped products are as cheap and keep their Jacobians across steps).
    for pivot in [true] {
        let model = top(pivot);
        let x0: V = model.initial_state();
        let mut flow = model
            .kick::<V>()
            .strang(model.drift::<V>())
            .projected(model.system::<f64>(), &x0, model.projection_options())
            .unwrap();
        let mut x = x0.clone();
        let steps = 2000;
        for _ in 0..steps {
            flow.step(1e-3, &mut x).unwrap();
        }
        let s = flow.stats();
        let (iterations, factorizations) = (
            s.newton_iterations as f64 / steps as f64,
            s.factorizations as f64 / steps as f64,
        );
        eprintln!(
            "pivot {pivot}: {iterations:.3} iterations, {factorizations:.3} factorizations a step"
        );
        // Two systems a step, at most one Jacobian each and two updates each.
        assert!(factorizations <= 2.0 + 1e-12, "{factorizations}");
        assert!(iterations <= 4.0 + 1e-12, "{iterations}");
        let rows = model.quadratic_rows::<f64>();
        let mut g = vec![0.0; HolonomicConstraint::<V>::dim(&rows)];
        HolonomicConstraint::<V>::residual(&rows, &x, &mut g);
        let worst = g.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(worst <= 16.0 * f64::EPSILON, "{worst:e}");
    }
}
