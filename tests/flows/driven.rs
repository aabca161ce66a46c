//! A damped pendulum driven by a torque at its pivot, `θ'' = −sin θ − c θ' + u(t)`: the model,
//! the input map and signal, and a reference solution, shared by the tests of the implicit
//! schemes with inputs.

use lieflow::models::DampedPendulum;
use lieflow::port::{InputMap, Signal};
use nalgebra::SVector;

pub type V = SVector<f64, 4>;

pub const C: f64 = 0.5;
pub const THETA0: f64 = 1.0;

/// The torque about the pivot: `p += u (−q₂, q₁)/|q|²`, which moves the angle only.
#[derive(Clone, Copy)]
pub struct PivotTorque;

impl InputMap<V> for PivotTorque {
    fn inputs(&self) -> usize {
        1
    }
    fn apply(&self, x: &mut V, w: &[f64]) {
        let mut f = V::zeros();
        self.add_product(&x.clone(), w, &mut f, &mut V::zeros());
        *x += f;
    }
    fn transpose_apply(&self, x: &V, e: &V, y: &mut [f64]) {
        let r2 = x[0] * x[0] + x[1] * x[1];
        y[0] = (-x[1] * e[2] + x[0] * e[3]) / r2;
    }
    fn add_product(&self, x: &V, w: &[f64], out: &mut V, _scratch: &mut V) {
        let r2 = x[0] * x[0] + x[1] * x[1];
        out[2] += -x[1] * w[0] / r2;
        out[3] += x[0] * w[0] / r2;
    }
}

/// `u(t) = A sin(Ω t)`.
pub const AMPLITUDE: f64 = 0.8;
pub const OMEGA: f64 = 2.3;

pub fn torque(t: f64) -> f64 {
    AMPLITUDE * (OMEGA * t).sin()
}

pub fn signal() -> Signal<f64> {
    Signal::Sine {
        amplitude: AMPLITUDE,
        omega: OMEGA,
        phase: 0.0,
        offset: 0.0,
    }
}

pub fn model() -> DampedPendulum<f64> {
    DampedPendulum::try_new(C).unwrap()
}

/// The pendulum with damping `c`.
pub fn model_with(c: f64) -> DampedPendulum<f64> {
    DampedPendulum::try_new(c).unwrap()
}

/// `θ'' = −sin θ − c θ' + u(t)` by RK4 at `dt` (error `O(dt⁴)`, below 1e-14 at 1e-4), as the
/// state `(sin θ, −cos θ, ω cos θ, ω sin θ)`.
pub fn reference(t_end: f64, dt: f64) -> [f64; 4] {
    reference_with(C, t_end, dt)
}

/// [`reference`] with damping `c`.
pub fn reference_with(c: f64, t_end: f64, dt: f64) -> [f64; 4] {
    let f = |t: f64, th: f64, om: f64| (om, -th.sin() - c * om + torque(t));
    let n = (t_end / dt).round() as usize;
    let dt = t_end / n as f64;
    let (mut th, mut om) = (THETA0, 0.0);
    for i in 0..n {
        let t = i as f64 * dt;
        let k1 = f(t, th, om);
        let k2 = f(t + 0.5 * dt, th + 0.5 * dt * k1.0, om + 0.5 * dt * k1.1);
        let k3 = f(t + 0.5 * dt, th + 0.5 * dt * k2.0, om + 0.5 * dt * k2.1);
        let k4 = f(t + dt, th + dt * k3.0, om + dt * k3.1);
        th += dt / 6.0 * (k1.0 + 2.0 * k2.0 + 2.0 * k3.0 + k4.0);
        om += dt / 6.0 * (k1.1 + 2.0 * k2.1 + 2.0 * k3.1 + k4.1);
    }
    let (s, co) = th.sin_cos();
    [s, -co, om * co, om * s]
}
