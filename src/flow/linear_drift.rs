//! The closed form a [`LinearFlow`](super::LinearFlow) takes when its generator is a damped
//! drift, coordinate by coordinate: no matrix exponential.

use crate::real::Real;

/// Coordinates mapped through a stack buffer in one pass (more are mapped twice).
const STACK: usize = 8;

/// The affine system `x' = A x + b` when it is, for a state `x = (q, p)` of `2d` entries,
///
/// ```text
/// q_i' = w_i p_i + a_i,     p_i' = −c_i p_i + f_i      (i = 1 … d),
/// ```
///
/// a mechanical model's free motion with diagonal inverse masses `w`, linear viscous damping
/// `c` on the momenta and constant forces `f` (gravity), `a` a constant drift of the
/// positions. Its exact flow, with `e = e^{−ch}`, `φ = (1 − e)/c` and `ψ = ∫₀ʰ φ = (h − φ)/c`
/// (`φ = h`, `ψ = h²/2` at `c = 0`):
///
/// ```text
/// p(h) = e p + φ f,     q(h) = q + w (φ p + ψ f) + h a,
/// ```
///
/// `3d` coefficients per step size and `O(d)` work per step, where the series and squarings
/// of the exponential of the `(2d+1)²` augmented matrix cost `O(d³)` per step size and a
/// dense product `O(d²)` per step. The same map to rounding: both are exact flows.
#[derive(Debug, Clone)]
pub(super) struct Drift<T> {
    coordinates: Vec<Coordinate<T>>,
    /// The step size of the coefficients (`None`: none yet).
    h: Option<T>,
}

/// One coordinate pair's constants and its coefficients for the last step size.
#[derive(Debug, Clone, Copy)]
struct Coordinate<T> {
    w: T,
    c: T,
    f: T,
    a: T,
    /// `e^{−ch}`, `φ`, `ψ` for the drift's `h`.
    e: T,
    phi: T,
    psi: T,
}

impl<T: Real> Coordinate<T> {
    /// `(q, p)` after a step.
    #[inline(always)]
    fn map(&self, h: T, q: T, p: T) -> (T, T) {
        (
            q + self.w * (self.phi * p + self.psi * self.f) + h * self.a,
            self.e * p + self.phi * self.f,
        )
    }
}

impl<T: Real> Drift<T> {
    /// The drift of `A` (row-major `n × n`) and the forcing `b`, when `A` has that form:
    /// `n = 2d`, row `i < d` nonzero at most at column `d + i`, row `d + i` at most on the
    /// diagonal.
    pub(super) fn detect(n: usize, a: &[T], b: &[T]) -> Option<Self> {
        if n == 0 || !n.is_multiple_of(2) || a.len() != n * n || b.len() != n {
            return None;
        }
        let d = n / 2;
        let zero = T::zero();
        for i in 0..n {
            for j in 0..n {
                let allowed = if i < d { j == d + i } else { j == i };
                if !allowed && a[i * n + j] != zero {
                    return None;
                }
            }
        }
        let coordinates = (0..d)
            .map(|i| Coordinate {
                w: a[i * n + d + i],
                c: -a[(d + i) * n + d + i],
                f: b[d + i],
                a: b[i],
                e: zero,
                phi: zero,
                psi: zero,
            })
            .collect();
        Some(Self {
            coordinates,
            h: None,
        })
    }

    /// Forms `(e, φ, ψ)` of each coordinate for step `h` when `h` changed (a coordinate with
    /// the damping of the one before takes its values).
    #[inline]
    fn update(&mut self, h: T) {
        if self.h == Some(h) {
            return;
        }
        let mut last: Option<(T, [T; 3])> = None;
        for k in &mut self.coordinates {
            let v = match last {
                Some((c, v)) if c == k.c => v,
                _ => drift_coefficients(k.c, h),
            };
            [k.e, k.phi, k.psi] = v;
            last = Some((k.c, v));
        }
        self.h = Some(h);
    }

