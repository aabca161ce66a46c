//! Extrapolation of a symmetric one-step map: orders 4, 6, 8, … with every sub-step forward.

use super::{Flow, FlowStats, Ledger, Multipliers};
use crate::error::{SetupError, StepError};
use crate::real::Real;
use crate::vector::{Vector, ops};
use num_traits::Zero as _;

/// The most rows (levels) an extrapolation takes: order `p + 2·(MAX_ROWS − 1)` on a base of
/// order `p`. Beyond it the weights amplify rounding more than the order gains.
pub const MAX_ROWS: usize = 8;

/// Aitken–Neville extrapolation of a symmetric base step `S_h` of even order `p`
/// (Gragg 1965; Hairer, Nørsett & Wanner, *Solving ODEs I*, §II.9; Hairer, Lubich & Wanner,
/// *Geometric Numerical Integration*, §II.4 and §V.3.2).
///
/// A symmetric one-step map (`S_{−h} = S_h⁻¹`) has a global error expansion in even powers of
/// the step, `S_{H/n}^n(x) = φ_H(x) + e_p(x) (H/n)^p + e_{p+2}(x) (H/n)^{p+2} + …`
/// (GNI Theorem II.3.2 with the symmetric adjoint). Over a macro step `H` this adapter takes
/// the rows `T_j = S_{H/n_j}^{n_j}(x)` for a step-number sequence `n_1 < … < n_l` and returns
///
/// ```text
/// x_{k+1} = Σ_j w_j T_j,     Σ_j w_j = 1,     Σ_j w_j n_j^{−(p+2i)} = 0   (i = 0 … l−2),
/// ```
///
/// the value at `h = 0` of the polynomial in `h²` through the rows — the Aitken–Neville table's
/// last entry — so the leading `l − 1` error terms cancel: **order `p + 2(l − 1)`**. With
/// `x_j = n_j^{−2}` the weights are `w_j ∝ x_j^{−p/2} / Π_{i≠j}(x_j − x_i)` (the divided
/// difference of order `l − 1` annihilates polynomials of degree `l − 2` in `x`). The default
/// sequence is the harmonic one `1, 2, …, l` (Deuflhard 1983), `l(l+1)/2` base steps per macro
/// step: order 4 from 3, order 6 from 6, order 8 from 10 base steps.
///
/// **Every sub-step is positive**, so a dissipative sub-flow (an exact damping flow) never runs
/// backwards — unlike a composition of order ≥ 3, which needs negative steps (Sheng 1989;
/// Suzuki 1991). The combination is not symmetric and does not preserve a constraint manifold:
/// its rows lie on it, their affine combination only to `O(H^{order+1})`; wrap it in
/// [`Reprojected`](crate::flow::Reprojected) to put each macro step back on `g = 0`, `φ = 0`.
/// Energy decays along every row, and the combination's energy differs from a monotone one by
/// the same `O(H^{order+1})`: dissipation is respected to the order, not structurally (for an
/// exact discrete balance use an energy-consistent implicit scheme).
///
/// The extended coordinates of the [`Ledger`] (time, supplied and dissipated energy) are part
/// of the state the base step maps, so they are extrapolated with the same weights: the
/// booked balance `H(x_{k+1}) − H(x_k) + D − S` is of the same order. Rounding is amplified by
/// `Σ |w_j|` ([`amplification`](Self::amplification): 1.67, 3.13 and 6.21 for orders 4, 6, 8 on
/// the harmonic sequence); the base step's Newton tolerance should sit that far below the target.
#[derive(Debug, Clone)]
pub struct Extrapolated<V: Vector, F> {
    base: F,
    steps: [u32; MAX_ROWS],
    weights: [V::Real; MAX_ROWS],
    rows: usize,
    order: u32,
    /// The state the macro step starts from (restored on failure).
    start: Option<V>,
    /// The row being computed (all but the last run here; the last runs in place).
    row: Option<V>,
    /// `Σ_{j<l} w_j T_j`.
    acc: Option<V>,
    sub_steps: u64,
    /// The base flow's memory at the start of the step ([`Flow::save_memory`]), restored
    /// before every row after the first.
    memory: Vec<V::Real>,
}

