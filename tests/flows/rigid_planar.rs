//! Planar rigid bodies (`Multibody::planar`): a body in the plane is its centre and two
//! directors, three rows of `QᵀQ = I`, and the joints are the 3D kinds with the normal a
//! constant director. A bar on a pin swings as its compound pendulum at order 2 (and 4 composed),
//! a planar model runs through the same states as the spatial model of the same mechanism in
//! its `x–y` plane (springs, dampers and all), and what would leave the plane is refused.

use crate::common::{fitted_order, pendulum_angle};
use lieflow::flow::{Flow, FlowExt, Ledger};
use lieflow::prelude::*;
use lieflow::rigid::{BodyRef, Hinge, Inertia, Multibody, RigidBody, Rotation, Slider, Universal};

type V = faer::Col<f64>;

/// RATTLE on the model: the projection around kick ∘ drift ∘ kick.
fn rattle(model: &Multibody, x0: &V) -> impl Flow<V> + use<> {
    model
        .kick::<V>()
        .strang(model.drift::<V>())
        .projected(model.system::<f64>(), x0, model.projection_options())
        .unwrap()
}

/// A pin about the normal at `at` (world) through `anchor` (the body's frame).
fn pin(body: usize, anchor: [f64; 3], at: [f64; 3]) -> Hinge {
    Hinge {
        a: BodyRef::Body(body),
        anchor_a: anchor,
        axis_a: [0.0, 0.0, 1.0],
        b: BodyRef::World,
        anchor_b: at,
        axis_b: [0.0, 0.0, 1.0],
    }
}

/// A bar (1 kg, 0.1 × 1 × 0.1, long along its y) hanging from a pin at its top end, turned
/// `theta0` about the normal, in a model of `dim` positions a slot.
fn hanging_bar(planar: bool, theta0: f64) -> (Multibody, Inertia) {
    let (g, l) = (9.81, 0.5);
    let inertia = Inertia::solid_box(1.0, [0.1, 1.0, 0.1]).unwrap();
    let mut model = if planar {
        Multibody::planar([0.0, -g])
    } else {
        Multibody::new([0.0, -g, 0.0])
    };
    let tilt = Rotation::from_axis_angle([0.0, 0.0, 1.0], theta0).unwrap();
    let mut bar = RigidBody::at_rest(1.0, inertia, tilt.apply([0.0, -l, 0.0]));
    bar.orientation = tilt;
    let b = model.add_rigid(bar).unwrap();
    model.add_joint(&pin(b, [0.0, l, 0.0], [0.0; 3])).unwrap();
    (model, inertia)
}

#[test]
fn a_planar_bar_on_a_pin_swings_as_its_compound_pendulum_at_orders_two_and_four() {
    // Released at 1 rad: θ'' = −(m g l / I_p) sin θ, I_p = J_z + m l². Three rows of QᵀQ = I
    // and the pin's two, all at round-off; the centre follows the closed-form pendulum at
    // order 2, and at order 4 composed by the triple jump.
    let (g, l, theta0) = (9.81, 0.5, 1.0f64);
    let (model, inertia) = hanging_bar(true, theta0);
    assert_eq!((model.dim(), model.slots(), model.constraints()), (2, 3, 5));
    let x0: V = model.initial_state();
    assert_eq!(x0.nrows(), 12);
    let w2 = g * l / (inertia.moments()[2] + l * l);
    let t_end = 3.0;
    let th = pendulum_angle(|th, _| -w2 * th.sin(), theta0, t_end);
    // R_z(θ) (0, −l) = (l sin θ, −l cos θ).
    let want = [l * th.sin(), -l * th.cos()];
    for (order, hs, floor) in [
        (2.0, [0.04, 0.02, 0.01, 0.005], 1e-12),
        (4.0, [0.04, 0.02, 0.01, 0.005], 1e-11),
    ] {
        let mut errs = Vec::new();
        for &h in &hs {
            let mut flow: Box<dyn Flow<V>> = if order == 2.0 {
                Box::new(rattle(&model, &x0))
            } else {
                Box::new(rattle(&model, &x0).triple_jump())
            };
            let mut x = x0.clone();
            let system = model.system::<f64>();
            let mut rows = vec![0.0f64; model.constraints()];
            let mut g_max = 0.0f64;
            for _ in 0..(t_end / h).round() as usize {
                flow.step(h, &mut x).unwrap();
                system.constraint.residual(&x, &mut rows);
                g_max = rows.iter().fold(g_max, |a, &r| a.max(r.abs()));
            }
            assert!(g_max <= 16.0 * f64::EPSILON, "h = {h}: rows {g_max:e}");
            assert!(model.orthonormality_error(x.as_slice()) <= 16.0 * f64::EPSILON);
            errs.push((x[0] - want[0]).abs().max((x[1] - want[1]).abs()));
        }
        let p = fitted_order(&hs, &errs, floor);
        eprintln!("planar bar, order {order}: errors {errs:?}, fitted {p:.3}");
        assert!((p - order).abs() < 0.3, "order {p}, want {order}");
    }
}

