//! The Schur iteration on a linear problem whose left-out block is known: the relaxation
//! reaches the rate theory gives for the spectrum (module docs of `schur`).

use super::{ReducedBlocks, SchurIteration};
use crate::error::StepError;
use crate::linalg::DenseLu;
use crate::nonlinear::{NewtonOptions, NonlinearProblem, SolveReport};

/// `F(z) = J z − b` on `(q₁, q₂, q₃, ν)`, `J = [[I + E, Gᵀ], [G, 0]]`, `G = [0, 0, 1]`,
/// `E = diag(e, e, 0)`: the iteration's matrix has `I` where `J` has `I + E` (as a taut chain's
/// has no geometric stiffness), so its error propagates by `−e` on the tangent directions.
struct Linear {
    e: f64,
    b: [f64; 4],
}

impl NonlinearProblem<f64> for Linear {
    type Error = StepError;
    fn dim(&self) -> usize {
        4
    }
    fn residual(&mut self, z: &[f64], f: &mut [f64]) -> Result<(), StepError> {
        f[0] = (1.0 + self.e) * z[0] - self.b[0];
        f[1] = (1.0 + self.e) * z[1] - self.b[1];
        f[2] = z[2] + z[3] - self.b[2];
        f[3] = z[2] - self.b[3];
        Ok(())
    }
}

impl ReducedBlocks<f64> for Linear {
    fn multiplier_columns_add(&mut self, v: &[f64], out: &mut [f64]) {
        out[2] += v[0];
    }
    fn constraint_rows(&mut self, v: &[f64], out: &mut [f64]) {
        out[0] = v[2];
    }
}

/// Iterations to the root from `z = 0`, and the largest error there.
fn solve(e: f64) -> (usize, f64) {
    let options = NewtonOptions {
        max_contraction: 0.5,
        max_iterations: 60,
        ..NewtonOptions::default()
    };
    let mut schur: SchurIteration<f64, DenseLu<f64>> =
        SchurIteration::new(&[1.0; 3], &[], 1, Some(&[(0, 2)]), options, &[0.5]).unwrap();
    schur.begin(0.1);
    assert!(schur.ready());
    let b = [1.0, -0.5, 0.5, 0.25];
    let mut problem = Linear { e, b };
    let mut z = [0.0; 4];
    let mut report = SolveReport::default();
    assert!(schur.solve(&mut problem, &mut z, &mut report).unwrap());
    let exact = [b[0] / (1.0 + e), b[1] / (1.0 + e), b[3], b[2] - b[3]];
    let err = z
        .iter()
        .zip(&exact)
        .fold(0.0f64, |a, (z, x)| a.max((z - x).abs()));
    (report.iterations, err)
}

/// `e = 0.4`: the unrelaxed iteration contracts by 0.4 and needs ≥ 35 iterations from a unit
/// residual to `~7e-15` (ln(1.4e14)/ln 2.5); with `ω = 2/(2 + 0.4)` the rate is `0.4/2.4 = 1/6`
/// once `μ` is estimated (after two updates): ≤ 2 + ln(1.4e14)/ln 6 ≈ 20.1. A wrong estimate
/// (the relaxed update kept as the last one, or `μ` without the division by `ω`) takes more.
#[test]
fn relaxation_contracts_an_alternating_error_at_the_optimal_rate() {
    let (iterations, err) = solve(0.4);
    assert!(err <= 1e-14, "error {err:e}");
    assert!(iterations <= 21, "{iterations} iterations");
}

/// `e = −0.4` (a spectrum of the other sign, `+0.4`): `ω = 2/1.6` over-relaxes, rate `0.25`:
/// ≤ 2 + ln(1.4e14)/ln 4 ≈ 25.5 against the unrelaxed ≥ 35.
#[test]
fn relaxation_contracts_a_monotone_error_faster() {
    let (iterations, err) = solve(-0.4);
    assert!(err <= 1e-14, "error {err:e}");
    assert!(iterations <= 26, "{iterations} iterations");
}

/// `e = 0.8` (a hanging chain of 10⁴ links of 1 g at `h = 10⁻⁴` has `μ ≈ −0.8`): unrelaxed the
/// error shrinks by 0.8, more than the bound 0.5 allows; with `ω = 2/2.8` by `0.8/2.8 = 2/7`.
/// The first update is unrelaxed (it moves the error by `e`) and the next one relaxed by a
/// first estimate: ≤ 3 + ln(1.4e14 · 0.8)/ln 3.5 ≈ 28.8 (measured 28). A clamp of the estimate
/// at `μ = −½` (`ω = 0.8`, rate 0.44) takes 42.
#[test]
fn relaxation_keeps_a_strongly_alternating_error_in_the_iteration() {
    let (iterations, err) = solve(0.8);
    assert!(err <= 1e-14, "error {err:e}");
    assert!(iterations <= 29, "{iterations} iterations");
}