impl<V: Vector, F: Flow<V>> Extrapolated<V, F> {
    /// Extrapolation of `base` to `order` on the harmonic sequence `1, 2, …, l`.
    ///
    /// # Errors
    /// [`SetupError::Scheme`] when `base` is not symmetric, its order is odd, or `order` is not
    /// an even number from `base.order() + 2` to `base.order() + 2 (MAX_ROWS − 1)`.
    pub fn try_new(base: F, order: u32) -> Result<Self, SetupError> {
        let p = base.order();
        let rows = rows_for(p, order)?;
        let steps: Vec<u32> = (1..=rows as u32).collect();
        Self::with_steps(base, &steps)
    }

    /// Extrapolation of `base` on the step-number sequence `steps` (strictly increasing,
    /// positive; Romberg's `1, 2, 4, 8`, Bulirsch's `1, 2, 3, 4, 6, 8`, …): order
    /// `base.order() + 2 (steps.len() − 1)`.
    ///
    /// # Errors
    /// [`SetupError::Scheme`] when `base` is not symmetric or of odd order, or `steps` is empty,
    /// longer than [`MAX_ROWS`], or not strictly increasing from at least 1.
    pub fn with_steps(base: F, steps: &[u32]) -> Result<Self, SetupError> {
        let p = base.order();
        check_base(&base, p)?;
        if steps.is_empty()
            || steps.len() > MAX_ROWS
            || steps[0] == 0
            || steps.windows(2).any(|w| w[0] >= w[1])
        {
            return Err(SetupError::Scheme {
                what: format!(
                    "step sequence {steps:?}: it must be strictly increasing from at least 1, with 1 to {MAX_ROWS} entries"
                ),
            });
        }
        let rows = steps.len();
        let mut s = [0u32; MAX_ROWS];
        s[..rows].copy_from_slice(steps);
        Ok(Self {
            base,
            steps: s,
            weights: weights::<V::Real>(&s[..rows], p),
            rows,
            order: p + 2 * (rows as u32 - 1),
            start: None,
            row: None,
            acc: None,
            sub_steps: 0,
            memory: Vec::new(),
        })
    }

    /// The step-number sequence `n_1, …, n_l`.
    pub fn steps(&self) -> &[u32] {
        &self.steps[..self.rows]
    }

    /// The weights `w_j` of the rows (they sum to one).
    pub fn weights(&self) -> &[V::Real] {
        &self.weights[..self.rows]
    }

    /// `Σ |w_j|`: the factor by which the combination can amplify the rows' rounding and
    /// Newton errors.
    pub fn amplification(&self) -> f64 {
        self.weights().iter().map(|w| w.to_f64_lossy().abs()).sum()
    }

    /// Base steps taken so far (`Σ n_j` per macro step), every one of them forward in time
    /// when the macro step is.
    pub fn sub_steps(&self) -> u64 {
        self.sub_steps
    }

    /// The base step.
    pub fn base(&self) -> &F {
        &self.base
    }

    /// `n` base steps of `h` on `x` from `ledger` ([`Flow::step_repeated`]: a projection
    /// fuses the half-steps between them).
    #[inline]
    fn row(
        base: &mut F,
        ledger: &mut Ledger<V::Real>,
        n: u32,
        h: V::Real,
        x: &mut V,
    ) -> Result<(), StepError> {
        base.step_repeated(ledger, h, n, x)
    }
}

/// The number of rows that raise a base of order `p` to `order`.
fn rows_for(p: u32, order: u32) -> Result<usize, SetupError> {
    let max = p.saturating_add(2 * (MAX_ROWS as u32 - 1));
    if !order.is_multiple_of(2) || order <= p || order > max {
        return Err(SetupError::Scheme {
            what: format!(
                "extrapolation of an order-{p} symmetric step reaches the even orders {} to {max}, not {order}",
                p.saturating_add(2)
            ),
        });
    }
    Ok(((order - p) / 2 + 1) as usize)
}

