//! Order- and step-size-controlled extrapolation of a symmetric step of order 2: ODEX's
//! controller around the projected Strang step (RATTLE), every sub-step forward.

use super::control::{Control, Outcome};
use super::interpolant::{Interpolant, run_row};
use super::{AcceptStep, AdaptiveOptions};
use crate::error::{SetupError, StepError};
use crate::flow::{Flow, Ledger, MAX_ROWS};
use crate::real::Real;
use crate::vector::Vector;
use num_traits::{One as _, Zero as _};

/// Order- and step-size-controlled extrapolation of a symmetric base step `S_h` of order 2
/// (the projected Strang step, RATTLE): the macro step of size `H` builds the Aitken–Neville
/// table in `h²` row by row,
///
/// ```text
/// T_{j,1} = S_{H/j}^j(x),   T_{j,k} = T_{j,k−1} + (T_{j,k−1} − T_{j−1,k−1}) / ((j/(j−k+1))² − 1),
/// ```
///
/// (the harmonic sequence `n_j = j`, the base flow's memory restored before each row: every row
/// starts from the same state and the same warm starts). `T_{j,j}` has order `2j`; the
/// difference `err_j = ‖T_{j,j} − T_{j,j−1}‖` in the weighted norm ([`Tolerances`](super::Tolerances)) estimates
/// the error of `T_{j,j−1}`, `O(H^{2j−1})`, and gives the step that would meet the tolerance
/// at that column, `H_j = H · 0.94 (0.65/err_j)^{1/(2j−1)}` (clamped to `[0.02, 4] H`). The
/// column `k` the controller aims at is chosen by the work per unit step `W_j = A_j / H_j`
/// (`A_j = j(j+1)/2` base steps); a row is tested for convergence at `k − 1`, `k` and `k + 1`
/// only, and the step is abandoned early when the estimate is too far above 1 to converge
/// within the window (ODEX: Hairer, Nørsett & Wanner, *Solving ODEs I*, §II.9, and `odex.f`).
///
/// An accepted step's result `T_{j,j}` goes through `P` ([`AcceptStep`]: the projection onto
/// the manifold, so the constraints are at round-off after every accepted step). A rejected
/// step, or one whose sub-step fails (a Newton failure: the step is halved), restores the state,
/// the ledger and the base flow's memory exactly. Every sub-step has the sign of the macro
/// step, so a dissipative sub-flow never runs backwards. The extended coordinates of the
/// [`Ledger`] (supplied and dissipated energy) are extrapolated with the state.
///
/// With [`AdaptiveOptions::resolve`], a step aimed at column `k` is at most `k · resolve`
/// long: the sub-steps resolve a time the base step needs resolved (a stiff damping's
/// relaxation time, over which a splitting's error is not the expansion in `h²` the table
/// assumes).
///
/// Without a first step in the options, the first is estimated from the base step's
/// derivatives (Hairer, Nørsett & Wanner's starting step, for order `2 k_c`; three base steps):
/// a macro step over the whole interval would be rejected, or fail in Newton's solve, down to
/// the problem's time scale.
///
/// `step(h, x)` advances by exactly `h`, with as many macro steps as the tolerance needs (the
/// last clipped to land on `t + h`); the controller's proposal for the next step and its column
/// carry over from one call to the next and are part of the flow's memory
/// ([`Flow::save_memory`]), so a checkpoint's continuation is bit-identical.
#[derive(Debug)]
pub struct AdaptiveExtrapolation<V: Vector, F, P = ()> {
    base: F,
    finish: P,
    control: Control<V>,
    /// The most rows.
    kmax: usize,
    /// The column aimed at (2 … kmax; no increase after a rejection).
    kc: usize,
    start: V,
    /// Two rows of the table (the previous one and the one being built).
    prev: Vec<V>,
    cur: Vec<V>,
    /// The ledger's supplied and dissipated increments, tabled like the state.
    prev_l: [[V::Real; 2]; MAX_ROWS],
    cur_l: [[V::Real; 2]; MAX_ROWS],
    memory: Vec<V::Real>,
    /// The interpolant of the last accepted step ([`AdaptiveOptions::dense_output`]).
    dense: Option<Interpolant<V::Real>>,
}