    /// `x ← Φ_h(x)`; `false` (and `x` unchanged) when the result is not finite (a
    /// non-finite `x` gives one: every coordinate's map has a nonzero coefficient on itself).
    #[inline]
    pub(super) fn step(&mut self, h: T, x: &mut [T]) -> bool {
        self.update(h);
        let d = self.coordinates.len();
        let (q, p) = x.split_at_mut(d);
        // Checked before writing (`v · 0` is zero exactly when `v` is finite): a non-finite
        // result leaves `x` as it was. A few coordinates go through a stack buffer (one pass),
        // more are mapped twice.
        let mut check = T::zero();
        if d <= STACK {
            let mut out = [(T::zero(), T::zero()); STACK];
            for (((k, &qi), &pi), o) in self.coordinates.iter().zip(&*q).zip(&*p).zip(&mut out) {
                *o = k.map(h, qi, pi);
                check = check + (o.0 + o.1) * T::zero();
            }
            if check != T::zero() {
                return false;
            }
            for ((o, qi), pi) in out.iter().zip(q).zip(p) {
                (*qi, *pi) = *o;
            }
            return true;
        }
        for ((k, &qi), &pi) in self.coordinates.iter().zip(&*q).zip(&*p) {
            let (a, b) = k.map(h, qi, pi);
            check = check + (a + b) * T::zero();
        }
        if check != T::zero() {
            return false;
        }
        for ((k, qi), pi) in self.coordinates.iter().zip(q).zip(p) {
            (*qi, *pi) = k.map(h, *qi, *pi);
        }
        true
    }

    /// `out = DΦ_h v = (v_q + w φ v_p, e v_p)` for the step size of the last step.
    #[inline]
    pub(super) fn tangent(&self, v: &[T], out: &mut [T]) -> bool {
        if self.h.is_none() {
            return false;
        }
        let d = self.coordinates.len();
        let (vq, vp) = v.split_at(d);
        let (oq, op) = out.split_at_mut(d);
        for (((k, oq), op), (&vq, &vp)) in self
            .coordinates
            .iter()
            .zip(oq)
            .zip(op)
            .zip(vq.iter().zip(vp))
        {
            *oq = vq + k.w * k.phi * vp;
            *op = k.e * vp;
        }
        true
    }
}

/// `(e^{−ch}, φ, ψ)` with `φ = (1 − e^{−ch})/c` by `exp_m1` (no cancellation) and
/// `ψ = (h − φ)/c = h² (x − 1 + e^{−x})/x²` at `x = ch` ([`fall_series`], by its Taylor series
/// where the closed form cancels).
pub(super) fn drift_coefficients<T: Real>(c: T, h: T) -> [T; 3] {
    let x = c * h;
    let e = (-x).exp();
    if c == T::zero() {
        return [e, h, T::lit(0.5) * h * h];
    }
    let phi = -(-x).exp_m1() / c;
    [e, phi, h * h * fall_series(x, 2)]
}

/// `(x − 1 + e^{−x})/x²` (`k = 2`) or `(x − 2(1 − e^{−x}) + (1 − e^{−2x})/2)/x³` (`k = 3`),
/// the free fall's `ψ/t²` and `∫φ²/t³` at `x = γt`: by their Taylor series below `|x| = 1/2`,
/// where the closed forms cancel, `Σ_{n≥k} cₙ (−x)^{n−k}/n!` with `cₙ = 1` (`k = 2`) or
/// `cₙ = 2^{n−1} − 2` (`k = 3`), summed to the scalar's round-off (`k = 2` in `f64` or
/// coarser: Horner's rule on the polynomial that reaches it, [`fall_horner`]).
pub(crate) fn fall_series<T: Real>(x: T, k: u32) -> T {
    if x.abs() >= T::lit(0.5) {
        let e1 = (-x).exp_m1();
        return if k == 2 {
            (x + e1) / (x * x)
        } else {
            (x + T::lit(2.0) * e1 - T::lit(0.5) * (T::lit(-2.0) * x).exp_m1()) / (x * x * x)
        };
    }
    if k == 2 && T::epsilon() >= T::lit(f64::EPSILON) {
        return fall_horner(x);
    }
    fall_summed(x, k)
}

/// [`fall_series`] below `|x| = 1/2` by summing the series until its terms fall below the
/// scalar's round-off (any precision).
fn fall_summed<T: Real>(x: T, k: u32) -> T {
    let one = T::one();
    // term = (−x)^{n−k}/n!, starting at n = k.
    let mut term = if k == 2 {
        T::lit(0.5)
    } else {
        one / T::lit(6.0)
    };
    let mut pow2 = if k == 2 { one } else { T::lit(4.0) }; // 2^{n−1}
    let mut sum = T::lit(0.0);
    let mut n = k;
    loop {
        let coefficient = if k == 2 { one } else { pow2 - T::lit(2.0) };
        let add = coefficient * term;
        sum = sum + add;
        if add.abs() <= T::epsilon() * sum.abs() || n > 80 {
            return sum;
        }
        n += 1;
        term = -term * x / T::lit(f64::from(n));
        pow2 = pow2 * T::lit(2.0);
    }
}

