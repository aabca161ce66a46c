//! The small decoupled path (full Newton on stack arrays with closed-form Jacobians, one linear
//! solve for an affine `λ_{k+1}` system) against the general path (kept, Broyden-updated
//! difference Jacobians), and `SmallNewton` on problems with known roots.

use lieflow::error::{LinearSolveError, NewtonError, StepError};
use lieflow::models::paper;
use lieflow::nonlinear::{NewtonOptions, NonlinearProblem, NonlinearSolver, SmallNewton};
use lieflow::prelude::*;
use nalgebra::SVector;

use crate::common;

type V = SVector<f64, 4>;

use common::PaperNoHessian as NoHessian;

/// The paper's Hamiltonian with its Hessian but not declared quadratic: the small path with
/// Newton iterations for `λ_{k+1}` instead of one linear solve.
struct NotDeclaredQuadratic;

impl Hamiltonian<V> for NotDeclaredQuadratic {
    fn energy(&self, x: &V) -> f64 {
        Hamiltonian::<V>::energy(&paper::Energy, x)
    }
    fn gradient(&self, x: &V, out: &mut V) {
        Hamiltonian::<V>::gradient(&paper::Energy, x, out)
    }
    fn hessian_apply(&self, x: &V, v: &V, out: &mut V) -> bool {
        Hamiltonian::<V>::hessian_apply(&paper::Energy, x, v, out)
    }
}

fn run<H: Hamiltonian<V>>(hamiltonian: H, scheme: Option<&'static str>) -> (V, f64, f64, bool) {
    let x0: V = paper::initial_state();
    let system = System::new(paper::Structure, hamiltonian, paper::Circle);
    let projected = paper::drift()
        .projected(system, &x0, ProjectionOptions::default())
        .unwrap();
    let small = projected.uses_small_path();
    let mut flow: Box<dyn Flow<V>> = match scheme {
        None => Box::new(projected),
        Some(name) => {
            Box::new(projected.composed(lieflow::flow::coefficients::table_by_name(name).unwrap()))
        }
    };
    let (mut x, mut max_g, mut max_phi) = (x0, 0.0f64, 0.0f64);
    for _ in 0..1000 {
        flow.step(0.1, &mut x).unwrap();
        max_g = max_g.max((0.5 * (x[0] * x[0] + x[1] * x[1] - 1.0)).abs());
        max_phi = max_phi.max((x[0] * x[2] + x[1] * x[3]).abs());
    }
    (x, max_g, max_phi, small)
}

/// All three paths solve the same equations to round-off, so they agree to round-off
/// accumulated over 1000 steps (the trajectory is not chaotic: the error grows linearly).
#[test]
fn small_and_general_paths_agree() {
    for scheme in [None, Some("triple-jump"), Some("kahan-li8")] {
        let (general, g0, p0, s0) = run(NoHessian, scheme);
        let (newton, g1, p1, s1) = run(NotDeclaredQuadratic, scheme);
        let (affine, g2, p2, s2) = run(paper::Energy, scheme);
        assert!(!s0 && s1 && s2, "{scheme:?}: paths {s0} {s1} {s2}");
        for (name, x) in [("newton", newton), ("affine", affine)] {
            let d = (x - general).amax();
            assert!(d < 1e-12, "{scheme:?} {name}: differs by {d:e}");
        }
        for (g, phi) in [(g0, p0), (g1, p1), (g2, p2)] {
            // g at round-off: |g| ≤ 100 ftol is Newton's noise floor (ftol = 2ε).
            assert!(g <= 200.0 * f64::EPSILON, "{scheme:?}: |g| = {g:e}");
            assert!(phi <= 200.0 * f64::EPSILON, "{scheme:?}: |phi| = {phi:e}");
        }
    }
}

/// The affine `λ_{k+1}` system costs one evaluation and one solve; `λ_k` from a good warm
/// start about two evaluations.
#[test]
fn small_path_evaluation_counts() {
    let x0: V = paper::initial_state();
    let mut flow = paper::drift()
        .projected(paper::system(), &x0, ProjectionOptions::default())
        .unwrap();
    let mut x = x0;
    for _ in 0..1000 {
        flow.step(0.1, &mut x).unwrap();
    }
    let s = flow.stats();
    let per_step = s.residual_evaluations as f64 / s.projected_steps as f64;
    // λ_k: ≥ 1 evaluation (2 when one Newton update is needed); λ_{k+1}: exactly 1.
    assert!(
        (2.0..=3.5).contains(&per_step),
        "{per_step} evaluations per step"
    );
}

/// `F(z) = (z₁² + z₂² − 4, z₁ − z₂)` with its exact Jacobian: root `(√2, √2)`.
struct Circle {
    exact: bool,
}

