//! Helpers shared by the integration tests.
#![allow(dead_code)]

use lieflow::prelude::*;
use lieflow::system::Case;
use nalgebra::SVector;

/// Least-squares slope of `log(err)` against `log(h)`, ignoring errors below `floor`
/// (the round-off floor, where the error no longer follows `C h^p`).
pub fn fitted_order(hs: &[f64], errs: &[f64], floor: f64) -> f64 {
    let pts: Vec<(f64, f64)> = hs
        .iter()
        .zip(errs)
        .filter(|(_, e)| **e > floor)
        .map(|(h, e)| (h.ln(), e.ln()))
        .collect();
    assert!(
        pts.len() >= 4,
        "need at least 4 points above the floor {floor:e}, errors {errs:?}"
    );
    let n = pts.len() as f64;
    let mx = pts.iter().map(|p| p.0).sum::<f64>() / n;
    let my = pts.iter().map(|p| p.1).sum::<f64>() / n;
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx) * (p.0 - mx)).sum();
    sxy / sxx
}

/// Least-squares slope of `log y` against `log x` (an error against a tolerance, say).
pub fn log_slope(x: &[f64], y: &[f64]) -> f64 {
    let (lx, ly): (Vec<f64>, Vec<f64>) = x.iter().zip(y).map(|(a, b)| (a.ln(), b.ln())).unzip();
    let n = lx.len() as f64;
    let (mx, my) = (lx.iter().sum::<f64>() / n, ly.iter().sum::<f64>() / n);
    let sxy: f64 = lx.iter().zip(&ly).map(|(a, b)| (a - mx) * (b - my)).sum();
    sxy / lx.iter().map(|a| (a - mx) * (a - mx)).sum::<f64>()
}

pub type V4 = SVector<f64, 4>;
pub type V3 = SVector<f64, 3>;

/// A non-degenerate test model: the gradient flow of `H = ½ Σ aᵢ xᵢ² + ¼ b x₁⁴` (`M = −I`, pure
/// dissipation) on the unit sphere `g = (|x|² − 1)/2`. `⟨g,g⟩ = −|x|²` is invertible, so the
/// hidden constraint is not a constraint and the symmetric projection applies. (Without the
/// quartic term the radial projection commutes with the linear flow and the scheme is exact.)
pub mod gradient_sphere {
    use super::*;

    pub const A: [f64; 3] = [1.0, 2.0, 4.0];
    pub const B: f64 = 3.0;

    #[derive(Clone, Copy)]
    pub struct NegIdentity;
    impl<V: Vector> StructureMatrix<V> for NegIdentity {
        fn apply_add(&self, _x: &V, v: &V, alpha: V::Real, out: &mut V) {
            for (o, &vi) in out.as_mut_slice().iter_mut().zip(v.as_slice()) {
                *o = *o - alpha * vi;
            }
        }
    }

    #[derive(Clone, Copy)]
    pub struct Quadratic;
    impl Hamiltonian<V3> for Quadratic {
        fn energy(&self, x: &V3) -> f64 {
            0.5 * (0..3).map(|i| A[i] * x[i] * x[i]).sum::<f64>() + 0.25 * B * x[0].powi(4)
        }
        fn gradient(&self, x: &V3, out: &mut V3) {
            for i in 0..3 {
                out[i] = A[i] * x[i];
            }
            out[0] += B * x[0].powi(3);
        }
    }

    #[derive(Clone, Copy)]
    pub struct UnitSphere;
    impl<V: Vector<Real = f64>> HolonomicConstraint<V> for UnitSphere {
        fn dim(&self) -> usize {
            1
        }
        fn residual(&self, x: &V, out: &mut [f64]) {
            out[0] = 0.5 * (x.as_slice().iter().map(|v| v * v).sum::<f64>() - 1.0);
        }
        fn jacobian_apply(&self, x: &V, v: &V, out: &mut [f64]) {
            out[0] = x
                .as_slice()
                .iter()
                .zip(v.as_slice())
                .map(|(a, b)| a * b)
                .sum();
        }
        fn jacobian_transpose_apply_add(&self, x: &V, mu: &[f64], alpha: f64, out: &mut V) {
            for (o, &xi) in out.as_mut_slice().iter_mut().zip(x.as_slice()) {
                *o += alpha * mu[0] * xi;
            }
        }
    }

