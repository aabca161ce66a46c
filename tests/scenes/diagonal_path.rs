//! Independent unknowns: `DiagonalNewton` takes the root of each unknown's quadratic model in one
//! iteration, converges quadratically without it, differences the diagonal when no product is
//! given; and on a scene of particles each on its own sphere the projection solves each
//! multiplier system in one iteration, with one pair-force sum per base step of an extrapolation
//! (the rows' common first force computed once).

use crate::scene_text;

use lieflow::error::{LinearSolveError, NewtonError};
use lieflow::nonlinear::{DiagonalNewton, NewtonOptions, NonlinearProblem, NonlinearSolver};
use scene_text::{parse, run_scene};

/// `F_i(z) = a_i z_i² + b_i z_i + c_i`, independent unknowns, with its diagonal product
/// (`products`) and its curvatures (`curvature`) in closed form when asked.
struct Quadratics {
    a: Vec<f64>,
    b: Vec<f64>,
    c: Vec<f64>,
    products: bool,
    curvature: bool,
    evaluations: usize,
}

impl Quadratics {
    fn new(products: bool, curvature: bool) -> Self {
        Self {
            a: vec![0.3, -0.7, 1.5, 0.05, -2.0],
            b: vec![1.0, 2.0, -1.5, 0.8, 3.0],
            c: vec![-0.4, 0.9, 0.2, -0.3, 1.1],
            products,
            curvature,
            evaluations: 0,
        }
    }

    /// Each unknown's root nearest `0` (the one Newton from `0` approaches): the closed form
    /// without cancellation, `−2c / (b + sgn(b) √(b² − 4ac))`.
    fn roots(&self) -> Vec<f64> {
        (0..self.a.len())
            .map(|i| {
                let (a, b, c) = (self.a[i], self.b[i], self.c[i]);
                -2.0 * c / (b + (b * b - 4.0 * a * c).sqrt().copysign(b))
            })
            .collect()
    }
}

impl NonlinearProblem<f64> for Quadratics {
    type Error = ();
    fn dim(&self) -> usize {
        self.a.len()
    }
    fn residual(&mut self, z: &[f64], f: &mut [f64]) -> Result<(), ()> {
        self.evaluations += 1;
        for i in 0..self.a.len() {
            f[i] = (self.a[i] * z[i] + self.b[i]) * z[i] + self.c[i];
        }
        Ok(())
    }
    fn jacobian_group(&mut self, z: &[f64], cols: &[usize], out: &mut [f64]) -> bool {
        if !self.products {
            return false;
        }
        out.iter_mut().for_each(|v| *v = 0.0);
        for &j in cols {
            out[j] = 2.0 * self.a[j] * z[j] + self.b[j];
        }
        true
    }
    fn curvature_group(&mut self, _z: &[f64], cols: &[usize], out: &mut [f64]) -> bool {
        if !self.curvature {
            return false;
        }
        out.iter_mut().for_each(|v| *v = 0.0);
        for &j in cols {
            out[j] = 2.0 * self.a[j];
        }
        true
    }
}

fn options() -> NewtonOptions<f64> {
    NewtonOptions::default()
}

fn max_rel(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs() / y.abs())
        .fold(0.0, f64::max)
}

/// With the curvatures every unknown steps to its model's root, which for a quadratic is the
/// root: one iteration, two evaluations (start and check), the root to rounding.
#[test]
fn independent_quadratics_take_one_iteration() {
    let mut p = Quadratics::new(true, true);
    let mut solver = DiagonalNewton::new(5, options());
    let mut z = vec![0.0; 5];
    let report = solver.solve(&mut p, &mut z).unwrap();
    assert_eq!(report.iterations, 1, "{report:?}");
    assert_eq!(report.quadratic_steps, 1, "{report:?}");
    assert_eq!(p.evaluations, 2);
    let err = max_rel(&z, &p.roots());
    assert!(err <= 8.0 * f64::EPSILON, "relative error {err:e}");
    assert!(!solver.needs_differences());
}

/// Without them, Newton with the exact diagonal: quadratic convergence from `0` to the same
/// roots (the error squares each iteration: six iterations reach rounding from `O(1)`).
#[test]
fn without_curvatures_newton_converges_quadratically() {
    let mut p = Quadratics::new(true, false);
    let mut solver = DiagonalNewton::new(5, options());
    let mut z = vec![0.0; 5];
    let report = solver.solve(&mut p, &mut z).unwrap();
    assert!(
        (2..=6).contains(&report.iterations),
        "iterations {report:?}"
    );
    assert_eq!(report.quadratic_steps, 0);
    let err = max_rel(&z, &p.roots());
    assert!(err <= 8.0 * f64::EPSILON, "relative error {err:e}");
}

