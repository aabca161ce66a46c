//! Fitted convergence orders against references computed independently of the schemes.

use crate::common;

use common::{V3, V4, fitted_order, gradient_sphere};
use lieflow::flow::CompositionTable;
use lieflow::flow::coefficients::*;
use lieflow::models::paper;
use lieflow::prelude::*;

fn paper_error(table: Option<&'static CompositionTable>, h: f64, t_end: f64) -> f64 {
    let mut x: V4 = paper::initial_state();
    let base = paper::drift()
        .projected(paper::system(), &x, ProjectionOptions::default())
        .unwrap();
    let steps = (t_end / h).round() as usize;
    assert!((steps as f64 * h - t_end).abs() < 1e-12);
    match table {
        None => {
            let mut f = base;
            for _ in 0..steps {
                f.step(h, &mut x).unwrap();
            }
        }
        Some(t) => {
            let mut f = base.composed(t);
            for _ in 0..steps {
                f.step(h, &mut x).unwrap();
            }
        }
    }
    let r = paper::reference(t_end, -0.15, 1e-3);
    (0..4).map(|i| (x[i] - r[i]).abs()).fold(0.0, f64::max)
}

fn check_order(table: Option<&'static CompositionTable>, expected: f64, hs: &[f64], t_end: f64) {
    let errs: Vec<f64> = hs.iter().map(|&h| paper_error(table, h, t_end)).collect();
    let p = fitted_order(hs, &errs, 1e-12);
    let name = table.map_or("projection", |t| t.name);
    eprintln!("{name}: h = {hs:?}, errors = {errs:?}, fitted order {p:.3}");
    assert!(
        (p - expected).abs() <= 0.3,
        "{name}: fitted order {p:.3}, expected {expected} ± 0.3 (errors {errs:?})"
    );
}

#[test]
fn reference_solution_is_converged() {
    // RK4 on the angle ODE: halving dt must not change the reference at the 1e-13 level.
    let a = paper::reference(40.0, -0.15, 1e-3);
    let b = paper::reference(40.0, -0.15, 5e-4);
    let d = (0..4).map(|i| (a[i] - b[i]).abs()).fold(0.0, f64::max);
    assert!(d < 1e-13, "reference not converged: {d:e}");
}

#[test]
fn projection_scheme_is_order_2() {
    check_order(None, 2.0, &[0.4, 0.2, 0.1, 0.05, 0.025], 20.0);
}

/// The paper's §2 scheme: projection half-steps around the implicit-midpoint flow of
/// `H_N1 = H + μ g`. Order 2, residuals at round-off every step — with the generic
/// `ModifiedHamiltonian` (Newton matrix by differences) and with the closed-form
/// `paper::ModifiedEnergy` (exact Newton matrix): the same map, so the same errors up to the
/// Newton tolerance.
#[test]
fn modified_hamiltonian_scheme_is_order_2() {
    let hs = [0.4, 0.2, 0.1, 0.05, 0.025];
    let generic = modified_errors(&hs, paper::modified_hamiltonian::<V4>);
    let closed = modified_errors(&hs, paper::modified_energy);
    for (what, errs) in [("generic", &generic), ("closed form", &closed)] {
        let p = fitted_order(&hs, errs, 1e-12);
        eprintln!("modified ({what}): errors = {errs:?}, fitted order {p:.3}");
        assert!((p - 2.0).abs() <= 0.1, "{what}: fitted order {p}");
    }
    for (a, b) in generic.iter().zip(&closed) {
        // Both solve the same equations to the Newton tolerance (2 ε) per step; over up to
        // 800 steps of a stable motion that stays far below the errors (≥ 1e-5).
        assert!((a - b).abs() <= 1e-10 * a.abs().max(1.0), "{a:e} vs {b:e}");
    }
}

fn modified_errors<H: Hamiltonian<V4>>(hs: &[f64], make: impl Fn() -> H) -> Vec<f64> {
    use lieflow::flow::ImplicitMidpoint;
    use lieflow::nonlinear::NewtonOptions;
    let t_end = 20.0;
    let r = paper::reference(t_end, -0.15, 1e-3);
    hs.iter()
        .map(|&h| {
            let mut x: V4 = paper::initial_state();
            let inner: ImplicitMidpoint<V4, _, _> =
                ImplicitMidpoint::try_new(paper::Structure, make(), &x, NewtonOptions::default())
                    .unwrap();
            let mut f = inner
                .projected(paper::system(), &x, ProjectionOptions::default())
                .unwrap();
            let sys = paper::system();
            let (mut t1, mut t2) = (V4::zeros(), V4::zeros());
            for _ in 0..(t_end / h).round() as usize {
                f.step(h, &mut x).unwrap();
                let (mut g, mut phi) = ([0.0], [0.0]);
                sys.constraint.residual(&x, &mut g);
                sys.hidden_constraint(&x, &mut t1, &mut t2, &mut phi);
                assert!(g[0].abs() <= 4.0 * f64::EPSILON && phi[0].abs() <= 4.0 * f64::EPSILON);
            }
            (0..4).map(|i| (x[i] - r[i]).abs()).fold(0.0, f64::max)
        })
        .collect()
}