    pub fn system() -> System<NegIdentity, Quadratic, UnitSphere> {
        System::new(NegIdentity, Quadratic, UnitSphere)
    }

    /// Strang splitting of the two exact gradient flows: `xᵢ ← e^{−h aᵢ} xᵢ` and
    /// `x₁ ← x₁ / √(1 + 2 b h x₁²)`; symmetric, order 2.
    pub fn exact_gradient_flow() -> impl Flow<V3> {
        let linear = from_fn(|h: f64, x: &mut V3| {
            for i in 0..3 {
                x[i] *= (-h * A[i]).exp();
            }
        });
        let quartic = from_fn(|h: f64, x: &mut V3| {
            x[0] /= (1.0 + 2.0 * B * h * x[0] * x[0]).sqrt();
        });
        quartic.strang(linear)
    }

    pub fn x0() -> V3 {
        V3::new(0.6, 0.0, 0.8)
    }

    /// The projected gradient flow `x' = −∇H + x (xᵀ∇H)/|x|²` by RK4 with `n` steps
    /// (independent of the schemes under test).
    pub fn reference(t: f64, n: usize) -> V3 {
        let f = |x: &V3| {
            let mut g = V3::from_fn(|i, _| A[i] * x[i]);
            g[0] += B * x[0].powi(3);
            -g + x * (x.dot(&g) / x.dot(x))
        };
        let dt = t / n as f64;
        let mut x = x0();
        for _ in 0..n {
            let k1 = f(&x);
            let k2 = f(&(x + k1 * (0.5 * dt)));
            let k3 = f(&(x + k2 * (0.5 * dt)));
            let k4 = f(&(x + k3 * dt));
            x += (k1 + k2 * 2.0 + k3 * 2.0 + k4) * (dt / 6.0);
        }
        x
    }

    pub fn projected() -> impl Flow<V3> {
        exact_gradient_flow()
            .projected(system(), &x0(), ProjectionOptions::default())
            .expect("non-degenerate model builds")
    }

    pub fn case() -> Case {
        Case::NonDegenerate
    }
}

/// The paper's Hamiltonian without its Hessian, so that a projection of the paper's model takes
/// the general path (kept difference Jacobians) instead of the small one.
pub struct PaperNoHessian;

impl Hamiltonian<SVector<f64, 4>> for PaperNoHessian {
    fn energy(&self, x: &SVector<f64, 4>) -> f64 {
        Hamiltonian::<SVector<f64, 4>>::energy(&lieflow::models::paper::Energy, x)
    }
    fn gradient(&self, x: &SVector<f64, 4>, out: &mut SVector<f64, 4>) {
        Hamiltonian::<SVector<f64, 4>>::gradient(&lieflow::models::paper::Energy, x, out)
    }
}

/// `θ(t_end)` of `θ'' = accel(θ, θ')` from rest at `θ₀`, by RK4 at 1e-4 (error below 1e-13 for
/// the pendulums here).
pub fn pendulum_angle(accel: impl Fn(f64, f64) -> f64, theta0: f64, t_end: f64) -> f64 {
    let f = |th: f64, om: f64| (om, accel(th, om));
    let (mut th, mut om) = (theta0, 0.0);
    let dt = 1e-4f64;
    for _ in 0..(t_end / dt).round() as usize {
        let k1 = f(th, om);
        let k2 = f(th + 0.5 * dt * k1.0, om + 0.5 * dt * k1.1);
        let k3 = f(th + 0.5 * dt * k2.0, om + 0.5 * dt * k2.1);
        let k4 = f(th + dt * k3.0, om + dt * k3.1);
        th += dt / 6.0 * (k1.0 + 2.0 * k2.0 + 2.0 * k3.0 + k4.0);
        om += dt / 6.0 * (k1.1 + 2.0 * k2.1 + 2.0 * k3.1 + k4.1);
    }
    th
}