/// `1/(n+2)!`, `n = 0 … 14`: the Taylor coefficients of `(x − 1 + e^{−x})/x²` in `−x`.
const FALL_COEFFICIENTS: [f64; 15] = [
    0.5,
    0.16666666666666666,
    0.041666666666666664,
    0.008333333333333333,
    0.001388888888888889,
    0.0001984126984126984,
    2.48015873015873e-05,
    2.7557319223985893e-06,
    2.755731922398589e-07,
    2.505210838544172e-08,
    2.08767569878681e-09,
    1.6059043836821613e-10,
    1.1470745597729725e-11,
    7.647163731819816e-13,
    4.779477332387385e-14,
];

/// `(x − 1 + e^{−x})/x²` for `|x| < 1/2` in a scalar no finer than `f64`: the Taylor
/// polynomial by Horner's rule, with as many terms as `|x|` needs for the first one left out,
/// `|x|^N/(N+2)!`, to fall below `ε/1000` of the sum (≥ 0.42): multiplications only, where the
/// summed series divides once a term (a drift's coefficients are formed for every new step
/// size, an extrapolation's every row).
#[inline]
fn fall_horner<T: Real>(x: T) -> T {
    let a = x.abs();
    let top = if a > T::lit(0.25) {
        14
    } else if a > T::lit(0.1) {
        12
    } else if a > T::lit(0.03) {
        10
    } else if a > T::lit(0.01) {
        8
    } else {
        7
    };
    let mut sum = T::lit(FALL_COEFFICIENTS[top]);
    for &c in FALL_COEFFICIENTS[..top].iter().rev() {
        sum = T::lit(c) - x * sum;
    }
    sum
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The coefficients against their definitions, `φ = ∫₀ʰ e^{−cs} ds` and `ψ = ∫₀ʰ φ(s) ds`
    /// by Simpson's rule on a fine grid (error `O(h⁵/N⁴)`, far below the bound), on both sides
    /// of the series' threshold and where `1 − e^{−ch}` cancels (`c = 10⁻⁹`).
    #[test]
    fn coefficients_match_their_integrals() {
        let simpson = |g: &dyn Fn(f64) -> f64, h: f64| {
            let n = 2000;
            let ds = h / n as f64;
            let inner: f64 = (1..n)
                .map(|k| if k % 2 == 1 { 4.0 } else { 2.0 } * g(k as f64 * ds))
                .sum();
            ds / 3.0 * (g(0.0) + inner + g(h))
        };
        for &(c, h) in &[
            (0.5f64, 0.01f64),
            (0.5, 0.9),
            (2.0, 0.3),
            (1e-9, 1.0),
            (30.0, 0.1),
        ] {
            let [e, phi, psi] = drift_coefficients(c, h);
            assert!((e - (-c * h).exp()).abs() <= 1e-15);
            let decay = |s: f64| (-c * s).exp();
            let phi_ref = simpson(&decay, h);
            assert!(
                (phi - phi_ref).abs() <= 1e-12 * phi,
                "c {c}, h {h}: φ {phi} vs {phi_ref}"
            );
            let phi_at = |s: f64| simpson(&decay, s);
            let psi_ref = simpson(&phi_at, h);
            assert!(
                (psi - psi_ref).abs() <= 1e-11 * psi,
                "c {c}, h {h}: ψ {psi} vs {psi_ref}"
            );
        }
        assert_eq!(drift_coefficients(0.0, 0.2), [1.0, 0.2, 0.5 * 0.2 * 0.2]);
    }

    /// The closed form against the matrix exponential of the same system with its
    /// coordinates reordered `(p, q)` (not a drift in that order: the dense path): two
    /// coordinates of different damping, masses and forces, steps on both sides of the
    /// series' threshold and backwards. Both are the exact flow; they differ by rounding.
    #[test]
    fn closed_form_equals_the_exponential() {
        use crate::flow::{Flow, LinearFlow};
        use nalgebra::SVector;
        type V = SVector<f64, 4>;
        let (w, c, f, a) = ([2.0, 0.5], [0.7, 3.0], [-1.0, 0.25], [0.1, 0.0]);
        // x = (q1, q2, p1, p2).
        let mut m = [0.0; 16];
        let mut b = [0.0; 4];
        for i in 0..2 {
            m[i * 4 + 2 + i] = w[i];
            m[(2 + i) * 4 + 2 + i] = -c[i];
            b[i] = a[i];
            b[2 + i] = f[i];
        }
        // y = (p1, p2, q1, q2) = P x.
        let perm = [2, 3, 0, 1];
        let mut mp = [0.0; 16];
        let mut bp = [0.0; 4];
        for i in 0..4 {
            for j in 0..4 {
                mp[i * 4 + j] = m[perm[i] * 4 + perm[j]];
            }
            bp[i] = b[perm[i]];
        }
        let mut drift = LinearFlow::try_new(4, &m)
            .unwrap()
            .with_forcing(&b)
            .unwrap();
        let mut dense = LinearFlow::try_new(4, &mp)
            .unwrap()
            .with_forcing(&bp)
            .unwrap();
        assert!(drift.is_drift() && !dense.is_drift());
        let x0 = V::new(0.3, -1.2, 0.8, -0.4);
        for &h in &[0.05, 0.4, 1.7, -0.3] {
            let mut x = x0;
            let mut y = V::from_fn(|i, _| x0[perm[i]]);
            Flow::<V>::step(&mut drift, h, &mut x).unwrap();
            Flow::<V>::step(&mut dense, h, &mut y).unwrap();
            for i in 0..4 {
                let scale = 1.0 + x[perm[i]].abs();
                assert!(
                    (y[i] - x[perm[i]]).abs() <= 1e-14 * scale,
                    "h {h}: {x} vs {y}"
                );
            }
            // Tangent maps: the same linear part.
            let v = V::new(1.0, -0.5, 0.25, 2.0);
            let (mut tx, mut ty) = (V::zeros(), V::zeros());
            assert!(drift.tangent_apply(&v, &mut tx));
            let vp = V::from_fn(|i, _| v[perm[i]]);
            assert!(dense.tangent_apply(&vp, &mut ty));
            for i in 0..4 {
                assert!((ty[i] - tx[perm[i]]).abs() <= 1e-14 * (1.0 + tx[perm[i]].abs()));
            }
        }
    }

    /// A non-finite state, or a result that overflows, is an error that names the component
    /// and leaves the state as it was (the flow contract), as on the exponential's path.
    #[test]
    fn a_non_finite_state_or_result_is_refused_and_leaves_the_state() {
        use crate::error::StepError;
        use crate::flow::{Flow, LinearFlow};
        use nalgebra::SVector;
        type V = SVector<f64, 4>;
        let a = [
            0.0, 0.0, 1.0, 0.0, //
            0.0, 0.0, 0.0, 1.0, //
            0.0, 0.0, -0.5, 0.0, //
            0.0, 0.0, 0.0, -0.5,
        ];
        let mut flow = LinearFlow::try_new(4, &a).unwrap();
        assert!(flow.is_drift());
        let nan = V::new(0.1, f64::NAN, 0.0, 1.0);
        let mut x = nan;
        match Flow::<V>::step(&mut flow, 0.1, &mut x) {
            Err(StepError::NonFinite { component: 1 }) => {}
            other => panic!("expected NonFinite at 1, got {other:?}"),
        }
        assert!(x[0] == 0.1 && x[1].is_nan() && x[3] == 1.0);
        // q + h p overflows in the first coordinate.
        let big = V::new(f64::MAX, 0.0, f64::MAX, 0.0);
        let mut x = big;
        match Flow::<V>::step(&mut flow, 1.0, &mut x) {
            Err(StepError::NonFinite { component: 0 }) => {}
            other => panic!("expected NonFinite at 0, got {other:?}"),
        }
        assert_eq!(x, big);
    }

    /// Horner's polynomial against the series summed to round-off, across `|x| < 1/2` and on
    /// both sides of each change in its length: the same function, each within a few
    /// roundings of a sum ≥ 0.42 of positive-ratio terms (`|x|/(n+3) ≤ 1/6`), so within 4ε of
    /// each other.
    #[test]
    fn horner_agrees_with_the_summed_series() {
        let mut xs: Vec<f64> = (-500..500).map(|i| i as f64 * 1e-3 + 3.7e-4).collect();
        for edge in [0.25f64, 0.1, 0.03, 0.01] {
            for s in [-1.0, 1.0] {
                xs.extend([s * edge * (1.0 - 1e-12), s * edge * (1.0 + 1e-12)]);
            }
        }
        xs.extend([0.0, 1e-300, -1e-9, 0.4999999]);
        for x in xs {
            let (a, b) = (fall_horner(x), fall_summed(x, 2));
            assert!(
                (a - b).abs() <= 4.0 * f64::EPSILON * b,
                "x {x}: Horner {a:e}, summed {b:e}"
            );
        }
        assert_eq!(fall_series(0.2f64, 2), fall_horner(0.2));
    }

    #[test]
    fn detects_only_the_drift_form() {
        // q' = 2 p, p' = −0.5 p − 1: a drift.
        let a = [0.0, 2.0, 0.0, -0.5];
        assert!(Drift::detect(2, &a, &[0.0, -1.0]).is_some());
        // A spring couples p' to q: not a drift.
        let spring = [0.0, 1.0, -1.0, -0.5];
        assert!(Drift::detect(2, &spring, &[0.0, 0.0]).is_none());
        // Odd dimension.
        assert!(Drift::detect(1, &[0.0], &[0.0]).is_none());
    }
}