/// Two bars on pins (the second hung from the first's lower end), a spring and a damper on the
/// lower pin, a slider carrying a third body along a turned axis, in a model of either kind.
fn linkage(planar: bool) -> (Multibody, Hinge) {
    let (mut model, _) = hanging_bar(planar, 0.7);
    let inertia = Inertia::solid_box(0.5, [0.05, 0.6, 0.05]).unwrap();
    let top = Rotation::from_axis_angle([0.0, 0.0, 1.0], 0.7).unwrap();
    let end = top.apply([0.0, -1.0, 0.0]);
    let tilt = Rotation::from_axis_angle([0.0, 0.0, 1.0], -0.4).unwrap();
    let below = tilt.apply([0.0, -0.3, 0.0]);
    let mut bar = RigidBody::at_rest(0.5, inertia, core::array::from_fn(|k| end[k] + below[k]));
    bar.orientation = tilt;
    bar.angular_velocity = [0.0, 0.0, 1.5];
    let w = cross_z(1.5, below);
    bar.velocity = w;
    let b = model.add_rigid(bar).unwrap();
    let knee = Hinge {
        a: BodyRef::Body(b),
        anchor_a: [0.0, 0.3, 0.0],
        axis_a: [0.0, 0.0, 1.0],
        b: BodyRef::Body(0),
        anchor_b: [0.0, -0.5, 0.0],
        axis_b: [0.0, 0.0, 1.0],
    };
    model.add_joint(&knee).unwrap();
    model.add_hinge_spring(&knee, 2.0, 0.1).unwrap();
    model.add_hinge_damper(&knee, 0.05).unwrap();
    // A block on a slider along (1, 1)/√2 through (2, 0), free to fall along it.
    let block = Inertia::solid_box(0.3, [0.1, 0.1, 0.1]).unwrap();
    let s = model
        .add_rigid(RigidBody::at_rest(0.3, block, [2.0, 0.0, 0.0]))
        .unwrap();
    model
        .add_joint(&Slider {
            a: BodyRef::Body(s),
            anchor_a: [0.0; 3],
            axis_a: [1.0, 1.0, 0.0],
            b: BodyRef::World,
            anchor_b: [2.0, 0.0, 0.0],
        })
        .unwrap();
    (model, knee)
}

/// `ω e_z × r`.
fn cross_z(w: f64, r: [f64; 3]) -> [f64; 3] {
    [-w * r[1], w * r[0], 0.0]
}

#[test]
fn a_planar_model_runs_through_the_states_of_the_spatial_one_in_its_plane() {
    // The same linkage as a planar model and as a spatial model in its x–y plane: the spatial
    // one's normal directors stay e_z and the multipliers of its out-of-plane rows zero (the
    // reflection z → −z maps its motion to itself), so both take the same projected steps on
    // the in-plane coordinates and differ by rounding alone, grown by the motion over 2 s
    // (≲ N ε e^{λt}, N = 2000 steps: below 1e-10). The planar model has 2 × 3 + 2 + 2 + 2 rows
    // (bodies, pins, slider) against 3 × 6 + 5 + 5 + 5.
    let (planar, _) = linkage(true);
    let (spatial, _) = linkage(false);
    assert_eq!(planar.constraints(), 3 * 3 + 2 + 2 + 2);
    assert_eq!(spatial.constraints(), 3 * 6 + 5 + 5 + 5);
    let (h, steps) = (1e-3, 2000);
    let run = |model: &Multibody| {
        let x0: V = model.initial_state();
        let mut flow = rattle(model, &x0);
        let mut x = x0.clone();
        let mut ledger = Ledger::at(0.0);
        for _ in 0..steps {
            flow.step_at(&mut ledger, h, &mut x).unwrap();
        }
        let e0 = model.system::<f64>().hamiltonian.energy(&x0);
        let e = model.system::<f64>().hamiltonian.energy(&x);
        (x, e0, e, ledger.dissipated)
    };
    let (xp, e0p, ep, dp) = run(&planar);
    let (xs, e0s, es, ds) = run(&spatial);
    assert!((e0p - e0s).abs() <= 1e-14 * e0s.abs().max(1.0));
    assert!(dp > 1e-3, "the damper works: {dp}");
    assert!(
        (ep - es).abs() <= 1e-10 && (dp - ds).abs() <= 1e-10,
        "{ep} {es} {dp} {ds}"
    );
    // Slot by slot: planar slot s of body b is spatial slot s + b (each spatial body has the
    // normal director after its two moving ones), x and y.
    let (np, ns) = (2 * planar.slots(), 3 * spatial.slots());
    let mut worst = 0.0f64;
    for b in 0..3 {
        for i in 0..3 {
            let (sp, ss) = (3 * b + i, 4 * b + i);
            for k in 0..2 {
                worst = worst.max((xp[2 * sp + k] - xs[3 * ss + k]).abs());
                worst = worst.max((xp[np + 2 * sp + k] - xs[ns + 3 * ss + k]).abs());
            }
        }
        // The spatial normal director and its momentum stay e_z and 0.
        let n = 4 * b + 3;
        assert!((xs[3 * n + 2] - 1.0).abs() <= 1e-15 && xs[ns + 3 * n + 2].abs() <= 1e-15);
    }
    eprintln!("planar against spatial: worst slot difference {worst:e}");
    assert!(worst <= 1e-10, "{worst:e}");
    // The bodies' spins and frames read the same.
    for b in 0..3 {
        let (wp, ws) = (
            planar.angular_velocity(xp.as_slice(), b),
            spatial.angular_velocity(xs.as_slice(), b),
        );
        assert!((wp[2] - ws[2]).abs() <= 1e-9 && wp[0] == 0.0 && wp[1] == 0.0);
        let (qp, qs) = (
            planar.quaternion(xp.as_slice(), b),
            spatial.quaternion(xs.as_slice(), b),
        );
        assert!(
            (0..4).all(|k| (qp[k] - qs[k]).abs() <= 1e-10),
            "{qp:?} {qs:?}"
        );
    }
}

