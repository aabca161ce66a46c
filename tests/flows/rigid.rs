//! Rigid bodies as directors (`lieflow::rigid`): RATTLE on the rotation matrix keeps `QᵀQ = I`
//! and every joint row at round-off, a free body's energy and angular momentum without drift
//! (the discrete Moser–Veselov map), order 2 against Euler's equations and a compound
//! pendulum's, a slider's closed-form fall, and impossible inertias refused by name.

use crate::common::{fitted_order, pendulum_angle};
use lieflow::flow::{Flow, FlowExt};
use lieflow::prelude::*;
use lieflow::rigid::{
    Ball, BodyRef, Hinge, Inertia, Multibody, RigidBody, Rotation, Slider, Universal, cross,
};

type V = faer::Col<f64>;

/// The free box of `../shared/docs/METHOD.md` §8: mass 1, sides 1 × 2 × 3 (`J = (13, 10, 5)/12`,
/// `E = (1, 4, 9)/12`), body angular velocity `(0.1, 1, 0.1)` — near the unstable middle axis.
fn free_box() -> Multibody {
    let mut model = Multibody::new([0.0; 3]);
    let mut body = RigidBody::at_rest(
        1.0,
        Inertia::solid_box(1.0, [1.0, 2.0, 3.0]).unwrap(),
        [0.0; 3],
    );
    body.angular_velocity = [0.1, 1.0, 0.1];
    model.add_rigid(body).unwrap();
    model
}

/// RATTLE: the projection around kick ∘ drift ∘ kick (the kick is gravity's, zero for the free
/// box).
fn rattle(model: &Multibody, x0: &V) -> impl Flow<V> + use<> {
    model
        .kick::<V>()
        .strang(model.drift::<V>())
        .projected(model.system::<f64>(), x0, model.projection_options())
        .unwrap()
}

/// The body angular velocity `Ω = Rᵀω` (the box's frame is its principal frame).
fn body_rate(model: &Multibody, x: &[f64]) -> [f64; 3] {
    model.body_angular_velocity(x, 0)
}

/// Euler's equations `J Ω' = (JΩ) × Ω` by RK4 at `dt` (error below 1e-13 at 1e-4 here).
fn euler(j: [f64; 3], omega: [f64; 3], t_end: f64, dt: f64) -> [f64; 3] {
    let f = |w: [f64; 3]| {
        let l = [j[0] * w[0], j[1] * w[1], j[2] * w[2]];
        let c = cross(l, w);
        [c[0] / j[0], c[1] / j[1], c[2] / j[2]]
    };
    let n = (t_end / dt).round() as usize;
    let dt = t_end / n as f64;
    let mut w = omega;
    let add =
        |a: [f64; 3], b: [f64; 3], s: f64| [a[0] + s * b[0], a[1] + s * b[1], a[2] + s * b[2]];
    for _ in 0..n {
        let k1 = f(w);
        let k2 = f(add(w, k1, 0.5 * dt));
        let k3 = f(add(w, k2, 0.5 * dt));
        let k4 = f(add(w, k3, dt));
        for i in 0..3 {
            w[i] += dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
        }
    }
    w
}