fn check_base<V: Vector, F: Flow<V>>(base: &F, p: u32) -> Result<(), SetupError> {
    if !base.is_symmetric() || !p.is_multiple_of(2) || p == super::EXACT {
        return Err(SetupError::Scheme {
            what: format!(
                "extrapolation needs a symmetric step of finite even order (its error expands in even powers of h); this one is {}of order {}",
                if base.is_symmetric() {
                    ""
                } else {
                    "not symmetric and "
                },
                if p == super::EXACT {
                    "exact".to_owned()
                } else {
                    p.to_string()
                }
            ),
        });
    }
    Ok(())
}

/// `w_j = x_j^{−p/2} / Π_{i≠j}(x_j − x_i)`, normalized to `Σ w_j = 1`, with `x_j = n_j^{−2}`.
fn weights<T: Real>(steps: &[u32], p: u32) -> [T; MAX_ROWS] {
    let x: Vec<T> = steps
        .iter()
        .map(|&n| T::one() / (T::lit(n as f64) * T::lit(n as f64)))
        .collect();
    let mut w = [T::zero(); MAX_ROWS];
    let mut sum = T::zero();
    for j in 0..steps.len() {
        let mut d = T::one();
        for i in 0..steps.len() {
            if i != j {
                d = d * (x[j] - x[i]);
            }
        }
        let mut v = T::one() / d;
        for _ in 0..p / 2 {
            v = v / x[j];
        }
        w[j] = v;
        sum = sum + v;
    }
    for wj in &mut w[..steps.len()] {
        *wj = *wj / sum;
    }
    w
}

impl<V: Vector, F: Flow<V>> Flow<V> for Extrapolated<V, F> {
    fn step(&mut self, h: V::Real, x: &mut V) -> Result<(), StepError> {
        self.step_at(&mut Ledger::default(), h, x)
    }

    fn step_at(
        &mut self,
        ledger: &mut Ledger<V::Real>,
        h: V::Real,
        x: &mut V,
    ) -> Result<(), StepError> {
        if !super::check_step(h, x)? {
            return Ok(());
        }
        self.prepare(x);
        let (Some(start), Some(row), Some(acc)) =
            (self.start.as_mut(), self.row.as_mut(), self.acc.as_mut())
        else {
            unreachable!("prepared above");
        };
        start.copy_from(x);
        // Every row starts from the same state, and from the same memory of the base flow
        // (its warm starts): a row's first multipliers are predicted from the steps before
        // `t`, not from the previous row's end at `t + h`, and a projection rebuilds its kept
        // Newton matrix for the row's step size instead of rescaling one built for another.
        // (The capacity is kept: no allocation after the first step.)
        self.memory.clear();
        self.base.save_memory(&mut self.memory);
        ops::fill_zero(acc.as_mut_slice());
        let l0 = *ledger;
        let (mut dt, mut ds, mut dd) = (V::Real::zero(), V::Real::zero(), V::Real::zero());
        let last = self.rows - 1;
        let mut result = Ok(());
        for j in 0..self.rows {
            let n = self.steps[j];
            let w = self.weights[j];
            let sub = h / V::Real::lit(n as f64);
            let mut lj = l0;
            if j > 0 {
                let mut from = self.memory.as_slice();
                self.base.restore_memory(&mut from);
            }
            let target: &mut V = if j == last { &mut *x } else { &mut *row };
            if j != last {
                target.copy_from(start);
            }
            result = Self::row(&mut self.base, &mut lj, n, sub, target);
            if result.is_err() {
                break;
            }
            self.sub_steps += u64::from(n);
            dt = dt + w * (lj.t - l0.t);
            ds = ds + w * (lj.supplied - l0.supplied);
            dd = dd + w * (lj.dissipated - l0.dissipated);
            if j != last {
                ops::axpy(acc.as_mut_slice(), w, target.as_slice());
            }
        }
        if let Err(e) = result {
            x.copy_from(start);
            *ledger = l0;
            let mut from = self.memory.as_slice();
            self.base.restore_memory(&mut from);
            return Err(e);
        }
        // x = w_l T_l + Σ_{j<l} w_j T_j.
        let wl = self.weights[last];
        for (xi, &ai) in x.as_mut_slice().iter_mut().zip(acc.as_slice()) {
            *xi = wl * *xi + ai;
        }
        ledger.t = l0.t + dt;
        ledger.supplied = l0.supplied + ds;
        ledger.dissipated = l0.dissipated + dd;
        Ok(())
    }