/// The closed-form μ of the paper model agrees with the finite-difference brackets.
#[test]
fn closed_form_modified_multiplier_matches_the_brackets() {
    let sys = paper::system();
    let brackets = lieflow::system::Brackets::new(&sys);
    for th in [0.0f64, 0.7, 2.0] {
        let (s, c) = th.sin_cos();
        let x = V4::new(c, s, -0.3 * s, 0.3 * c);
        let fd = brackets.modified_multiplier(&x, Case::Degenerate).unwrap();
        let mut mu = [0.0];
        paper::modified_multiplier(&x, &mut mu);
        assert!(
            (fd[0] - mu[0]).abs() <= 1e-7 * mu[0].abs(),
            "{} vs {}",
            fd[0],
            mu[0]
        );
    }
}

#[test]
fn triple_jump_is_order_4() {
    check_order(Some(&TRIPLE_JUMP), 4.0, &[0.8, 0.4, 0.2, 0.1], 40.0);
}

#[test]
fn suzuki_is_order_4() {
    check_order(Some(&SUZUKI4), 4.0, &[0.8, 0.4, 0.2, 0.1], 40.0);
}

#[test]
fn yoshida6_is_order_6() {
    check_order(Some(&YOSHIDA6), 6.0, &[1.6, 0.8, 0.4, 0.2], 32.0);
}

#[test]
fn kahan_li6_is_order_6() {
    check_order(Some(&KAHAN_LI6), 6.0, &[1.6, 0.8, 0.4, 0.2], 32.0);
}

#[test]
fn suzuki_umeno8_is_order_8() {
    check_order(Some(&SUZUKI_UMENO8), 8.0, &[2.0, 1.6, 1.25, 1.0, 0.8], 80.0);
}

// Kahan–Li 8 minimizes its leading error constant, so at every step size whose f64 error is
// above the round-off floor the h^10 term still bends the log-log slope (measured 8.38 over
// h = 1.6 … 0.625, T = 400). Its order is measured in double-double below.

#[test]
fn symmetric_projection_is_order_2_on_a_non_degenerate_model() {
    // h |λ| must stay well below 1 for the fixed point of the implicit end point.
    let t_end = 1.0;
    let r = gradient_sphere::reference(t_end, 100_000);
    let hs = [0.1, 0.05, 0.025, 0.0125];
    let errs: Vec<f64> = hs
        .iter()
        .map(|&h| {
            let mut f = gradient_sphere::projected();
            let mut x: V3 = gradient_sphere::x0();
            for _ in 0..(t_end / h).round() as usize {
                f.step(h, &mut x).unwrap();
            }
            (x - r).amax()
        })
        .collect();
    let p = fitted_order(&hs, &errs, 1e-12);
    eprintln!("symmetric projection: errors {errs:?}, order {p:.3}");
    assert!((p - 2.0).abs() <= 0.3, "order {p}");
}

/// The same order check in double-double arithmetic (`twofloat`, ~32 digits): the library is
/// generic over the scalar, so the round-off floor drops from ~1e-13 to ~1e-28 and the order-8
/// tables can be measured at step sizes where their `h^8` term dominates. The reference is the
/// index-reduced ODE `x₃' = −x₁μ, x₄' = −2x₂μ`, `μ = (x₃² + x₄²)/(x₁² + 2x₂²)` (the paper's
/// degenerate-case multiplier), integrated by RK4 in double-double with a tiny step.
mod double_double {
    use super::*;
    use nalgebra::SVector;
    use twofloat::TwoFloat;

    type T = TwoFloat;
    type V = SVector<T, 4>;