#[test]
fn a_free_box_keeps_its_rotation_energy_and_momentum_and_flips() {
    let model = free_box();
    let x0: V = model.initial_state();
    let h0 = model.system::<f64>().hamiltonian.energy(&x0);
    // ½ ΩᵀJΩ and |JΩ|² of the closed forms (METHOD §8).
    assert!((h0 - 0.424_166_666_666_666_7).abs() < 1e-15, "{h0}");
    let l0 = model.angular_momentum(x0.as_slice());
    let l2: f64 = l0.iter().map(|v| v * v).sum();
    assert!((l2 - 0.707_916_666_666_666_6).abs() < 1e-15, "{l2}");
    let mut flow = rattle(&model, &x0);
    let mut x = x0.clone();
    let (h, period) = (0.01f64, 31.733_194_352_908_76f64);
    let steps = (0.5 * period / h).round() as usize;
    let (mut worst_q, mut worst_h, mut worst_l) = (0.0f64, 0.0f64, 0.0f64);
    for _ in 0..steps {
        flow.step(h, &mut x).unwrap();
        worst_q = worst_q.max(model.orthonormality_error(x.as_slice()));
        let e = model.system::<f64>().hamiltonian.energy(&x);
        worst_h = worst_h.max((e - h0).abs() / h0);
        let l = model.angular_momentum(x.as_slice());
        worst_l = worst_l.max((0..3).map(|k| (l[k] - l0[k]).abs()).fold(0.0, f64::max));
    }
    let omega = body_rate(&model, x.as_slice());
    eprintln!(
        "free box, {steps} steps of {h}: |QᵀQ − I| ≤ {worst_q:e}, |ΔH|/H ≤ {worst_h:e}, |ΔL| ≤ {worst_l:e}; Ω(T/2) = {omega:?}"
    );
    // Each step's rows are solved to 16 ε (the diagonal of QᵀQ − I is twice its rows); H and
    // L are invariants of the discrete map, so they move only by the rounding of its
    // arithmetic, a few ε a step in a random walk.
    assert!(worst_q <= 32.0 * f64::EPSILON, "{worst_q:e}");
    assert!(
        worst_h <= 64.0 * f64::EPSILON * (steps as f64).sqrt(),
        "{worst_h:e}"
    );
    assert!(
        worst_l <= 64.0 * f64::EPSILON * (steps as f64).sqrt(),
        "{worst_l:e}"
    );
    // Half a period of the body angular momentum later the rotation about the middle axis has
    // turned over (Dzhanibekov): Ω₂ ≈ −1.
    assert!(omega[1] < -0.9, "{omega:?}");
}

#[test]
fn a_free_box_converges_at_order_two_to_euler_s_equations() {
    let model = free_box();
    let x0: V = model.initial_state();
    let t_end = 8.0;
    let j = Inertia::solid_box(1.0, [1.0, 2.0, 3.0]).unwrap().moments();
    let reference = euler(j, [0.1, 1.0, 0.1], t_end, 1e-4);
    let hs = [0.08, 0.04, 0.02, 0.01];
    let errs: Vec<f64> = hs
        .iter()
        .map(|&h| {
            let mut flow = rattle(&model, &x0);
            let mut x = x0.clone();
            for _ in 0..(t_end / h).round() as usize {
                flow.step(h, &mut x).unwrap();
            }
            let omega = body_rate(&model, x.as_slice());
            (0..3)
                .map(|k| (omega[k] - reference[k]).abs())
                .fold(0.0, f64::max)
        })
        .collect();
    let p = fitted_order(&hs, &errs, 1e-12);
    eprintln!("free box against Euler's equations: errors {errs:?}, order {p:.3}");
    assert!((p - 2.0).abs() < 0.2, "{p}");
    // Composed by the triple jump (no dissipation), order 4.
    let errs: Vec<f64> = hs
        .iter()
        .map(|&h| {
            let mut flow = rattle(&model, &x0).triple_jump();
            let mut x = x0.clone();
            for _ in 0..(t_end / h).round() as usize {
                flow.step(h, &mut x).unwrap();
            }
            let omega = body_rate(&model, x.as_slice());
            (0..3)
                .map(|k| (omega[k] - reference[k]).abs())
                .fold(0.0, f64::max)
        })
        .collect();
    let p = fitted_order(&hs, &errs, 1e-11);
    eprintln!("free box, triple jump: errors {errs:?}, order {p:.3}");
    assert!((p - 4.0).abs() < 0.3, "{p}");
}

