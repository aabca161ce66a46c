//! Hairer's DOP853 as his Fortran code runs it: the Dormand–Prince 8(5,3) pair, the combined
//! 5th/3rd-order error estimate, `HINIT` for the first step, and the step-size control with
//! `FAC1 = 0.333`, `FAC2 = 6`, `SAFE = 0.9`, `BETA = 0` (so no memory of the last error) — 12 right-hand sides per accepted step,
//! no dense-output stages (the peers only need the step points), no allocation per step.
//!
//! Reference: E. Hairer, S. P. Nørsett, G. Wanner, *Solving Ordinary Differential Equations I*,
//! 2nd ed., Springer 1993, §II.10 and the code `dop853.f` (version of 2004). The coefficients are
//! the published ones, taken from `differential-equations`' tableau so that both peers agree.

use differential_equations::tableau::ButcherTableau;

/// Stages of the 8(5,3) pair.
const STAGES: usize = 12;

/// What a DOP853 run did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Dop853Stats {
    /// Accepted steps.
    pub accepted: u64,
    /// Rejected steps (after the first accepted one, as Hairer counts them).
    pub rejected: u64,
    /// Right-hand-side evaluations.
    pub evaluations: u64,
}

/// Why a run stopped early.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Dop853Error {
    /// More than `max_steps` steps.
    #[error("DOP853 needed more than {max_steps} steps (stopped at t = {t})")]
    MaxSteps {
        /// The limit.
        max_steps: u64,
        /// Where it stopped.
        t: f64,
    },
    /// The step size fell below the rounding of `t`.
    #[error("DOP853's step size {h:e} fell below the rounding of t = {t}")]
    StepSize {
        /// The step size.
        h: f64,
        /// Where it stopped.
        t: f64,
    },
}

/// DOP853 for `y' = f(t, y)`, with scalar tolerances `rtol`, `atol`, workspace for states of
/// `n` entries.
#[derive(Debug, Clone)]
pub struct Dop853 {
    rtol: f64,
    atol: f64,
    max_steps: u64,
    a: [[f64; STAGES]; STAGES],
    /// The nodes `c_i = Σ_j a_ij`.
    c: [f64; STAGES],
    b: [f64; STAGES],
    er: [f64; STAGES],
    bh: [f64; STAGES],
    k: Vec<Vec<f64>>,
    stage: Vec<f64>,
    y_new: Vec<f64>,
}

impl Dop853 {
    /// The solver for `n` unknowns at tolerances `rtol`, `atol` (Hairer's `ITOL = 0`).
    pub fn new(n: usize, rtol: f64, atol: f64) -> Self {
        let t = ButcherTableau::<f64, 12, 16>::dop853();
        let mut a = [[0.0; STAGES]; STAGES];
        for (row, full) in a.iter_mut().zip(&t.a) {
            row.copy_from_slice(&full[..STAGES]);
        }
        let c = a.map(|row| row.iter().sum());
        Self {
            rtol,
            atol,
            max_steps: u64::MAX,
            a,
            c,
            b: t.b,
            er: t.er.expect("DOP853 has an error estimator"),
            bh: t.bh.expect("DOP853 has its 3rd-order estimator"),
            k: vec![vec![0.0; n]; STAGES],
            stage: vec![0.0; n],
            y_new: vec![0.0; n],
        }
    }

    /// At most `max_steps` steps per run.
    pub fn max_steps(mut self, max_steps: u64) -> Self {
        self.max_steps = max_steps;
        self
    }

    /// `sk = atol + rtol · max(|y|, |ŷ|)`, Hairer's weight.
    fn weight(&self, y: f64, y_new: f64) -> f64 {
        self.atol + self.rtol * y.abs().max(y_new.abs())
    }