    fn reference(t_end: f64, n: usize) -> V {
        let f = |x: &V| {
            let mu = (x[2] * x[2] + x[3] * x[3]) / (x[0] * x[0] + T::from(2.0) * x[1] * x[1]);
            V::new(x[2], x[3], -x[0] * mu, -T::from(2.0) * x[1] * mu)
        };
        let dt = T::from(t_end) / T::from(n as f64);
        let half = dt * T::from(0.5);
        let mut x: V = paper::initial_state();
        for _ in 0..n {
            let k1 = f(&x);
            let k2 = f(&(x + k1 * half));
            let k3 = f(&(x + k2 * half));
            let k4 = f(&(x + k3 * dt));
            x += (k1 + k2 * T::from(2.0) + k3 * T::from(2.0) + k4) * (dt / T::from(6.0));
        }
        x
    }

    fn error(table: &'static CompositionTable, h: f64, t_end: f64, r: &V) -> f64 {
        let mut x: V = paper::initial_state();
        // twofloat's `epsilon()` is f64::MIN_POSITIVE, not the double-double unit round-off,
        // so the tolerances derived from it by default are set explicitly.
        let newton = lieflow::nonlinear::NewtonOptions::default()
            .with_ftol(T::from(1e-30))
            .with_xtol(T::from(1e-31))
            .with_fd_step(T::from(1e-16));
        let mut f = paper::drift()
            .projected(
                paper::system(),
                &x,
                ProjectionOptions::default().with_newton(newton),
            )
            .unwrap()
            .composed(table);
        let steps = (t_end / h).round() as usize;
        for _ in 0..steps {
            f.step(T::from(h), &mut x).unwrap();
        }
        (0..4)
            .map(|i| f64::from((x[i] - r[i]).abs()))
            .fold(0.0, f64::max)
    }

    fn check(table: &'static CompositionTable) {
        let t_end = 20.0;
        let r = reference(t_end, 200_000);
        let r2 = reference(t_end, 400_000);
        let ref_err = (0..4)
            .map(|i| f64::from((r[i] - r2[i]).abs()))
            .fold(0.0, f64::max);
        let hs = [1.0, 0.8, 0.5, 0.4, 0.25];
        let errs: Vec<f64> = hs.iter().map(|&h| error(table, h, t_end, &r)).collect();
        let p = fitted_order(&hs, &errs, 1e3 * ref_err.max(1e-30));
        eprintln!(
            "{} (double-double): reference error {ref_err:e}, errors = {errs:?}, fitted order {p:.3}",
            table.name
        );
        assert!(
            (p - 8.0).abs() <= 0.3,
            "{}: fitted order {p:.3}",
            table.name
        );
    }

    #[test]
    fn kahan_li8_is_order_8_in_double_double() {
        check(&KAHAN_LI8);
    }

    #[test]
    fn suzuki_umeno8_is_order_8_in_double_double() {
        check(&SUZUKI_UMENO8);
    }
}

#[test]
fn closed_form_reference_agrees_with_the_integrated_one() {
    // exact() inverts t(θ) from a spectrally accurate quadrature; reference() integrates the
    // angle ODE by RK4 (error O(dt⁴ t)). At t = 0 both are the initial state; at t = 40 the RK4
    // reference is converged to 1e-13 (test above), so the two must agree to that level.
    let x0 = paper::exact(0.0, -0.15);
    let d0 = (0..4)
        .map(|i| (x0[i] - [1.0, 0.0, 0.0, -0.15][i]).abs())
        .fold(0.0, f64::max);
    assert!(d0 <= 4.0 * f64::EPSILON, "exact(0) = {x0:?}");
    for t in [40.0, 1000.0] {
        let a = paper::exact(t, -0.15);
        let b = paper::reference(t, -0.15, 1e-3);
        let d = (0..4).map(|i| (a[i] - b[i]).abs()).fold(0.0, f64::max);
        eprintln!("t = {t}: |exact - rk4| = {d:e}");
        // RK4's own error grows like t dt⁴ (2.5e-14 per unit time here, measured at t = 40).
        assert!(d < 1e-13 * (1.0 + t / 40.0), "t = {t}: {d:e}");
        // On the manifold: g = 0, phi = 0, H~ = v0²/4.
        let g = 0.5 * (a[0] * a[0] + a[1] * a[1] - 1.0);
        let phi = a[0] * a[2] + a[1] * a[3];
        let h = 0.5 * (a[2] * a[2] + 0.5 * a[3] * a[3]);
        assert!(g.abs() < 4e-16 && phi.abs() < 1e-16, "{g:e} {phi:e}");
        assert!((h - 0.25 * 0.15 * 0.15).abs() < 1e-16, "{h:e}");
    }
}