/// `e = 1.5`: the unrelaxed iteration diverges (its error grows by 1.5); relaxed by
/// `ω = 2/3.5` it contracts by `1.5/3.5 = 3/7`. As above, ≤ 3 + ln(1.4e14 · 1.5)/ln(7/3) ≈ 42.0
/// (measured 41); with the clamp at `μ = −½` the iteration stops contracting and hands over.
#[test]
fn relaxation_contracts_an_error_the_plain_iteration_amplifies() {
    let (iterations, err) = solve(1.5);
    assert!(err <= 1e-14, "error {err:e}");
    assert!(iterations <= 42, "{iterations} iterations");
}

/// Nothing left out (`e = 0`): the first update is the root.
#[test]
fn an_exact_iteration_matrix_converges_at_once() {
    let (iterations, err) = solve(0.0);
    assert!(err <= 1e-15, "error {err:e}");
    assert!(iterations <= 2, "{iterations} iterations");
}

/// Solves from `x* + offset` for each of `offsets`, consecutive steps with the prediction
/// trusted: the residual evaluations of each solve and the largest residual at what each
/// returned.
fn trusted(e: f64, offsets: &[f64]) -> (Vec<usize>, f64) {
    let options = NewtonOptions {
        max_contraction: 0.5,
        ..NewtonOptions::default()
    };
    let mut schur: SchurIteration<f64, DenseLu<f64>> =
        SchurIteration::new(&[1.0; 3], &[], 1, Some(&[(0, 2)]), options, &[0.5]).unwrap();
    schur.trust_contraction();
    schur.begin(0.1);
    let b = [1.0, -0.5, 0.5, 0.25];
    let exact = [b[0] / (1.0 + e), b[1] / (1.0 + e), b[3], b[2] - b[3]];
    let mut problem = Linear { e, b };
    let (mut evaluations, mut worst) = (Vec::new(), 0.0f64);
    for &offset in offsets {
        assert!(schur.ready());
        let mut z = exact;
        for (i, v) in z.iter_mut().enumerate() {
            *v += offset * [1.0, -1.0, 0.5, 0.3][i];
        }
        let mut report = SolveReport::default();
        assert!(schur.solve(&mut problem, &mut z, &mut report).unwrap());
        evaluations.push(report.residual_evaluations);
        let mut f = [0.0; 4];
        problem.residual(&z, &mut f).unwrap();
        worst = f.iter().fold(worst, |a, v| a.max(v.abs()));
    }
    (evaluations, worst)
}

/// A contraction of `e = 10⁻⁴` from a start residual `~10⁻¹²`: after the first solve measured
/// it, the next `CONFIRM_EVERY` stop after one update without evaluating it (its residual
/// predicted at `~10⁻¹⁶`), and the one after is evaluated again. What they return passes
/// Newton's round-off test (`‖F‖ ≤ NOISE_FACTOR · ftol`, 4.4e-14) when evaluated here.
#[test]
fn a_measured_contraction_stops_a_solve_without_the_confirming_residual() {
    use crate::flow::contraction::CONFIRM_EVERY;
    let (evaluations, worst) = trusted(1e-4, &[1e-12; CONFIRM_EVERY + 2]);
    assert_eq!(evaluations[0], 2, "{evaluations:?}");
    assert!(
        evaluations[1..=CONFIRM_EVERY].iter().all(|&e| e == 1),
        "{evaluations:?}"
    );
    assert_eq!(evaluations[CONFIRM_EVERY + 1], 2, "{evaluations:?}");
    assert!(worst <= 100.0 * 2.0 * f64::EPSILON, "residual {worst:e}");
}

/// A contraction of 0.3 predicts a residual far above the tolerance: every solve is evaluated
/// to the end, as without the estimate.
#[test]
fn a_slow_contraction_is_never_trusted() {
    let (evaluations, worst) = trusted(0.3, &[1e-12; 6]);
    assert!(evaluations.iter().all(|&e| e >= 3), "{evaluations:?}");
    assert!(worst <= 100.0 * 2.0 * f64::EPSILON, "residual {worst:e}");
}