/// Without a product the diagonal is differenced (one extra evaluation an iteration) and the
/// solver says so, for a caller to switch to a kept Jacobian.
#[test]
fn without_products_the_diagonal_is_differenced() {
    let mut p = Quadratics::new(false, false);
    let mut solver = DiagonalNewton::new(5, options());
    let mut z = vec![0.0; 5];
    let report = solver.solve(&mut p, &mut z).unwrap();
    assert!(solver.needs_differences());
    assert_eq!(
        report.residual_evaluations,
        1 + 2 * report.iterations,
        "{report:?}"
    );
    // Differences at √ε: the root to the tolerance, not to rounding.
    let err = max_rel(&z, &p.roots());
    assert!(err <= 1e-12, "relative error {err:e}");
}

/// A zero diagonal entry is a typed error, not a division by zero.
#[test]
fn a_zero_diagonal_is_singular() {
    let mut p = Quadratics::new(true, false);
    p.b[2] = 0.0; // J_22 = 2 a z + b = 0 at z = 0
    let mut solver = DiagonalNewton::new(5, options());
    let mut z = vec![0.0; 5];
    let err = solver.solve(&mut p, &mut z).unwrap_err();
    assert!(
        matches!(
            err,
            NewtonError::Linear(LinearSolveError::Singular { pivot: 2, .. })
        ),
        "{err:?}"
    );
}

/// Ten damped particles, each on its own sphere, extrapolated to order 8 at H = 0.25: each
/// base step's `λ_k` system (quadratic: a potential's kick and a free flight are affine in the
/// momenta, the spheres quadratic) and `λ_{k+1}` system (affine) take one iteration, the macro
/// step's re-projection at most two, and the pair forces are summed once a base step plus once
/// for the rows' common start: 10 + 1.
#[test]
fn the_shell_solves_each_multiplier_system_in_one_iteration() {
    let text =
        // No diagnostics: an energy observation would evaluate the pair term too.
        include_str!("../../scenes/shell_damped.toml")
            .replace("dt = 0.01", "dt = 0.25\norder = 8\ndiagnostics = []");
    let summary = run_scene(&parse(&text));
    assert!(summary.error.is_none(), "{:?}", summary.error);
    let steps = summary.steps as u64;
    assert_eq!(steps, 20);
    assert!(
        summary.newton_iterations <= 22 * steps,
        "{} Newton iterations in {steps} macro steps",
        summary.newton_iterations
    );
    let pair = summary
        .effects
        .iter()
        .find(|e| e.kind == "pair")
        .expect("a pair term");
    assert!(
        pair.evaluations <= 11 * steps + 1,
        "{} pair sums in {steps} macro steps",
        pair.evaluations
    );
}

/// The projection's state beyond its multipliers — the diagonal solver in use, `λ_k` from zero —
/// is memory: a run restored from a save continues bit for bit, in the same stepper and in a
/// new one, on the moving shell with independent constraints, projected and extrapolated.
#[test]
fn a_checkpoint_of_the_shell_continues_bit_for_bit() {
    use lieflow::prelude::*;
    use lieflow::scene::{FreeFlight, Kick};
    let (model, x0) = scene_text::moving_shell("");
    let system = || System::new(model.clone(), model.clone(), model.clone());
    for order in [2, 8] {
        let make = || -> Box<dyn Flow<faer::Col<f64>>> {
            let projected = Kick::new(model.clone())
                .strang(FreeFlight::new(model.clone()))
                .projected(system(), &x0, ProjectionOptions::default())
                .unwrap();
            if order == 2 {
                Box::new(projected)
            } else {
                Box::new(projected.extrapolated(order).unwrap())
            }
        };
        let h = 0.25;
        let mut s = Stepper::new(make(), x0.clone(), 0.0, h).unwrap();
        for _ in 0..6 {
            s.step().unwrap();
        }
        let checkpoint = s.save();
        let run = |s: &mut Stepper<faer::Col<f64>, Box<dyn Flow<faer::Col<f64>>>>| {
            (0..6)
                .map(|_| {
                    s.step().unwrap();
                    s.state().clone()
                })
                .collect::<Vec<_>>()
        };
        let first = run(&mut s);
        s.restore(&checkpoint).unwrap();
        assert!(first == run(&mut s), "order {order}: restored run differs");
        let mut other = Stepper::new(make(), x0.clone(), 0.0, h).unwrap();
        other.restore(&checkpoint).unwrap();
        assert!(
            first == run(&mut other),
            "order {order}: run restored into a new stepper differs"
        );
    }
}