    fn order(&self) -> u32 {
        self.order
    }

    fn is_symmetric(&self) -> bool {
        false
    }

    fn prepare(&mut self, x: &V) {
        for b in [&mut self.start, &mut self.row, &mut self.acc] {
            if b.as_ref().is_none_or(|v| v.len() != x.len()) {
                *b = Some(x.zeros_like());
            }
        }
        self.base.prepare(x);
    }

    fn stats(&self) -> FlowStats {
        self.base.stats()
    }

    fn multipliers(&self) -> Option<Multipliers<'_, V::Real>> {
        self.base.multipliers()
    }

    fn dissipates(&self) -> bool {
        self.base.dissipates()
    }

    fn save_memory(&mut self, out: &mut Vec<V::Real>) {
        self.base.save_memory(out);
    }

    fn restore_memory(&mut self, from: &mut &[V::Real]) {
        self.base.restore_memory(from);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weights_reproduce_the_aitken_neville_table() {
        // Harmonic 1, 2: (4 T_2 − T_1)/3.
        let w = weights::<f64>(&[1, 2], 2);
        assert!((w[0] + 1.0 / 3.0).abs() < 1e-15 && (w[1] - 4.0 / 3.0).abs() < 1e-15);
        // 1, 2, 3 (order 6): 1/24, −16/15, 81/40.
        let w = weights::<f64>(&[1, 2, 3], 2);
        for (a, b) in w.iter().zip([1.0 / 24.0, -16.0 / 15.0, 81.0 / 40.0]) {
            assert!((a - b).abs() < 1e-14, "{a} vs {b}");
        }
        // Every row count: the weights sum to one and cancel n^{-2}, …, n^{-2(l-1)}.
        for l in 1..=MAX_ROWS {
            let steps: Vec<u32> = (1..=l as u32).collect();
            let w = weights::<f64>(&steps, 2);
            let moment = |k: i32| -> f64 {
                steps
                    .iter()
                    .zip(&w)
                    .map(|(&n, &wj)| wj * f64::from(n).powi(-2 * k))
                    .sum()
            };
            assert!((moment(0) - 1.0).abs() < 1e-12);
            for k in 1..l as i32 {
                let scale: f64 = w.iter().map(|v| v.abs()).sum();
                assert!(moment(k).abs() < 1e-13 * scale, "l = {l}, k = {k}");
            }
        }
    }

    #[test]
    fn the_harmonic_weights_amplify_rounding_by_their_absolute_sum() {
        let sum = |l: u32| -> f64 {
            let steps: Vec<u32> = (1..=l).collect();
            weights::<f64>(&steps, 2)[..l as usize]
                .iter()
                .map(|w| w.abs())
                .sum()
        };
        // 5/3; 1/24 + 16/15 + 81/40; 1/360 + 16/45 + 729/280 + 1024/315.
        assert!((sum(2) - 5.0 / 3.0).abs() < 1e-14);
        assert!((sum(3) - (1.0 / 24.0 + 16.0 / 15.0 + 81.0 / 40.0)).abs() < 1e-14);
        let four = 1.0 / 360.0 + 16.0 / 45.0 + 729.0 / 280.0 + 1024.0 / 315.0;
        assert!((sum(4) - four).abs() < 1e-13, "{} vs {four}", sum(4));
    }

    #[test]
    fn a_base_of_order_four_cancels_from_h4_on() {
        let w = weights::<f64>(&[1, 2], 4);
        // (16 T_2 − T_1)/15.
        assert!((w[0] + 1.0 / 15.0).abs() < 1e-15 && (w[1] - 16.0 / 15.0).abs() < 1e-15);
    }

    #[test]
    fn orders_out_of_reach_are_refused() {
        assert!(rows_for(2, 4).is_ok_and(|r| r == 2));
        assert!(rows_for(2, 8).is_ok_and(|r| r == 4));
        assert!(rows_for(2, 5).is_err());
        assert!(rows_for(2, 2).is_err());
        assert!(rows_for(2, 18).is_err());
    }
}
