//! Dense output of the adaptive extrapolation: the polynomial of an accepted macro step
//! through its two ends and the derivatives at its midpoint, each extrapolated from the rows'
//! central differences (Hairer & Ostermann, *Dense output for extrapolation methods*, Numer.
//! Math. 58, 1990; Hairer, Nørsett & Wanner, *Solving ODEs I*, §II.9, ODEX's `IOUT = 2`).
//!
//! With the even sequence `n_j = 2j` every row's midpoint is one of its points. A symmetric
//! base step's values at the fixed times `t₀ + i h_j` have a global error expanding in `h_j²`
//! with smooth coefficients, and so do their central differences at the midpoint: in units of
//! the macro step (`θ = (t − t₀)/H`, spacing `1/(2j)`),
//!
//! ```text
//! d_l^{(j)} = (2j)^l δ^l u_j(½)  =  H^l y^{(l)}(t₀ + H/2)  +  c₂ h_j² + c₄ h_j⁴ + …
//! ```
//!
//! (`δ^l` the central difference of order `l`, averaged over the two neighbours for odd `l`).
//! The rows `j ≥ ⌈l/2⌉` that have the stencil extrapolate each `d_l` by Aitken–Neville in
//! `h_j²`, as the table does the end. With `κ` the accepted row and `μ = 2κ − 3`, the
//! polynomial in `s = θ − ½`
//!
//! ```text
//! P(s) = Σ_{l=0}^{μ} d_l s^l / l!  +  s^{μ+1} (c₀ + c₁ s),
//! ```
//!
//! its two last coefficients fixed by `P(−½) = x₀`, `P(½) = x₁` (the accepted, projected end),
//! has the midpoint's derivatives up to `μ` and both ends: degree `2κ − 1`. The extended
//! coordinates of the [`Ledger`](crate::flow::Ledger) (supplied and dissipated energy) are
//! interpolated with the state.

use super::Tolerances;
use crate::error::StepError;
use crate::flow::{Flow, Ledger};
use crate::real::Real;
use crate::vector::Vector;

/// The interpolant's storage: flat buffers of `stride = n + 2` values a vector (the state and
/// the ledger's two increments since the macro step's start).
#[derive(Debug, Clone)]
pub(crate) struct Interpolant<T> {
    stride: usize,
    /// Most rows (`kmax`) and derivatives kept a row (`2 kmax − 2`).
    rows: usize,
    orders: usize,
    /// The row being recorded: its points `mid − w … mid + w`.
    points: Vec<T>,
    /// Row `j`'s differences `d_l^{(j)}` at `[(j − 1) orders + l]`, extrapolated in place.
    table: Vec<T>,
    /// `P`'s coefficients in `s`, lowest first (`μ + 3` vectors).
    coef: Vec<T>,
    terms: usize,
    /// The step the polynomial covers (`h = 0`: none) and the ledger's supplied and
    /// dissipated energy at its start.
    t0: T,
    h: T,
    ledger0: [T; 2],
}

impl<T: Real> Interpolant<T> {
    /// Storage for states of length `n` and tables of at most `kmax` rows.
    pub(crate) fn new(n: usize, kmax: usize) -> Self {
        let stride = n + 2;
        let orders = 2 * kmax - 2;
        Self {
            stride,
            rows: kmax,
            orders,
            points: vec![T::zero(); (2 * kmax + 1) * stride],
            table: vec![T::zero(); kmax * orders * stride],
            coef: vec![T::zero(); (orders + 2) * stride],
            terms: 0,
            t0: T::zero(),
            h: T::zero(),
            ledger0: [T::zero(); 2],
        }
    }

    /// Whether it was built for states of length `n` and `kmax` rows.
    pub(crate) fn fits(&self, n: usize, kmax: usize) -> bool {
        self.stride == n + 2 && self.rows == kmax
    }

    /// No polynomial (after a restore, a rejected or failed step).
    pub(crate) fn forget(&mut self) {
        self.h = T::zero();
    }

    /// Records point `i` (`0 … 2w`) of the row: the state `x` and the ledger's increments.
    pub(crate) fn record(&mut self, i: usize, x: &[T], increments: [T; 2]) {
        let p = &mut self.points[i * self.stride..(i + 1) * self.stride];
        let (state, ledger) = p.split_at_mut(x.len());
        state.copy_from_slice(x);
        ledger.copy_from_slice(&increments);
    }

