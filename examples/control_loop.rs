//! lieflow inside a control loop: a PD controller, sampled at its own rate, swings a pendulum
//! (a constrained mechanism: a rod of fixed length in 3D) up to a target angle through a motor
//! torque about the pivot. The integrator steps at `dt`; the controller reads the sensor
//! (angle and angular velocity, the port's collocated output), sets the held torque and
//! advances the stepper to its next sample time — a zero-order hold, as in FMI co-simulation.
//!
//! ```text
//! cargo run --release --example control_loop -- --rate 50 --dt 0.001 --target 2.0
//! ```
//!
//! The input's exact sub-flow `p ← p + τ t̂(q)/L ∫dt` joins the kick of the projected
//! splitting (RATTLE, composed to order 4), so the rod stays at round-off while the motor
//! works, and the energy balance `H(T) − H(0) = supplied` closes to the scheme's order.

mod common;

use common::{Args, Json, fatal};
use lieflow::models::SphericalPendulum;
use lieflow::port::{FnInputMap, Held, InputFlow, InputMap, Signal};
use lieflow::prelude::*;
use nalgebra::SVector;

type V = SVector<f64, 6>;

/// The torque about the y axis through the pivot, as a force on the bob: `τ t̂(q)/L` with
/// `t̂ = (−q_z, 0, q_x)/L` the unit tangent of the swing. Its transpose reads the angular
/// velocity `ω = (q_x v_z − q_z v_x)/L²` from `∇H = (…, v)`.
fn motor(length: f64) -> impl InputMap<V> + Clone {
    let l2 = length * length;
    FnInputMap::new(
        1,
        move |x: &mut V, w: &[f64]| {
            let (qx, qz) = (x[0], x[2]);
            x[3] += w[0] * (-qz) / l2;
            x[5] += w[0] * qx / l2;
        },
        move |x: &V, e: &V, y: &mut [f64]| y[0] = (x[0] * e[5] - x[2] * e[3]) / l2,
    )
}

fn main() {
    let args = Args::parse(
        "A PD controller swings a pendulum to a target angle through a motor torque (held between samples).",
        &[
            ("dt", "H", "integrator step (default 0.001)"),
            ("rate", "HZ", "controller sampling rate (default 50)"),
            ("t-end", "T", "final time (default 10)"),
            (
                "target",
                "RAD",
                "target angle from the downward vertical (default 2.0)",
            ),
            ("kp", "K", "proportional gain, N m/rad (default 40)"),
            ("kd", "K", "derivative gain, N m s/rad (default 8)"),
        ],
    );
    let dt = args.positive("dt", 0.001);
    let rate = args.positive("rate", 50.0);
    let t_end = args.positive("t-end", 10.0);
    let target: f64 = args.get("target", 2.0);
    let (kp, kd): (f64, f64) = (args.get("kp", 40.0), args.get("kd", 8.0));
    if !(target.is_finite() && kp.is_finite() && kd.is_finite()) {
        args.fail("--target, --kp and --kd must be finite");
    }
    let model = SphericalPendulum::try_new(1.0, 1.0, 9.81).unwrap_or_else(|e| fatal(&e));
    let x0 = V::from_column_slice(&[0.0, 0.0, -1.0, 0.0, 0.0, 0.0]);
    let torque = Held::new(0.0);
    let input = InputFlow::try_new(motor(model.length), vec![Signal::Held(torque.clone())])
        .unwrap_or_else(|e| fatal(&e))
        .supplying(model);
    let flow = model
        .kick::<V>()
        .strang(input)
        .strang(model.drift::<V>())
        .projected(model.system(), &x0, ProjectionOptions::default())
        .unwrap_or_else(|e| fatal(&e))
        .triple_jump();
    let mut stepper = Stepper::new(flow, x0, 0.0, dt).unwrap_or_else(|e| fatal(&e));
    let sensor = motor(model.length);
    let mut grad = V::zeros();
    let (mut max_g, mut samples, mut max_torque) = (0.0f64, 0usize, 0.0f64);
    let period = 1.0 / rate;
    let gravity_hold = model.mass * model.gravity * model.length * target.sin();
    let start = std::time::Instant::now();
    while stepper.time() < t_end - 1e-12 {
        // Sample: angle from the downward vertical, angular velocity from the port's output.
        let x = *stepper.state();
        let theta = x[0].atan2(-x[2]);
        let mut omega = [0.0];
        sensor.output(&model, &x, &mut grad, &mut omega);
        let tau = gravity_hold + kp * (target - theta) - kd * omega[0];
        torque.set(tau);
        max_torque = max_torque.max(tau.abs());
        samples += 1;
        let next = (samples as f64 * period).min(t_end);
        stepper
            .advance_to(next, &mut |_k: usize, _t: f64, x: &V| {
                let g = ((x[0] * x[0] + x[1] * x[1] + x[2] * x[2]) - 1.0).abs() / 2.0;
                max_g = max_g.max(g);
            })
            .unwrap_or_else(|e| fatal(&e));
    }
    let elapsed = start.elapsed().as_secs_f64();
    let x = *stepper.state();
    let theta = x[0].atan2(-x[2]);
    let ledger = stepper.ledger();
    let balance = model.energy(&x) - model.energy(&x0) - ledger.supplied;
    let steps = stepper.steps_taken();
    println!(
        "PD control of a pendulum at {rate} Hz, integrator triple jump of RATTLE, h = {dt}, T = {t_end}"
    );
    println!(
        "  final angle      = {theta:.6} rad (target {target}), error {:.3e}",
        theta - target
    );
    println!("  samples          = {samples}, steps = {steps}, max |torque| = {max_torque:.3} N m");
    println!("  max |g|          = {max_g:.3e}   (|q|^2 - L^2)/2");
    println!(
        "  energy           = supplied {:.9}, H(T) - H(0) - supplied = {balance:.3e}",
        ledger.supplied
    );
    println!(
        "  time             = {:.0} ns/step",
        elapsed * 1e9 / steps as f64
    );
    Json::default()
        .str("example", "control_loop")
        .num("dt", dt)
        .num("rate", rate)
        .num("t", stepper.time())
        .num("angle", theta)
        .num("angle_error", theta - target)
        .int("samples", samples as u64)
        .int("steps", steps as u64)
        .num("max_abs_g", max_g)
        .num("supplied", ledger.supplied)
        .num("energy_balance_error", balance)
        .print();
}