    /// Hairer's `HINIT`: an initial step from `f(y)` (in `k[0]`) and one more evaluation.
    fn initial_step<F: FnMut(f64, &[f64], &mut [f64])>(
        &mut self,
        f: &mut F,
        y: &[f64],
        span: f64,
    ) -> f64 {
        let (mut dnf, mut dny) = (0.0, 0.0);
        for (i, &yi) in y.iter().enumerate() {
            let sk = self.atol + self.rtol * yi.abs();
            dnf += (self.k[0][i] / sk).powi(2);
            dny += (yi / sk).powi(2);
        }
        let mut h = if dnf <= 1e-10 || dny <= 1e-10 {
            1e-6
        } else {
            (dny / dnf).sqrt() * 0.01
        };
        h = h.min(span);
        for (i, &yi) in y.iter().enumerate() {
            self.stage[i] = yi + h * self.k[0][i];
        }
        f(h, &self.stage, &mut self.k[1]);
        let mut der2 = 0.0;
        for (i, &yi) in y.iter().enumerate() {
            let sk = self.atol + self.rtol * yi.abs();
            der2 += ((self.k[1][i] - self.k[0][i]) / sk).powi(2);
        }
        let der2 = der2.sqrt() / h;
        let der12 = der2.abs().max(dnf.sqrt());
        let h1 = if der12 <= 1e-15 {
            (h.abs() * 1e-3).max(1e-6)
        } else {
            (0.01 / der12).powf(1.0 / 8.0)
        };
        (100.0 * h.abs()).min(h1).min(span)
    }