    /// Row `j`'s central differences at its midpoint from the `2w + 1` points recorded,
    /// orders `0 … min(2w, 2 kmax − 3)`, in units of the macro step.
    pub(crate) fn differences(&mut self, j: usize, w: usize) {
        let s = self.stride;
        let top = (2 * w).min(self.orders - 1);
        let mut c = [0.0f64; 2 * crate::flow::MAX_ROWS + 1];
        for l in 0..=top {
            stencil(l, w, &mut c[..2 * w + 1]);
            let scale = (2.0 * j as f64).powi(l as i32);
            let out = &mut self.table[((j - 1) * self.orders + l) * s..][..s];
            out.fill(T::zero());
            for (i, &ci) in c[..2 * w + 1].iter().enumerate() {
                if ci != 0.0 {
                    let a = T::lit(ci * scale);
                    let p = &self.points[i * s..(i + 1) * s];
                    for (o, &v) in out.iter_mut().zip(p) {
                        *o = *o + a * v;
                    }
                }
            }
        }
    }

    /// The polynomial of the step accepted at row `kappa ≥ 2` from `start` (the ledger at its
    /// beginning, increments zero) over `h`, from `x0` to `x1` with the ledger's `inc`rements.
    pub(crate) fn build(
        &mut self,
        kappa: usize,
        start: &Ledger<T>,
        h: T,
        x0: &[T],
        x1: &[T],
        inc: [T; 2],
    ) {
        let s = self.stride;
        let mu = 2 * kappa - 3;
        let one = T::one();
        let mut factorial = one;
        for l in 0..=mu {
            // Aitken–Neville in h_j² over rows ⌈l/2⌉ … κ, in place, from the finest row down.
            let first = l.div_ceil(2).max(1);
            for k in 1..=kappa - first {
                for r in (first + k..=kappa).rev() {
                    let ratio = r as f64 / (r - k) as f64;
                    let c = T::lit(1.0 / (ratio * ratio - 1.0));
                    let (lo, hi) = self.table.split_at_mut(((r - 1) * self.orders + l) * s);
                    let below = &lo[((r - 2) * self.orders + l) * s..][..s];
                    for (a, &b) in hi[..s].iter_mut().zip(below) {
                        *a = *a + (*a - b) * c;
                    }
                }
            }
            if l > 0 {
                factorial = factorial * T::lit(l as f64);
            }
            let inv = one / factorial;
            let d = &self.table[((kappa - 1) * self.orders + l) * s..][..s];
            for (o, &v) in self.coef[l * s..(l + 1) * s].iter_mut().zip(d) {
                *o = v * inv;
            }
        }
        // c₀, c₁ from the ends: A = x₁ − T(½), B = x₀ − T(−½), σ = 2^{−(μ+1)} (μ odd: the sign
        // (−1)^{μ+1} is +1): c₀ = (A + B)/(2σ), c₁ = (A − B)/σ.
        let half = T::lit(0.5);
        let sigma_inv = T::lit(2.0f64.powi(mu as i32 + 1));
        let n = s - 2;
        for e in 0..s {
            let (mut plus, mut minus, mut power) = (T::zero(), T::zero(), one);
            let mut sign = one;
            for l in 0..=mu {
                let a = self.coef[l * s + e] * power;
                plus = plus + a;
                minus = minus + a * sign;
                power = power * half;
                sign = -sign;
            }
            let (end, start) = if e < n {
                (x1[e], x0[e])
            } else {
                (inc[e - n], T::zero())
            };
            let (a, b) = (end - plus, start - minus);
            self.coef[(mu + 1) * s + e] = (a + b) * half * sigma_inv;
            self.coef[(mu + 2) * s + e] = (a - b) * sigma_inv;
        }
        self.terms = mu + 3;
        self.t0 = start.t;
        self.h = h;
        self.ledger0 = [start.supplied, start.dissipated];
    }

    /// An estimate of the largest error over the step of the polynomial column `c` would
    /// have built (`μ_c = 2c − 3`), in the weighted norm of `tolerances` (scaled by the step's
    /// ends `x0`, `x1`): the first term it leaves out, `a_{2c} s^{2c−2} (¼ − s²)` once the
    /// ends fix its two last coefficients, at its largest, `s*^{2c−2} / (4c)` at
    /// `s*² = (c − 1)/(4c)`, with `a_{2c}` taken as the built polynomial's `a_{2c−1}` (larger
    /// while the Taylor coefficients at the midpoint decay; its `c₁` for the column built).
    /// For the column above the built one, `a_{2c−1}` is continued geometrically from
    /// `a_{2c−5}` and `a_{2c−3}`.
    pub(crate) fn error_estimate(
        &self,
        c: usize,
        tolerances: &Tolerances<T>,
        x0: &[T],
        x1: &[T],
    ) -> f64 {
        let s = self.stride;
        let n = s - 2;
        let m = (2 * c - 2) as f64;
        let peak = 0.5 * (m / (m + 2.0)).sqrt();
        let bound = peak.powf(m) / (2.0 * (m + 2.0));
        let norm = |l: usize| {
            tolerances
                .norm(&self.coef[l * s..][..n], x0, x1)
                .to_f64_lossy()
        };
        let l = 2 * c - 1;
        let a = if l < self.terms {
            norm(l)
        } else {
            let top = self.terms - 1;
            let (hi, lo) = (norm(top), norm(top - 2));
            if lo > 0.0 {
                hi * (hi / lo).powf(((l - top) / 2) as f64)
            } else {
                hi
            }
        };
        bound * a
    }