#[test]
fn a_box_on_a_hinge_swings_as_a_compound_pendulum() {
    // A 1 kg bar (0.1 × 0.1 × 1) hanging from a hinge about y at its top end, released at
    // 1 rad: θ'' = −(m g l / I_p) sin θ with l = 0.5, I_p = J_y + m l². The hinge's five rows
    // and the six of QᵀQ = I stay at round-off; the centre follows the closed-form pendulum at
    // order 2.
    let (g, l, theta0) = (9.81, 0.5, 1.0f64);
    let inertia = Inertia::solid_box(1.0, [0.1, 0.1, 1.0]).unwrap();
    let mut model = Multibody::new([0.0, 0.0, -g]);
    let tilt = Rotation::from_axis_angle([0.0, 1.0, 0.0], theta0).unwrap();
    let mut bar = RigidBody::at_rest(1.0, inertia, tilt.apply([0.0, 0.0, -l]));
    bar.orientation = tilt;
    let b = model.add_rigid(bar).unwrap();
    model
        .add_joint(&Hinge {
            a: BodyRef::Body(b),
            anchor_a: [0.0, 0.0, l],
            axis_a: [0.0, 1.0, 0.0],
            b: BodyRef::World,
            anchor_b: [0.0; 3],
            axis_b: [0.0, 1.0, 0.0],
        })
        .unwrap();
    assert_eq!(model.constraints(), 11);
    let x0: V = model.initial_state();
    let ip = inertia.moments()[1] + l * l;
    let w2 = g * l / ip;
    // θ'' = −w² sin θ by RK4.
    let t_end = 3.0;
    let reference = {
        let th = pendulum_angle(|th, _| -w2 * th.sin(), theta0, t_end);
        // R_y(θ) (0, 0, −l) = (−l sin θ, 0, −l cos θ).
        [-l * th.sin(), 0.0, -l * th.cos()]
    };
    let hs = [0.04, 0.02, 0.01, 0.005];
    let mut errs = Vec::new();
    for &h in &hs {
        let mut flow = rattle(&model, &x0);
        let mut x = x0.clone();
        let system = model.system::<f64>();
        let mut g_max = 0.0f64;
        let mut rows = vec![0.0f64; model.constraints()];
        for _ in 0..(t_end / h).round() as usize {
            flow.step(h, &mut x).unwrap();
            system.constraint.residual(&x, &mut rows);
            g_max = rows.iter().fold(g_max, |a, &r| a.max(r.abs()));
        }
        assert!(g_max <= 16.0 * f64::EPSILON, "h = {h}: rows {g_max:e}");
        errs.push(
            (0..3)
                .map(|k| (x[k] - reference[k]).abs())
                .fold(0.0, f64::max),
        );
    }
    let p = fitted_order(&hs, &errs, 1e-12);
    eprintln!("hinged bar against the compound pendulum: errors {errs:?}, order {p:.3}");
    assert!((p - 2.0).abs() < 0.2, "{p}");
}

#[test]
fn a_box_on_a_slider_falls_along_its_axis_exactly() {
    // A box on a slider along a world axis tilted 30° from the vertical: its centre moves
    // along the axis with acceleration g cos 30°, its orientation does not change. The splitting
    // of a uniform field and a drift is exact on this motion: the closed form to round-off.
    let g = 9.81;
    let mut model = Multibody::new([0.0, 0.0, -g]);
    let inertia = Inertia::solid_box(2.0, [0.3, 0.2, 0.1]).unwrap();
    let b = model
        .add_rigid(RigidBody::at_rest(2.0, inertia, [0.0; 3]))
        .unwrap();
    let (s, c) = (30f64.to_radians()).sin_cos();
    let axis = [s, 0.0, -c];
    model
        .add_joint(&Slider {
            a: BodyRef::Body(b),
            anchor_a: [0.0; 3],
            axis_a: axis,
            b: BodyRef::World,
            anchor_b: [0.0; 3],
        })
        .unwrap();
    let x0: V = model.initial_state();
    let mut flow = rattle(&model, &x0);
    let mut x = x0.clone();
    let h = 0.01;
    let mut worst = 0.0f64;
    for step in 1..=200 {
        flow.step(h, &mut x).unwrap();
        let t = step as f64 * h;
        let along = 0.5 * g * c * t * t;
        for k in 0..3 {
            worst = worst.max((x[k] - along * axis[k]).abs());
        }
        let r = model.orientation(x.as_slice(), 0);
        for (i, row) in r.0.iter().enumerate() {
            for (j, &v) in row.iter().enumerate() {
                let want = if i == j { 1.0 } else { 0.0 };
                worst = worst.max((v - want).abs());
            }
        }
    }
    eprintln!("box on a slider: largest deviation from the closed form {worst:e}");
    // Positions of size ≤ ½ g t² ≈ 17 m after 2 s: a few ε of that.
    assert!(worst <= 1e-13, "{worst:e}");
}