impl<V: Vector, F: Flow<V>, P: AcceptStep<V>> AdaptiveExtrapolation<V, F, P> {
    /// Extrapolation of `base` under `options`, each accepted step finished by `finish`.
    ///
    /// # Errors
    /// [`SetupError::Scheme`] when `base` is not a symmetric step of order 2 or `max_order` is
    /// not even in 4 … `2·MAX_ROWS`; [`SetupError::InvalidParameter`] for an `h_min` or
    /// `h_max` that is negative, not finite or out of order.
    pub fn try_new(
        base: F,
        finish: P,
        options: AdaptiveOptions<V::Real>,
    ) -> Result<Self, SetupError> {
        if !base.is_symmetric() || base.order() != 2 {
            return Err(SetupError::Scheme {
                what: format!(
                    "adaptive extrapolation needs a symmetric step of order 2 (its error expands in h²); this one is {}of order {}",
                    if base.is_symmetric() {
                        ""
                    } else {
                        "not symmetric and "
                    },
                    base.order()
                ),
            });
        }
        let m = options.max_order;
        if !m.is_multiple_of(2) || m < 4 || m as usize > 2 * MAX_ROWS {
            return Err(SetupError::Scheme {
                what: format!(
                    "max_order {m}: the adaptive extrapolation reaches the even orders 4 to {}",
                    2 * MAX_ROWS
                ),
            });
        }
        options.check()?;
        let kmax = (m / 2) as usize;
        // The starting column from the tolerance (ODEX: −0.6 log₁₀ rtol + 1.5).
        let rtol = options.tolerances.tightest_rtol().to_f64_lossy().max(1e-16);
        let kc = ((-0.6 * rtol.log10() + 1.5) as usize).clamp(2, kmax - 1);
        let zero = V::Real::zero();
        Ok(Self {
            base,
            finish,
            control: Control::new(options),
            kmax,
            kc,
            start: V::zeros(0),
            prev: Vec::new(),
            cur: Vec::new(),
            prev_l: [[zero; 2]; MAX_ROWS],
            cur_l: [[zero; 2]; MAX_ROWS],
            memory: Vec::new(),
            dense: None,
        })
    }

    /// The base step.
    pub fn base(&self) -> &F {
        &self.base
    }

    /// What runs after each accepted step.
    pub fn finish(&self) -> &P {
        &self.finish
    }

    /// The next macro step the controller will try (`None` before the first).
    pub fn next_step(&self) -> Option<V::Real> {
        self.control.h_next
    }

    /// The column (order / 2) the controller aims at next.
    pub fn target_rows(&self) -> usize {
        self.kc
    }

    /// The controller's state and the base flow's memory.
    fn save_state(&mut self, out: &mut Vec<V::Real>) {
        self.control.save(out);
        out.push(V::Real::lit(self.kc as f64));
        self.base.save_memory(out);
    }

    fn restore_state(&mut self, from: &mut &[V::Real]) {
        if from.len() >= 3 {
            let (head, rest) = from.split_at(3);
            self.control.restore(&head[..2]);
            self.kc = (head[2].to_f64_lossy() as usize).clamp(2, self.kmax);
            *from = rest;
        }
        self.base.restore_memory(from);
        self.finish.forget();
        if let Some(d) = self.dense.as_mut() {
            d.forget();
        }
    }