impl NonlinearProblem<f64> for Circle {
    type Error = StepError;
    fn dim(&self) -> usize {
        2
    }
    fn residual(&mut self, z: &[f64], f: &mut [f64]) -> Result<(), StepError> {
        f[0] = z[0] * z[0] + z[1] * z[1] - 4.0;
        f[1] = z[0] - z[1];
        Ok(())
    }
    fn jacobian_column(&mut self, z: &[f64], j: usize, out: &mut [f64]) -> bool {
        if !self.exact {
            // A poor guess: half the true first row. Newton must notice and difference.
            out[0] = z[j];
            out[1] = if j == 0 { 1.0 } else { -1.0 };
            return true;
        }
        out[0] = 2.0 * z[j];
        out[1] = if j == 0 { 1.0 } else { -1.0 };
        true
    }
}

#[test]
fn small_newton_converges_quadratically_with_exact_columns() {
    let mut newton = SmallNewton::new(2, NewtonOptions::default()).unwrap();
    let mut z = [1.0, 2.0];
    let report = newton.solve(&mut Circle { exact: true }, &mut z).unwrap();
    let r = 2f64.sqrt();
    assert!((z[0] - r).abs() <= 2.0 * f64::EPSILON && (z[1] - r).abs() <= 2.0 * f64::EPSILON);
    // Quadratic convergence from distance ~0.6: 0.6 → 0.1 → 4e-3 → 6e-6 → 1e-11 → round-off.
    assert!(report.iterations <= 6, "{report:?}");
    assert_eq!(report.residual_evaluations, report.iterations + 1);
}

/// The same circle with its constant second derivatives (`∂²F₁ = 2I`, `∂²F₂ = 0`): the first
/// iteration takes the root of the exact quadratic model, which is the root of `F` itself, so
/// one iteration converges where Newton needs several.
struct QuadraticCircle;

impl NonlinearProblem<f64> for QuadraticCircle {
    type Error = StepError;
    fn dim(&self) -> usize {
        2
    }
    fn residual(&mut self, z: &[f64], f: &mut [f64]) -> Result<(), StepError> {
        Circle { exact: true }.residual(z, f)
    }
    fn jacobian_column(&mut self, z: &[f64], j: usize, out: &mut [f64]) -> bool {
        Circle { exact: true }.jacobian_column(z, j, out)
    }
    fn second_derivative(&mut self, _z: &[f64], j: usize, k: usize, out: &mut [f64]) -> bool {
        out[0] = if j == k { 2.0 } else { 0.0 };
        out[1] = 0.0;
        true
    }
}

#[test]
fn small_newton_solves_a_quadratic_residual_in_one_iteration() {
    let mut newton = SmallNewton::new(2, NewtonOptions::default()).unwrap();
    let mut z = [1.0, 2.0];
    let report = newton.solve(&mut QuadraticCircle, &mut z).unwrap();
    let r = 2f64.sqrt();
    assert!((z[0] - r).abs() <= 2.0 * f64::EPSILON && (z[1] - r).abs() <= 2.0 * f64::EPSILON);
    assert_eq!(report.iterations, 1, "{report:?}");
    assert_eq!(report.residual_evaluations, 2);
    // Without the second derivatives the same start takes Newton's quadratic convergence.
    let mut z = [1.0, 2.0];
    let plain = newton.solve(&mut Circle { exact: true }, &mut z).unwrap();
    assert!(plain.iterations >= 4, "{plain:?}");
}

/// `F(z) = ½ a z² + b z + c` with its exact derivatives: one unknown, exactly quadratic.
struct Parabola {
    a: f64,
    b: f64,
    c: f64,
}

impl NonlinearProblem<f64> for Parabola {
    type Error = StepError;
    fn dim(&self) -> usize {
        1
    }
    fn residual(&mut self, z: &[f64], f: &mut [f64]) -> Result<(), StepError> {
        f[0] = 0.5 * self.a * z[0] * z[0] + self.b * z[0] + self.c;
        Ok(())
    }
    fn jacobian_column(&mut self, z: &[f64], _j: usize, out: &mut [f64]) -> bool {
        out[0] = self.a * z[0] + self.b;
        true
    }
    fn second_derivative(&mut self, _z: &[f64], _j: usize, _k: usize, out: &mut [f64]) -> bool {
        out[0] = self.a;
        true
    }
}