#[test]
fn a_chain_of_bodies_on_ball_and_universal_joints_keeps_its_rows() {
    // Two bars: the first on a ball joint to the world, the second on a universal joint to the
    // first; released from a tilt, turning about the vertical. Every row (6 + 6 + 3 + 4) at round-off after
    // every step; energy bounded (RATTLE is symplectic) and its error falling as h².
    let run = |h: f64| {
        let g = 9.81;
        let bar = Inertia::solid_box(1.0, [0.1, 0.1, 1.0]).unwrap();
        let mut model = Multibody::new([0.0, 0.0, -g]);
        let tilt = Rotation::from_axis_angle([1.0, 1.0, 0.0], 0.7).unwrap();
        // Both bars turning together about the vertical through the ball joint: a rigid
        // motion of the assembly, so the initial velocities satisfy the joints.
        let spin = [0.0, 0.0, 2.0];
        let mut first = RigidBody::at_rest(1.0, bar, tilt.apply([0.0, 0.0, -0.5]));
        first.orientation = tilt;
        first.angular_velocity = spin;
        first.velocity = cross(spin, first.position);
        let a = model.add_rigid(first).unwrap();
        let mut second = RigidBody::at_rest(1.0, bar, tilt.apply([0.0, 0.0, -1.5]));
        second.orientation = tilt;
        second.angular_velocity = spin;
        second.velocity = cross(spin, second.position);
        let b = model.add_rigid(second).unwrap();
        model
            .add_joint(&Ball {
                a: BodyRef::Body(a),
                anchor_a: [0.0, 0.0, 0.5],
                b: BodyRef::World,
                anchor_b: [0.0; 3],
            })
            .unwrap();
        model
            .add_joint(&Universal {
                a: BodyRef::Body(b),
                anchor_a: [0.0, 0.0, 0.5],
                axis_a: [1.0, 0.0, 0.0],
                b: BodyRef::Body(a),
                anchor_b: [0.0, 0.0, -0.5],
                axis_b: [0.0, 1.0, 0.0],
            })
            .unwrap();
        assert_eq!(model.constraints(), 19);
        let x0: V = model.initial_state();
        let system = model.system::<f64>();
        let h0 = system.hamiltonian.energy(&x0);
        let options = model.projection_options();
        let mut flow = model
            .kick::<V>()
            .strang(model.drift::<V>())
            .projected(model.system::<f64>(), &x0, options)
            .unwrap();
        let mut x = x0.clone();
        let mut rows = vec![0.0f64; model.constraints()];
        let (mut g_max, mut e_max) = (0.0f64, 0.0f64);
        for _ in 0..(2.0 / h).round() as usize {
            flow.step(h, &mut x).unwrap();
            system.constraint.residual(&x, &mut rows);
            g_max = rows.iter().fold(g_max, |a, &r| a.max(r.abs()));
            e_max = e_max.max((system.hamiltonian.energy(&x) - h0).abs());
        }
        (g_max, e_max)
    };
    let (g1, e1) = run(0.004);
    let (g2, e2) = run(0.002);
    eprintln!("ball + universal chain: rows {g1:e} / {g2:e}, energy error {e1:e} / {e2:e}");
    assert!(g1.max(g2) <= 64.0 * f64::EPSILON, "{g1:e} {g2:e}");
    let p = (e1 / e2).log2();
    assert!((p - 2.0).abs() < 0.4, "energy error order {p}");
}