    /// One macro step of size `big` from `x`: on acceptance `x` and `ledger` advance and the
    /// next step is proposed; on rejection or failure both and the base flow's memory are as
    /// they were.
    fn attempt_table(
        &mut self,
        ledger: &mut Ledger<V::Real>,
        big: V::Real,
        x: &mut V,
    ) -> Result<Outcome<V::Real>, StepError> {
        let l0 = *ledger;
        if let Some(d) = self.dense.as_mut() {
            d.forget();
        }
        self.start.copy_from(x);
        self.memory.clear();
        self.base.save_memory(&mut self.memory);
        let jmax = (self.kc + 1).min(self.kmax);
        let hf = big.to_f64_lossy().abs();
        // H_j and W_j by row (index j, 1-based).
        let mut h_opt = [0.0f64; MAX_ROWS + 2];
        // Row 1 has no estimate: its work is infinite, so that column 2 is always left upwards
        // after an accepted step (ODEX: KOPT = 3 when KC = 2) instead of staying there for good.
        let mut work = [f64::INFINITY; MAX_ROWS + 2];
        let mut err = 0.0f64;
        for j in 1..=jmax {
            if j > 1 {
                self.restore_base();
            }
            let mut lj = l0;
            self.cur[0].copy_from(&self.start);
            // n_j = j, or 2j with dense output (rows j ≤ jmax − 1 recorded whole, the last
            // one within jmax − 1 sub-steps of its midpoint: what μ = 2κ − 3 ≤ 2 jmax − 3 needs).
            let n = self.sub_steps(j);
            let sub = big / V::Real::lit(f64::from(n));
            let stepped = match self.dense.as_mut() {
                Some(d) => run_row(
                    &mut self.base,
                    d,
                    &mut lj,
                    &l0,
                    sub,
                    j,
                    j.min(jmax - 1),
                    &mut self.cur[0],
                ),
                None => self.base.step_repeated(&mut lj, sub, n, &mut self.cur[0]),
            };
            self.control.stats.base_steps += u64::from(n);
            if let Err(e) = stepped {
                self.restore_base();
                return Err(e);
            }
            self.cur_l[0] = [lj.supplied - l0.supplied, lj.dissipated - l0.dissipated];
            // Neville in h²: column k (0-based) from this row's k − 1 and the last row's.
            for k in 1..j {
                let ratio = V::Real::lit(j as f64 / (j - k) as f64);
                let c = V::Real::one() / (ratio * ratio - V::Real::one());
                let (done, rest) = self.cur.split_at_mut(k);
                let (left, prev) = (&done[k - 1], &self.prev[k - 1]);
                let out = rest[0].as_mut_slice();
                for ((o, &a), &b) in out.iter_mut().zip(left.as_slice()).zip(prev.as_slice()) {
                    *o = a + (a - b) * c;
                }
                for e in 0..2 {
                    let a = self.cur_l[k - 1][e];
                    self.cur_l[k][e] = a + (a - self.prev_l[k - 1][e]) * c;
                }
            }
            core::mem::swap(&mut self.prev, &mut self.cur);
            core::mem::swap(&mut self.prev_l, &mut self.cur_l);
            if j < 2 {
                continue;
            }
            let (a, b) = (&self.prev[j - 1], &self.prev[j - 2]);
            err = self
                .control
                .options
                .tolerances
                .error(
                    a.as_slice(),
                    b.as_slice(),
                    self.start.as_slice(),
                    a.as_slice(),
                )
                .to_f64_lossy();
            // A NaN estimate (a row blew up) shrinks as far as the clamp allows.
            h_opt[j] = hf * step_factor(err, 0.65, 2 * j - 1, 0.02);
            if let Some(r) = self.control.options.resolve {
                // Column j's finest sub-steps resolve the time asked for (its work follows).
                h_opt[j] = h_opt[j].min(f64::from(self.sub_steps(j)) * r.to_f64_lossy());
            }
            // A_j = j(j+1)/2 base steps (twice that with n_j = 2j: the same choices).
            work[j] = (j * (j + 1) / 2) as f64 / h_opt[j];
            // Rows are tested in the window k − 1 … k + 1 only; above `hopeless` the estimate
            // cannot fall below 1 by the window's last row (ODEX), so the step is rejected now.
            let kc = self.kc;
            if j + 1 < kc {
                continue;
            }
            let hopeless = match j + 1 - kc {
                0 => ((kc * (kc + 1)) as f64).powi(2),
                1 => ((kc + 1) as f64).powi(2),
                _ => 1.0,
            };
            if err <= 1.0 {
                return self.accept(ledger, l0, big, j, &mut h_opt, &mut work, err, x);
            }
            if err > hopeless || j == jmax {
                self.restore_base();
                let mut k = kc.min(j);
                if k >= 3 && work[k - 1] < 0.8 * work[k] {
                    k -= 1;
                }
                self.kc = k.clamp(2, self.kmax);
                self.control.book_rejected(err);
                let next = h_opt[k].min(0.9 * hf);
                return Ok(Outcome::Rejected(V::Real::lit(next)));
            }
        }
        // Row `jmax ≥ kc ≥ 2` always decides above.
        unreachable!("the last row decides (err = {err})")
    }

    /// Row `j`'s sub-steps: `j`, or `2j` with dense output.
    fn sub_steps(&self, j: usize) -> u32 {
        (if self.dense.is_some() { 2 * j } else { j }) as u32
    }