#[test]
fn what_would_leave_the_plane_is_refused_by_name() {
    let inertia = Inertia::solid_box(1.0, [0.1, 1.0, 0.1]).unwrap();
    let refused = |e: lieflow::error::SetupError, word: &str| {
        let text = e.to_string();
        assert!(text.contains(word), "`{word}` not in: {text}");
    };
    let mut model = Multibody::planar([0.0, -9.81]);
    refused(
        model
            .add_rigid(RigidBody::at_rest(1.0, inertia, [0.0, 0.0, 0.5]))
            .unwrap_err(),
        "position",
    );
    let mut spun = RigidBody::at_rest(1.0, inertia, [0.0; 3]);
    spun.angular_velocity = [1.0, 0.0, 0.0];
    refused(model.add_rigid(spun).unwrap_err(), "angular velocity");
    let mut tipped = RigidBody::at_rest(1.0, inertia, [0.0; 3]);
    tipped.orientation = Rotation::from_axis_angle([1.0, 0.0, 0.0], 0.3).unwrap();
    refused(model.add_rigid(tipped).unwrap_err(), "orientation");
    // Principal axes not along the normal: a tensor with an xz product.
    let skew = Inertia::tensor([[1.0, 0.0, 0.2], [0.0, 1.0, 0.0], [0.2, 0.0, 1.5]]).unwrap();
    refused(
        model
            .add_rigid(RigidBody::at_rest(1.0, skew, [0.0; 3]))
            .unwrap_err(),
        "planar body",
    );
    // A tensor with an xy product is turned to its principal axes in the plane.
    let turned = Inertia::tensor([[1.0, 0.3, 0.0], [0.3, 2.0, 0.0], [0.0, 0.0, 2.5]]).unwrap();
    let b = model
        .add_rigid(RigidBody::at_rest(1.0, turned, [0.0; 3]))
        .unwrap();
    refused(
        model
            .add_joint(&Hinge {
                axis_a: [1.0, 0.0, 0.0],
                ..pin(b, [0.0; 3], [0.0; 3])
            })
            .unwrap_err(),
        "hinge axis",
    );
    refused(
        model
            .add_joint(&Slider {
                a: BodyRef::Body(b),
                anchor_a: [0.0; 3],
                axis_a: [0.0, 1.0, 1.0],
                b: BodyRef::World,
                anchor_b: [0.0; 3],
            })
            .unwrap_err(),
        "slider axis",
    );
    refused(
        model
            .add_joint(&Universal {
                a: BodyRef::Body(b),
                anchor_a: [0.0; 3],
                axis_a: [1.0, 0.0, 0.0],
                b: BodyRef::World,
                anchor_b: [0.0; 3],
                axis_b: [0.0, 1.0, 0.0],
            })
            .unwrap_err(),
        "universal",
    );
    // The pin itself is two rows.
    let before = model.constraints();
    model.add_joint(&pin(b, [0.0; 3], [0.0; 3])).unwrap();
    assert_eq!(model.constraints(), before + 2);
}