#[test]
fn impossible_inertias_and_misplaced_joints_are_refused_by_name() {
    // J₃ > J₁ + J₂: no mass distribution has it.
    let e = Inertia::principal([1.0, 1.0, 2.5]).unwrap_err();
    assert!(e.to_string().contains("moment of inertia 3"), "{e}");
    assert!(e.to_string().contains("triangle inequality"), "{e}");
    // J₃ = J₁ + J₂: a lamina.
    assert!(Inertia::principal([1.0, 2.0, 3.0]).is_err());
    assert!(Inertia::principal([1.0, -1.0, 1.0]).is_err());
    assert!(Inertia::tensor([[1.0, 0.5, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]).is_err());
    // A tensor with off-diagonal products: its principal moments and a rotation.
    let t = Inertia::tensor([[2.0, 0.5, 0.0], [0.5, 2.0, 0.0], [0.0, 0.0, 3.0]]).unwrap();
    let mut m = t.moments();
    m.sort_by(f64::total_cmp);
    assert!((m[0] - 1.5).abs() < 1e-14 && (m[1] - 2.5).abs() < 1e-14 && (m[2] - 3.0).abs() < 1e-14);
    // Quaternions: a rotation's and back, to round-off.
    let q = [0.9, 0.1, -0.3, 0.2];
    let n = q.iter().map(|v| v * v).sum::<f64>().sqrt();
    let back = Rotation::from_quaternion(q).unwrap().quaternion();
    for k in 0..4 {
        assert!((back[k] - q[k] / n).abs() < 4.0 * f64::EPSILON, "{back:?}");
    }
    // A hinge whose anchors are apart at the initial poses.
    let mut model = Multibody::new([0.0, 0.0, -9.81]);
    let b = model
        .add_rigid(RigidBody::at_rest(
            1.0,
            Inertia::solid_sphere(1.0, 0.1).unwrap(),
            [0.0; 3],
        ))
        .unwrap();
    let e = model
        .add_joint(&Hinge {
            a: BodyRef::Body(b),
            anchor_a: [0.0; 3],
            axis_a: [0.0, 1.0, 0.0],
            b: BodyRef::World,
            anchor_b: [0.0, 0.0, 1.0],
            axis_b: [0.0, 1.0, 0.0],
        })
        .unwrap_err();
    assert!(e.to_string().contains("hinge joint 0"), "{e}");
    // A hinge on a point mass: it has no axis to hold.
    let p = model.add_point(1.0, [0.0; 3], [0.0; 3]).unwrap();
    let e = model
        .add_joint(&Hinge {
            a: BodyRef::Body(p),
            anchor_a: [0.0; 3],
            axis_a: [0.0, 1.0, 0.0],
            b: BodyRef::World,
            anchor_b: [0.0; 3],
            axis_b: [0.0, 1.0, 0.0],
        })
        .unwrap_err();
    assert!(e.to_string().contains("point mass"), "{e}");
}

#[test]
fn the_implicit_schemes_run_rigid_bodies_at_their_orders() {
    // The model has a mechanical form (constant diagonal mass, linear potential), so the
    // energy-consistent Petrov–Galerkin scheme and the discrete gradient take it with the
    // momenta eliminated: the free box against Euler's equations at orders 4 and 2, energy to
    // the Newton tolerance, the rows at round-off after the hidden-constraint projection.
    use lieflow::flow::{ConstrainedDiscreteGradient, PetrovGalerkin};
    let model = free_box();
    let x0: V = model.initial_state();
    let t_end = 8.0;
    let j = Inertia::solid_box(1.0, [1.0, 2.0, 3.0]).unwrap().moments();
    let reference = euler(j, [0.1, 1.0, 0.1], t_end, 1e-4);
    let h0 = model.system::<f64>().hamiltonian.energy(&x0);
    type Make = fn(&Multibody, &V) -> Box<dyn Flow<V>>;
    let schemes: [(&str, Make, f64, [f64; 4]); 2] = [
        (
            "Petrov–Galerkin k = 2",
            |m, x0| {
                Box::new(
                    PetrovGalerkin::<V, _>::try_new(
                        m.system::<f64>(),
                        x0,
                        4,
                        m.projection_options(),
                    )
                    .unwrap(),
                )
            },
            4.0,
            [0.4, 0.2, 0.1, 0.05],
        ),
        (
            "discrete gradient",
            |m, x0| {
                Box::new(
                    ConstrainedDiscreteGradient::<V, _>::try_new(
                        m.system::<f64>(),
                        x0,
                        m.projection_options(),
                    )
                    .unwrap(),
                )
            },
            2.0,
            [0.08, 0.04, 0.02, 0.01],
        ),
    ];
    for (name, make, order, hs) in schemes {
        let mut worst_q = 0.0f64;
        let mut worst_h = 0.0f64;
        let errs: Vec<f64> = hs
            .iter()
            .map(|&h| {
                let mut flow = make(&model, &x0);
                let mut x = x0.clone();
                let mut ledger = lieflow::flow::Ledger::at(0.0);
                let (mut q_h, mut b_h) = (0.0f64, 0.0f64);
                for _ in 0..(t_end / h).round() as usize {
                    flow.step_at(&mut ledger, h, &mut x).unwrap();
                    q_h = q_h.max(model.orthonormality_error(x.as_slice()));
                    // The energy the hidden-constraint projection removed is booked as
                    // dissipated: H − H₀ + D = 0 to the Newton tolerance.
                    let e = model.system::<f64>().hamiltonian.energy(&x);
                    b_h = b_h.max((e - h0 + ledger.dissipated).abs() / h0);
                }
                eprintln!(
                    "  h = {h}: |QᵀQ − I| ≤ {q_h:e}, balance {b_h:e}, D = {:e}",
                    ledger.dissipated
                );
                // At the coarsest step (0.4 rad a step) Petrov–Galerkin's rows stop at its
                // Newton tolerance on the increment's scale (1.1e-13 measured); steps that
                // resolve the rotation keep them at round-off.
                if h * 1.0 <= 0.2 {
                    worst_q = worst_q.max(q_h);
                }
                worst_h = worst_h.max(b_h);
                let omega = body_rate(&model, x.as_slice());
                (0..3)
                    .map(|k| (omega[k] - reference[k]).abs())
                    .fold(0.0, f64::max)
            })
            .collect();
        let p = fitted_order(&hs, &errs, 1e-11);
        eprintln!(
            "free box, {name}: errors {errs:?}, order {p:.3}; |QᵀQ − I| ≤ {worst_q:e}, |ΔH|/H ≤ {worst_h:e}"
        );
        assert!((p - order).abs() < 0.3, "{name}: {p}");
        assert!(worst_q <= 32.0 * f64::EPSILON, "{name}: {worst_q:e}");
        // Both keep H − H₀ + D = 0 (D the kinetic energy the hidden-constraint projection
        // removed, at the defect's order) to the rounding of each step's energies, a few ε of
        // H a step: at most 8 ε over each of the finest run's steps.
        let steps = t_end / hs[3];
        assert!(worst_h <= 8.0 * f64::EPSILON * steps, "{name}: {worst_h:e}");
    }
}

#[test]
fn a_lagrange_top_on_a_ball_joint_precesses_steadily() {
    // A spinning cylinder (m = 1, radius 0.1, height 0.2) on a ball joint at the centre of its
    // base, tilted θ = 0.5 from the vertical, spin Ω = 60 about its axis (above the sleeping
    // limit I₃²Ω² > 4 I₁ m g l cos θ): at the slow steady
    // precession rate s, the root of I₁ cos θ s² − I₃ Ω s + m g l = 0 (I₁ about the apex;
    // Goldstein §5.7), the axis turns about the vertical at the constant tilt, e(t) =
    // (sin θ cos st, sin θ sin st, cos θ). RATTLE follows it at order 2.
    let (m, r, height, g, theta, spin) = (1.0, 0.1, 0.2, 9.81, 0.5f64, 60.0);
    let l = 0.5 * height;
    let inertia = Inertia::solid_cylinder(m, r, height).unwrap();
    let j = inertia.moments();
    let (i1, i3) = (j[0] + m * l * l, j[2]);
    let c = theta.cos();
    let s =
        (i3 * spin - (i3 * i3 * spin * spin - 4.0 * i1 * c * m * g * l).sqrt()) / (2.0 * i1 * c);
    let tilt = Rotation::from_axis_angle([0.0, 1.0, 0.0], theta).unwrap();
    let axis = tilt.column(2);
    let omega: [f64; 3] =
        core::array::from_fn(|k| s * [0.0, 0.0, 1.0][k] + (spin - s * c) * axis[k]);
    let mut model = Multibody::new([0.0, 0.0, -g]);
    let mut top = RigidBody::at_rest(m, inertia, axis.map(|a| l * a));
    top.orientation = tilt;
    top.angular_velocity = omega;
    top.velocity = cross(omega, top.position);
    let b = model.add_rigid(top).unwrap();
    model
        .add_joint(&Ball {
            a: BodyRef::Body(b),
            anchor_a: [0.0, 0.0, -l],
            b: BodyRef::World,
            anchor_b: [0.0; 3],
        })
        .unwrap();
    let x0: V = model.initial_state();
    let t_end = 0.5;
    let exact = [
        theta.sin() * (s * t_end).cos(),
        theta.sin() * (s * t_end).sin(),
        c,
    ];
    let hs = [0.002, 0.001, 0.0005, 0.00025];
    let errs: Vec<f64> = hs
        .iter()
        .map(|&h| {
            let mut flow = rattle(&model, &x0);
            let mut x = x0.clone();
            for _ in 0..(t_end / h).round() as usize {
                flow.step(h, &mut x).unwrap();
            }
            let e = model.orientation(x.as_slice(), b).column(2);
            (0..3).map(|k| (e[k] - exact[k]).abs()).fold(0.0, f64::max)
        })
        .collect();
    let p = fitted_order(&hs, &errs, 1e-12);
    eprintln!("Lagrange top, precession rate {s:.6}: axis errors {errs:?}, order {p:.3}");
    assert!((p - 2.0).abs() < 0.2, "{p}");
}

/// A hinge of `body` to the world about the world axis `axis` through the world point `at`
/// (the body's anchor at the same point).
fn world_hinge(body: usize, anchor: [f64; 3], at: [f64; 3], axis: [f64; 3]) -> Hinge {
    Hinge {
        a: BodyRef::Body(body),
        anchor_a: anchor,
        axis_a: axis,
        b: BodyRef::World,
        anchor_b: at,
        axis_b: axis,
    }
}

#[test]
fn a_torsion_oscillator_on_a_hinge_rings_down_as_its_closed_form() {
    // A box (0.4 × 0.2 × 0.1, 1 kg) on a hinge about z through its centre, a spring k = 1 and a
    // damper c = 0.02 on the angle, started turning at ω₀ = 2: I θ'' + c θ' + k θ = 0, so the
    // body's angle is φ(t) = (ω₀/ω_d) e^{−ζω t} sin ω_d t (the hinge's θ = −φ: it measures the
    // world against the body). Order 2, every row at round-off, and the energy budget
    // H − H₀ + D (D the dampers' booked energy) falling as h².
    let (k, c, w0) = (1.0, 0.02, 2.0);
    let inertia = Inertia::solid_box(1.0, [0.4, 0.2, 0.1]).unwrap();
    let i = inertia.moments()[2];
    let mut model = Multibody::new([0.0, 0.0, -9.81]);
    let mut body = RigidBody::at_rest(1.0, inertia, [0.0; 3]);
    body.angular_velocity = [0.0, 0.0, w0];
    let b = model.add_rigid(body).unwrap();
    let hinge = world_hinge(b, [0.0; 3], [0.0; 3], [0.0, 0.0, 1.0]);
    model.add_joint(&hinge).unwrap();
    model.add_hinge_spring(&hinge, k, 0.0).unwrap();
    model.add_hinge_damper(&hinge, c).unwrap();
    let x0: V = model.initial_state();
    let wn = (k / i).sqrt();
    let zeta = c / (2.0 * (k * i).sqrt());
    let wd = wn * (1.0 - zeta * zeta).sqrt();
    let t_end = 3.0;
    let exact = -(w0 / wd) * (-zeta * wn * t_end).exp() * (wd * t_end).sin();
    let hs = [0.02, 0.01, 0.005, 0.0025];
    let system = model.system::<f64>();
    let h0 = system.hamiltonian.energy(&x0);
    let mut budgets = Vec::new();
    let errs: Vec<f64> = hs
        .iter()
        .map(|&h| {
            let mut flow = rattle(&model, &x0);
            let mut x = x0.clone();
            let mut ledger = lieflow::flow::Ledger::at(0.0);
            let mut rows = vec![0.0f64; model.constraints()];
            let mut g_max = 0.0f64;
            for _ in 0..(t_end / h).round() as usize {
                flow.step_at(&mut ledger, h, &mut x).unwrap();
                system.constraint.residual(&x, &mut rows);
                g_max = rows.iter().fold(g_max, |a, &r| a.max(r.abs()));
            }
            assert!(g_max <= 16.0 * f64::EPSILON, "h = {h}: rows {g_max:e}");
            let e = system.hamiltonian.energy(&x);
            budgets.push((e - h0 + ledger.dissipated).abs());
            (model.spring_angle(x.as_slice(), 0) - exact).abs()
        })
        .collect();
    let p = fitted_order(&hs, &errs, 1e-12);
    let pb = fitted_order(&hs, &budgets, 1e-14);
    eprintln!(
        "torsion oscillator: angle errors {errs:?}, order {p:.3}; budget errors {budgets:?}, order {pb:.3}"
    );
    assert!((p - 2.0).abs() < 0.2, "{p}");
    assert!((pb - 2.0).abs() < 0.3, "{pb}");
}

#[test]
fn a_damper_on_an_off_centre_hinge_keeps_order_two_and_books_its_loss() {
    // The case of METHOD §8's trap: a 1 kg box (0.3 × 0.2 × 0.1) on a hinge about y whose
    // axis passes 0.15 m above its centre, under gravity, a damper c = 0.05: a damped compound
    // pendulum, I_p θ'' = −m g l sin θ − c θ' (I_p = J_y + m l²). The damper's rate ∇θ·q̇ lives
    // on the directors alone; the motion it damps also moves the centre. Along the consistent
    // direction the run keeps order 2 and books what H loses, to O(h²).
    let (g, l, c, theta0) = (9.81, 0.15, 0.05, 1.0f64);
    let inertia = Inertia::solid_box(1.0, [0.3, 0.2, 0.1]).unwrap();
    let ip = inertia.moments()[1] + l * l;
    let tilt = Rotation::from_axis_angle([0.0, 1.0, 0.0], theta0).unwrap();
    let mut model = Multibody::new([0.0, 0.0, -g]);
    let mut body = RigidBody::at_rest(1.0, inertia, tilt.apply([0.0, 0.0, -l]));
    body.orientation = tilt;
    let b = model.add_rigid(body).unwrap();
    let hinge = world_hinge(b, [0.0, 0.0, l], [0.0; 3], [0.0, 1.0, 0.0]);
    model.add_joint(&hinge).unwrap();
    model.add_hinge_damper(&hinge, c).unwrap();
    let x0: V = model.initial_state();
    let t_end = 2.0;
    let reference = {
        let th = pendulum_angle(|th, om| (-g * l * th.sin() - c * om) / ip, theta0, t_end);
        [-l * th.sin(), 0.0, -l * th.cos()]
    };
    let hs = [0.02, 0.01, 0.005, 0.0025];
    let system = model.system::<f64>();
    let h0 = system.hamiltonian.energy(&x0);
    let mut budgets = Vec::new();
    let mut losses = Vec::new();
    let errs: Vec<f64> = hs
        .iter()
        .map(|&h| {
            let mut flow = rattle(&model, &x0);
            let mut x = x0.clone();
            let mut ledger = lieflow::flow::Ledger::at(0.0);
            for _ in 0..(t_end / h).round() as usize {
                flow.step_at(&mut ledger, h, &mut x).unwrap();
            }
            let e = system.hamiltonian.energy(&x);
            budgets.push((e - h0 + ledger.dissipated).abs());
            losses.push(ledger.dissipated);
            (0..3)
                .map(|k| (x[k] - reference[k]).abs())
                .fold(0.0, f64::max)
        })
        .collect();
    let p = fitted_order(&hs, &errs, 1e-12);
    let pb = fitted_order(&hs, &budgets, 1e-14);
    eprintln!(
        "off-centre damped hinge: errors {errs:?}, order {p:.3}; booked {losses:?}, budget errors {budgets:?}, order {pb:.3}"
    );
    assert!((p - 2.0).abs() < 0.2, "{p}");
    assert!((pb - 2.0).abs() < 0.3, "{pb}");
    assert!(losses.iter().all(|&d| d > 0.1), "{losses:?}");
}