/// A start residual 10³ times the one the contraction was measured from is beyond the linear
/// model's reach (`START_GROWTH` = 10): that solve is evaluated. From `~10⁻⁹` one update
/// leaves `~10⁻¹³` (`e` times the start), above `ftol` and the noise `4.4e-14`, so it takes a
/// second update (three residuals), and the next solve from there, predicted at `10⁻¹³`, too.
#[test]
fn a_much_worse_start_is_evaluated() {
    let (evaluations, worst) = trusted(1e-4, &[1e-12, 1e-12, 1e-9, 1e-9]);
    assert_eq!(evaluations, [2, 1, 3, 3], "{evaluations:?}");
    assert!(worst <= 100.0 * 2.0 * f64::EPSILON, "residual {worst:e}");
}

/// `F(z) = J z − b` on `(q₁, q₂, q₃, ν)` with `J = [[I, cᵀ], [c, 0]]`, `c = (0, 0, s)`: the
/// iteration's matrix is exact at the constraint's current `s`, and a Schur complement kept
/// from an earlier `s₀` propagates the multiplier's error by `1 − s²/s₀²`.
struct Turning {
    s: f64,
    b: [f64; 4],
}

impl Turning {
    fn root(&self) -> [f64; 4] {
        let q3 = self.b[3] / self.s;
        [self.b[0], self.b[1], q3, (self.b[2] - q3) / self.s]
    }
}

impl NonlinearProblem<f64> for Turning {
    type Error = StepError;
    fn dim(&self) -> usize {
        4
    }
    fn residual(&mut self, z: &[f64], f: &mut [f64]) -> Result<(), StepError> {
        f[0] = z[0] - self.b[0];
        f[1] = z[1] - self.b[1];
        f[2] = z[2] + self.s * z[3] - self.b[2];
        f[3] = self.s * z[2] - self.b[3];
        Ok(())
    }
}

impl ReducedBlocks<f64> for Turning {
    fn multiplier_columns_add(&mut self, v: &[f64], out: &mut [f64]) {
        out[2] += self.s * v[0];
    }
    fn constraint_rows(&mut self, v: &[f64], out: &mut [f64]) {
        out[0] = self.s * v[2];
    }
}

/// Solves `Turning` at each of `s` in turn from its root offset by `1e-3`, consecutive steps of
/// one size: the factorizations, updates and residual error of each solve.
fn turning(s: &[f64]) -> Vec<(usize, usize, f64)> {
    let options = NewtonOptions {
        max_contraction: 0.5,
        ..NewtonOptions::default()
    };
    let mut schur: SchurIteration<f64, DenseLu<f64>> =
        SchurIteration::new(&[1.0; 3], &[], 1, Some(&[(0, 2)]), options, &[0.5]).unwrap();
    schur.begin(0.1);
    let mut out = Vec::new();
    for &s in s {
        let mut problem = Turning {
            s,
            b: [1.0, -0.5, 0.5, 0.25],
        };
        let root = problem.root();
        let mut z = root.map(|v| v + 1e-3);
        let mut report = SolveReport::default();
        assert!(schur.ready());
        assert!(schur.solve(&mut problem, &mut z, &mut report).unwrap());
        let err = z
            .iter()
            .zip(&root)
            .fold(0.0f64, |a, (z, x)| a.max((z - x).abs()));
        out.push((report.factorizations, report.iterations, err));
    }
    out
}

/// A solve that converged in one update leaves its factored `S` to the next: the same matrix
/// converges again in one update with no factorization.
#[test]
fn a_solve_in_one_update_keeps_its_schur_complement() {
    let runs = turning(&[1.0, 1.0, 1.0]);
    assert_eq!(runs[0].0, 1, "{runs:?}");
    assert!(runs[1..].iter().all(|r| r.0 == 0 && r.1 == 1), "{runs:?}");
    assert!(runs.iter().all(|r| r.2 <= 1e-15), "{runs:?}");
}

/// `s` from 1 to 3: the kept `S` (1 against 9) multiplies the multiplier's error by `−8` an
/// update, which stalls the iteration; the solve starts again from its predictor on a fresh
/// `S` and converges in one update (one factorization). A small turn (`s` 1 → 1.05, error
/// factor `1 − 1.1025 ≈ −0.1`) converges on the kept `S` in more than one update, and the solve
/// after it factors afresh.
#[test]
fn a_stale_kept_complement_is_replaced() {
    let runs = turning(&[1.0, 3.0]);
    assert_eq!(runs[1].0, 1, "{runs:?}");
    assert!(runs[1].2 <= 1e-15, "{runs:?}");
    let runs = turning(&[1.0, 1.05, 1.05]);
    assert_eq!(runs[1].0, 0, "{runs:?}");
    assert!(runs[1].1 > 1, "{runs:?}");
    assert_eq!(runs[2].0, 1, "{runs:?}");
    assert!(runs.iter().all(|r| r.2 <= 1e-14), "{runs:?}");
}