    /// Integrates `y' = f(t, y)` from `t = 0` to `t_end > 0` in place, calling `accepted(t, y)`
    /// after every accepted step.
    ///
    /// A step whose error estimate is not finite is rejected with the largest decrease (`h/3`),
    /// as Hairer's code does.
    ///
    /// # Errors
    /// [`Dop853Error`] when the steps run out or shrink below the rounding of `t`; `y` then
    /// holds the last accepted state.
    pub fn solve<F, O>(
        &mut self,
        mut f: F,
        y: &mut [f64],
        t_end: f64,
        mut accepted: O,
    ) -> Result<Dop853Stats, Dop853Error>
    where
        F: FnMut(f64, &[f64], &mut [f64]),
        O: FnMut(f64, &[f64]),
    {
        const SAFE: f64 = 0.9;
        const FACC1: f64 = 1.0 / 0.333;
        const FACC2: f64 = 1.0 / 6.0;
        const EXPO1: f64 = 1.0 / 8.0;
        let n = y.len();
        let mut stats = Dop853Stats::default();
        f(0.0, y, &mut self.k[0]);
        let mut h = self.initial_step(&mut f, y, t_end);
        stats.evaluations = 2;
        let (mut t, mut last, mut reject) = (0.0f64, false, false);
        loop {
            if stats.accepted + stats.rejected >= self.max_steps {
                return Err(Dop853Error::MaxSteps {
                    max_steps: self.max_steps,
                    t,
                });
            }
            if 0.1 * h.abs() <= t.abs() * f64::EPSILON {
                return Err(Dop853Error::StepSize { h, t });
            }
            if t + 1.01 * h - t_end > 0.0 {
                h = t_end - t;
                last = true;
            }
            for i in 1..STAGES {
                self.stage.copy_from_slice(y);
                for j in 0..i {
                    let a = self.a[i][j] * h;
                    if a != 0.0 {
                        for (s, kj) in self.stage.iter_mut().zip(&self.k[j]) {
                            *s += a * kj;
                        }
                    }
                }
                f(t + self.c[i] * h, &self.stage, &mut self.k[i]);
            }
            stats.evaluations += (STAGES - 1) as u64;
            let (mut err, mut err2) = (0.0, 0.0);
            for (i, &yi) in y.iter().enumerate() {
                let (mut seg, mut e, mut bh) = (0.0, 0.0, 0.0);
                for j in 0..STAGES {
                    let kj = self.k[j][i];
                    seg += self.b[j] * kj;
                    e += self.er[j] * kj;
                    bh += self.bh[j] * kj;
                }
                self.y_new[i] = yi + h * seg;
                let sk = self.weight(yi, self.y_new[i]);
                err2 += ((seg - bh) / sk).powi(2);
                err += (e / sk).powi(2);
            }
            let mut deno = err + 0.01 * err2;
            if deno <= 0.0 {
                deno = 1.0;
            }
            let mut err = h.abs() * err * (1.0 / (n as f64 * deno)).sqrt();
            if err.is_nan() {
                // Hairer's code compares with `ERR.LE.1`, false for NaN: a rejection with the
                // largest decrease, as for an infinite error.
                err = f64::INFINITY;
            }
            let fac11 = err.powf(EXPO1);
            let fac = FACC2.max(FACC1.min(fac11 / SAFE));
            let mut h_new = h / fac;
            if err <= 1.0 {
                stats.accepted += 1;
                // The last stage's slot takes f(y_new), which is the next step's k[0] (FSAL).
                let t_new = if last { t_end } else { t + h };
                f(t_new, &self.y_new, &mut self.k[STAGES - 1]);
                stats.evaluations += 1;
                self.k.swap(0, STAGES - 1);
                y.copy_from_slice(&self.y_new);
                t = if last { t_end } else { t + h };
                accepted(t, y);
                if last {
                    return Ok(stats);
                }
                if reject {
                    h_new = h_new.abs().min(h.abs());
                }
                reject = false;
            } else {
                h_new = h / FACC1.min(fac11 / SAFE);
                reject = true;
                if stats.accepted >= 1 {
                    stats.rejected += 1;
                }
                last = false;
            }
            h = h_new;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `y' = λ y` at tolerance `tol`: the error at `t = 1` falls with the tolerance, and the
    /// evaluations are 12 per accepted step plus 2 for the start and 11 per rejection.
    #[test]
    fn the_error_falls_with_the_tolerance_at_twelve_evaluations_a_step() {
        let mut last = f64::INFINITY;
        for tol in [1e-4, 1e-7, 1e-10, 1e-13] {
            let mut y = [1.0, 0.0];
            let mut dop = Dop853::new(2, tol, tol);
            // Harmonic oscillator: y = (cos t, −sin t).
            let stats = dop
                .solve(
                    |_, x, dx| {
                        dx[0] = x[1];
                        dx[1] = -x[0];
                    },
                    &mut y,
                    10.0,
                    |_, _| {},
                )
                .unwrap();
            let err = (y[0] - 10f64.cos()).abs().max((y[1] + 10f64.sin()).abs());
            assert!(err < last, "tol {tol:e}: {err:e} after {last:e}");
            // DOP853 keeps its global error within a modest multiple of the tolerance here.
            assert!(err < 1e3 * tol, "tol {tol:e}: {err:e}");
            last = err;
            let rejected_evals = 11 * stats.rejected;
            assert!(stats.evaluations >= 2 + 12 * stats.accepted + rejected_evals);
            assert!(stats.evaluations <= 2 + 12 * stats.accepted + 11 * (stats.rejected + 1));
        }
    }

    /// `y' = cos(t) y`: `y = exp(sin t)`, which the stages see only through their times.
    #[test]
    fn a_time_dependent_field_is_evaluated_at_the_stage_times() {
        for tol in [1e-6, 1e-10] {
            let mut y = [1.0];
            Dop853::new(1, tol, tol)
                .solve(|t, x, dx| dx[0] = t.cos() * x[0], &mut y, 7.0, |_, _| {})
                .unwrap();
            let err = (y[0] - 7f64.sin().exp()).abs();
            assert!(err < 1e2 * tol, "tol {tol:e}: {err:e}");
        }
    }

    #[test]
    fn it_ends_exactly_at_t_end() {
        let mut y = [1.0];
        let mut t_last = 0.0;
        Dop853::new(1, 1e-8, 1e-8)
            .solve(|_, x, dx| dx[0] = -x[0], &mut y, 3.7, |t, _| t_last = t)
            .unwrap();
        assert_eq!(t_last, 3.7);
        assert!((y[0] - (-3.7f64).exp()).abs() < 1e-8);
    }
}
