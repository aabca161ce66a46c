//! The first step of an error-controlled flow when none is given: the starting step of
//! Hairer, Nørsett & Wanner (*Solving ODEs I*, §II.4, "Starting step size"; DOP853's `hinit`),
//! its derivatives read from the base step itself.

use super::Tolerances;
use crate::flow::{Flow, Ledger};
use crate::real::Real;
use crate::vector::Vector;
use num_traits::{Float as _, Zero as _};

/// An estimate of the first step, at most `span` long, for a method of order `p` built on
/// `base` (a step `S_h`), from `x` at the ledger's time, in the direction `sign` (all in
/// [`Start`]).
///
/// With `‖·‖` the weighted norm of `tolerances` (scales from `x`), the derivatives are
/// difference quotients of the flow: `d₀ = ‖x‖`; a probe `S_{h_p} x` with `h_p = span/1000`
/// gives `d₁ ≈ ‖x'‖` and the step `h₀ = 0.01 d₀/d₁` along which `x` moves by about 1% of
/// itself; two steps of `h₀` give `d₁ = ‖S_{h₀}x − x‖/h₀` again and
/// `d₂ = ‖S²_{h₀}x − 2 S_{h₀}x + x‖/h₀² ≈ ‖x''‖`, and
///
/// ```text
/// h = min(100 h₀, (0.01 / max(d₁, d₂))^{1/p}, span)
/// ```
///
/// (`max(10⁻⁶, 10⁻³ h₀)` in place of the middle term when both derivatives vanish): the step at
/// which a method of order `p` whose error constants are those of the first two derivatives
/// would make an error of about the tolerance; at high order the first term, the time over
/// which `x` changes by about itself, is the one that binds. It costs three base steps,
/// against a first macro step tried over the whole interval and rejected down to the
/// problem's scale.
///
/// The base flow's memory is saved first and restored after, the state and the ledger are not
/// touched: the estimate changes nothing the run then does but its first step. `None` when a
/// probe fails at every size tried (the caller then starts from the interval, as given), or
/// the estimate is not a positive finite number. The second value counts the base steps taken.
pub(crate) fn estimate<V: Vector, F: Flow<V>>(
    base: &mut F,
    start: &Start<'_, V>,
) -> (Option<V::Real>, u64) {
    let mut memory = Vec::new();
    base.save_memory(&mut memory);
    let mut steps = 0;
    let found = probe(base, start, &memory, &mut steps);
    let mut from = memory.as_slice();
    base.restore_memory(&mut from);
    (
        found.filter(|h| *h > V::Real::zero() && h.is_finite()),
        steps,
    )
}

/// Where and for what the first step is estimated.
pub(crate) struct Start<'a, V: Vector> {
    /// The weighted norm.
    pub(crate) tolerances: &'a Tolerances<V::Real>,
    /// The order of the method the first step is taken with.
    pub(crate) order: u32,
    /// The ledger at the start (its time).
    pub(crate) ledger: &'a Ledger<V::Real>,
    /// The direction of time, `±1`.
    pub(crate) sign: V::Real,
    /// The longest first step.
    pub(crate) span: V::Real,
    /// The state.
    pub(crate) x: &'a V,
}

/// The estimate of [`estimate`], leaving the base flow's memory changed; `steps` counts the base
/// steps taken.
fn probe<V: Vector, F: Flow<V>>(
    base: &mut F,
    start: &Start<'_, V>,
    memory: &[V::Real],
    steps: &mut u64,
) -> Option<V::Real> {
    let Start {
        tolerances,
        order: p,
        ledger,
        sign,
        span,
        x,
    } = *start;
    let zero = x.zeros_like();
    let norm = |a: &V, b: &V| {
        tolerances
            .error(a.as_slice(), b.as_slice(), x.as_slice(), x.as_slice())
            .to_f64_lossy()
    };
    let span_f = span.to_f64_lossy();
    let mut z1 = x.clone();
    // One step of `h` from `x` into `out` with the base flow's memory as the call found it.
    let mut step = |base: &mut F, h: f64, out: &mut V| -> bool {
        *steps += 1;
        let mut from = memory;
        base.restore_memory(&mut from);
        out.copy_from(x);
        let mut l = *ledger;
        base.step_at(&mut l, sign * V::Real::lit(h), out).is_ok()
    };
    // The probe, smaller by 10 until the base step takes it (three tries).
    let d0 = norm(x, &zero);
    let mut hp = span_f * 1e-3;
    let mut d1 = f64::NAN;
    for _ in 0..3 {
        if step(base, hp, &mut z1) {
            d1 = norm(&z1, x) / hp;
            break;
        }
        hp *= 0.1;
    }
    if !d1.is_finite() {
        return None;
    }
    let h0 = if d0 < 1e-5 || d1 < 1e-5 {
        hp
    } else {
        (0.01 * d0 / d1).min(span_f)
    };
    if !step(base, h0, &mut z1) {
        return None;
    }
    let mut z2 = z1.clone();
    let mut l = *ledger;
    l.t = l.t + sign * V::Real::lit(h0);
    *steps += 1;
    base.step_at(&mut l, sign * V::Real::lit(h0), &mut z2)
        .ok()?;
    let d1 = norm(&z1, x) / h0;
    // z2 − 2 z1 + x, in place.
    let two = V::Real::lit(2.0);
    for ((c, &b), &a) in z2
        .as_mut_slice()
        .iter_mut()
        .zip(z1.as_slice())
        .zip(x.as_slice())
    {
        *c = *c - two * b + a;
    }
    let d2 = norm(&z2, &zero) / (h0 * h0);
    let d = d1.max(d2);
    let h1 = if d <= 1e-15 {
        (h0 * 1e-3).max(1e-6)
    } else {
        (0.01 / d).powf(1.0 / f64::from(p.max(1)))
    };
    Some(V::Real::lit((100.0 * h0).min(h1).min(span_f)))
}

#[cfg(test)]
#[path = "first_step_tests.rs"]
mod tests;