/// One unknown, exactly quadratic: the root nearest the Newton step in closed form, one
/// iteration; and where the parabola has no real root (`b² < 2ac`), a [`NewtonError::NoRoot`]
/// after one evaluation and no iteration — where Newton used to iterate and halve to its
/// limit (25 iterations) before failing.
#[test]
fn small_newton_takes_a_scalar_quadratics_root_or_fails_at_once() {
    let mut newton = SmallNewton::new(1, NewtonOptions::default()).unwrap();
    // ½ z² − 3z + 2 = 0: roots 3 ± √5; from 0 the Newton step is 2/3, nearest 3 − √5.
    let mut z = [0.0];
    let mut p = Parabola {
        a: 1.0,
        b: -3.0,
        c: 2.0,
    };
    let report = newton.solve(&mut p, &mut z).unwrap();
    let root = 3.0 - 5f64.sqrt();
    assert!((z[0] - root).abs() <= 2.0 * f64::EPSILON, "{z:?}");
    assert_eq!((report.iterations, report.quadratic_steps), (1, 1));
    // ½ z² + 1 = 0 has no real root: refused at once, with its numbers.
    let mut z = [0.5];
    let mut p = Parabola {
        a: 1.0,
        b: 0.0,
        c: 1.0,
    };
    match newton.solve(&mut p, &mut z) {
        Err(NewtonError::NoRoot {
            residual,
            discriminant,
        }) => {
            assert!((residual - 1.125).abs() <= 1e-15);
            // J² − 2cF = 0.25 − 2.25 = −2, over J² = 0.25.
            assert!((discriminant + 8.0).abs() <= 1e-14, "{discriminant}");
        }
        other => panic!("expected NoRoot, got {other:?}"),
    }
}

#[test]
fn small_newton_falls_back_to_differences_for_a_poor_jacobian() {
    let mut newton = SmallNewton::new(2, NewtonOptions::default()).unwrap();
    let mut z = [1.0, 2.0];
    let report = newton.solve(&mut Circle { exact: false }, &mut z).unwrap();
    let r = 2f64.sqrt();
    assert!((z[0] - r).abs() <= 4.0 * f64::EPSILON && (z[1] - r).abs() <= 4.0 * f64::EPSILON);
    // Differences cost extra evaluations: more than one per iteration.
    assert!(
        report.residual_evaluations > report.iterations + 1,
        "{report:?}"
    );
}

/// `F(z) = A z − b` with a singular `A`: a typed error naming the pivot, no panic.
struct Singular;

impl NonlinearProblem<f64> for Singular {
    type Error = StepError;
    fn dim(&self) -> usize {
        2
    }
    fn residual(&mut self, z: &[f64], f: &mut [f64]) -> Result<(), StepError> {
        f[0] = z[0] + z[1] - 1.0;
        f[1] = 2.0 * z[0] + 2.0 * z[1] - 3.0;
        Ok(())
    }
    fn jacobian_column(&mut self, _z: &[f64], j: usize, out: &mut [f64]) -> bool {
        let _ = j;
        out[0] = 1.0;
        out[1] = 2.0;
        true
    }
}

#[test]
fn small_newton_reports_a_singular_jacobian() {
    let mut newton = SmallNewton::new(2, NewtonOptions::default()).unwrap();
    let mut z = [0.0, 0.0];
    let err = newton.solve(&mut Singular, &mut z).unwrap_err();
    assert!(
        matches!(
            err,
            NewtonError::Linear(LinearSolveError::Singular { pivot: 1, .. })
        ),
        "{err:?}"
    );
    assert!(SmallNewton::<f64>::new(0, NewtonOptions::default()).is_none());
    assert!(SmallNewton::<f64>::new(5, NewtonOptions::default()).is_none());
}

/// An affine system is solved by one linear solve, without an evaluation at the result.
#[test]
fn small_newton_solves_an_affine_system_in_one_solve() {
    struct Affine;
    impl NonlinearProblem<f64> for Affine {
        type Error = StepError;
        fn dim(&self) -> usize {
            2
        }
        fn residual(&mut self, z: &[f64], f: &mut [f64]) -> Result<(), StepError> {
            f[0] = 3.0 * z[0] + z[1] - 5.0;
            f[1] = z[0] - 2.0 * z[1] + 3.0;
            Ok(())
        }
        fn jacobian_column(&mut self, _z: &[f64], j: usize, out: &mut [f64]) -> bool {
            out.copy_from_slice(if j == 0 { &[3.0, 1.0] } else { &[1.0, -2.0] });
            true
        }
    }
    let newton = SmallNewton::new(2, NewtonOptions::default()).unwrap();
    let mut z = [0.0, 0.0];
    let report = newton.solve_affine_fixed(&mut Affine, &mut z).unwrap();
    // Root (1, 2); the elimination rounds to within a few ulps.
    assert!((z[0] - 1.0).abs() <= 4.0 * f64::EPSILON && (z[1] - 2.0).abs() <= 8.0 * f64::EPSILON);
    assert_eq!(
        (
            report.iterations,
            report.residual_evaluations,
            report.factorizations
        ),
        (1, 1, 1)
    );
}