    /// The base flow's memory as the macro step found it.
    fn restore_base(&mut self) {
        let mut from = self.memory.as_slice();
        self.base.restore_memory(&mut from);
    }

    /// Accepts row `j`'s diagonal entry, finishes it, and chooses the next column and step.
    #[allow(clippy::too_many_arguments)]
    fn accept(
        &mut self,
        ledger: &mut Ledger<V::Real>,
        l0: Ledger<V::Real>,
        big: V::Real,
        j: usize,
        h_opt: &mut [f64],
        work: &mut [f64],
        err: f64,
        x: &mut V,
    ) -> Result<Outcome<V::Real>, StepError> {
        x.copy_from(&self.prev[j - 1]);
        let finished = super::accept::finish_accepted(&mut self.finish, x);
        if let Err(e) = finished {
            x.copy_from(&self.start);
            self.restore_base();
            self.finish.forget();
            return Err(e);
        }
        ledger.t = l0.t + big;
        ledger.supplied = l0.supplied + self.prev_l[j - 1][0];
        ledger.dissipated = l0.dissipated + self.prev_l[j - 1][1];
        let hf = big.to_f64_lossy().abs();
        // With dense output the polynomial's error is held too (ODEX): a step whose estimate
        // is above 10 is redone shorter, and each column's step is no longer than its
        // polynomial allows (docs/method.md §12d, "Dense output").
        let mut dense_cap = [f64::INFINITY; MAX_ROWS + 2];
        if let Some(d) = self.dense.as_mut() {
            let inc = self.prev_l[j - 1];
            let (x0, x1) = (self.start.as_slice(), x.as_slice());
            d.build(j, &l0, big, x0, x1, inc);
            let tolerances = &self.control.options.tolerances;
            for c in (j - 1).max(2)..=(j + 1).min(self.kmax) {
                let e = d.error_estimate(c, tolerances, x0, x1);
                let fac = step_factor(e, 1.0, 2 * c, 0.2);
                // (A NaN estimate, a polynomial that blew up, is redone as one above 10.)
                if c == j && (e.is_nan() || e > 10.0) {
                    d.forget();
                    *ledger = l0;
                    x.copy_from(&self.start);
                    self.restore_base();
                    self.finish.forget();
                    self.control.book_rejected(e);
                    return Ok(Outcome::Rejected(V::Real::lit(hf * fac)));
                }
                dense_cap[c] = hf * fac;
                if c <= j {
                    h_opt[c] = h_opt[c].min(dense_cap[c]);
                    work[c] = (c * (c + 1) / 2) as f64 / h_opt[c];
                }
            }
        }
        let kc = self.kc;
        let mut k = j;
        if j < kc + 1 {
            if j >= 3 && work[j - 1] < 0.8 * work[j] {
                k = j - 1;
            } else if j < self.kmax && work[j] < 0.9 * work[j - 1] {
                k = j + 1;
            }
        } else if work[j] >= 0.9 * work[j - 1] {
            k = j - 1;
        }
        let mut next = if k <= j {
            h_opt[k]
        } else {
            let a = |r: usize| (r * (r + 1) / 2) as f64;
            h_opt[j] * a(k) / a(j)
        };
        let c = &mut self.control;
        if c.rejected_last {
            k = k.min(j);
            next = next.min(hf);
        }
        if let Some(h_max) = c.options.h_max {
            next = next.min(h_max.to_f64_lossy());
        }
        next = next.min(dense_cap[k]);
        self.kc = k.clamp(2, self.kmax);
        c.rejected_last = false;
        c.h_next = Some(V::Real::lit(next));
        c.book_accepted(hf, j, err);
        Ok(Outcome::Accepted)
    }
}

/// The factor `0.94 (aim/e)^{1/p}` of a step whose error estimate is `e` (tolerances) for an
/// error in `H^p`, aiming at `aim`: `4` for a zero estimate, within `[least, 4]`, `least` for a
/// NaN one.
fn step_factor(e: f64, aim: f64, p: usize, least: f64) -> f64 {
    let fac = if e > 0.0 {
        0.94 * (aim / e).powf(1.0 / p as f64)
    } else {
        4.0
    };
    if fac.is_nan() {
        least
    } else {
        fac.clamp(least, 4.0)
    }
}

#[path = "extrapolation_stepping.rs"]
mod stepping;

#[cfg(test)]
#[path = "extrapolation_tests.rs"]
mod tests;