    /// `P` at `ledger.t` into `x` and `ledger`'s supplied and dissipated energy, or `false`
    /// when no polynomial covers that time (none built, or outside its step by more than
    /// rounding).
    pub(crate) fn eval(&self, ledger: &mut Ledger<T>, x: &mut [T]) -> bool {
        let t = ledger.t;
        if self.h == T::zero() {
            return false;
        }
        let theta = (t - self.t0) / self.h;
        let slack = T::lit(64.0) * T::epsilon();
        if !(theta >= -slack && theta <= T::one() + slack) {
            return false;
        }
        let sv = theta - T::lit(0.5);
        let s = self.stride;
        let n = s - 2;
        let mut inc = [T::zero(); 2];
        for e in 0..s {
            let mut acc = T::zero();
            for l in (0..self.terms).rev() {
                acc = acc * sv + self.coef[l * s + e];
            }
            if e < n {
                x[e] = acc;
            } else {
                inc[e - n] = acc;
            }
        }
        ledger.supplied = self.ledger0[0] + inc[0];
        ledger.dissipated = self.ledger0[1] + inc[1];
        true
    }
}

/// Row `j` of the even sequence (`2j` sub-steps of `sub` from `x`), its points
/// `j − w … j + w` recorded in `dense` and their central differences formed: the sub-steps
/// before and after the recorded window as one call of [`Flow::step_repeated`], those inside
/// one by one. The row's end is the table's `T_{j,1}` as without the recording.
#[allow(clippy::too_many_arguments)]
pub(crate) fn run_row<V: Vector, F: Flow<V>>(
    base: &mut F,
    dense: &mut Interpolant<V::Real>,
    ledger: &mut Ledger<V::Real>,
    l0: &Ledger<V::Real>,
    sub: V::Real,
    j: usize,
    w: usize,
    x: &mut V,
) -> Result<(), StepError> {
    let lead = (j - w) as u32;
    let inc = |l: &Ledger<V::Real>| [l.supplied - l0.supplied, l.dissipated - l0.dissipated];
    if lead > 0 {
        base.step_repeated(ledger, sub, lead, x)?;
    }
    dense.record(0, x.as_slice(), inc(ledger));
    for i in 1..=2 * w {
        base.step_at(ledger, sub, x)?;
        dense.record(i, x.as_slice(), inc(ledger));
    }
    if lead > 0 {
        base.step_repeated(ledger, sub, lead, x)?;
    }
    dense.differences(j, w);
    Ok(())
}

/// The weights of the central difference of order `l` at the middle of `2w + 1` points of
/// unit spacing (`l ≤ 2w`): `δ^l` for even `l`, the mean of `δ^l` at `±½` — the difference
/// `(δ^{l−1}(+1) − δ^{l−1}(−1))/2` — for odd `l`.
fn stencil(l: usize, w: usize, c: &mut [f64]) {
    c.fill(0.0);
    let binomial = |n: usize, i: usize| -> f64 {
        (0..i).fold(1.0, |b, k| b * (n - k) as f64 / (k + 1) as f64)
    };
    if l.is_multiple_of(2) {
        let h = l / 2;
        for i in 0..=l {
            let sign = if i % 2 == 0 { 1.0 } else { -1.0 };
            c[w + h - i] += sign * binomial(l, i);
        }
    } else {
        let h = (l - 1) / 2;
        for i in 0..l {
            let b = if i % 2 == 0 { 0.5 } else { -0.5 } * binomial(l - 1, i);
            c[w + 1 + h - i] += b;
            c[w + h - i - 1] -= b;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_stencils_differentiate_polynomials_exactly() {
        // On p(i) = i^d (unit spacing), the l-th central difference at 0 is d!/(d−l)! 0^{d−l}:
        // l! for d = l and 0 for d < l; odd l averaged over ±½ reads the same at the centre.
        for l in 0..=13usize {
            let w = l.div_ceil(2).max(1);
            let mut c = vec![0.0; 2 * w + 1];
            stencil(l, w, &mut c);
            for d in 0..=l {
                let v: f64 = (0..=2 * w)
                    .map(|i| c[i] * (i as f64 - w as f64).powi(d as i32))
                    .sum();
                let want = if d == l {
                    (1..=l).map(|k| k as f64).product::<f64>()
                } else {
                    0.0
                };
                assert!(
                    (v - want).abs() <= 1e-9 * want.max(1.0),
                    "l = {l}, d = {d}: {v} vs {want}"
                );
            }
        }
    }
}
