//! Input signals `u(t)` and their exact integrals over a sub-step.

use crate::real::Real;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

/// A value held between steps (zero-order hold), set by the embedder through any clone of the
/// handle: `u(t) = v` until the next [`set`](Held::set). Lock-free (an atomic `f64`), so a
/// flow that reads it stays `Send + Sync` and a step allocates nothing.
#[derive(Debug, Clone, Default)]
pub struct Held(Arc<AtomicU64>);

impl Held {
    /// A held value, initially `v`.
    pub fn new(v: f64) -> Self {
        Self(Arc::new(AtomicU64::new(v.to_bits())))
    }
    /// Sets the value the next steps integrate.
    pub fn set(&self, v: f64) {
        self.0.store(v.to_bits(), Ordering::Relaxed);
    }
    /// The value held.
    pub fn get(&self) -> f64 {
        f64::from_bits(self.0.load(Ordering::Relaxed))
    }
}

/// One input channel `u(t)`.
///
/// Every closed form is integrated exactly over a sub-step (`∫_a^b u dt`, the quantity the
/// exact input flow needs), computed from the sub-step's own length so that short sub-steps
/// late in a run keep their relative accuracy. A [`Signal::Function`] is integrated by the
/// 5-point Gauss–Legendre rule (exact for polynomials of degree 9, so it does not limit
/// compositions up to order 8 on smooth inputs).
#[derive(Clone)]
pub enum Signal<T> {
    /// `u = c`.
    Constant(T),
    /// `u = before` for `t < at`, `after` from `at` on.
    Step {
        /// The switching time.
        at: T,
        /// The value before.
        before: T,
        /// The value after.
        after: T,
    },
    /// `u = from` until `start`, linear to `to` at `end`, `to` after.
    Ramp {
        /// Start of the ramp.
        start: T,
        /// End of the ramp (`> start`).
        end: T,
        /// The value before `start`.
        from: T,
        /// The value after `end`.
        to: T,
    },
    /// `u = offset + amplitude · sin(ω t + phase)`, `ω` in rad per unit time.
    Sine {
        /// Amplitude.
        amplitude: T,
        /// Angular frequency `ω`.
        omega: T,
        /// Phase (rad).
        phase: T,
        /// Offset.
        offset: T,
    },
    /// Piecewise-linear through `(times[i], values[i])` (increasing times), held constant
    /// outside.
    Table(Arc<[(T, T)]>),
    /// A value held between steps, set by the embedder.
    Held(Held),
    /// Any function of time.
    Function(Arc<dyn Fn(T) -> T + Send + Sync>),
}

impl<T: core::fmt::Debug> core::fmt::Debug for Signal<T> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Constant(c) => f.debug_tuple("Constant").field(c).finish(),
            Self::Step { at, before, after } => f
                .debug_struct("Step")
                .field("at", at)
                .field("before", before)
                .field("after", after)
                .finish(),
            Self::Ramp {
                start,
                end,
                from,
                to,
            } => f
                .debug_struct("Ramp")
                .field("start", start)
                .field("end", end)
                .field("from", from)
                .field("to", to)
                .finish(),
            Self::Sine {
                amplitude,
                omega,
                phase,
                offset,
            } => f
                .debug_struct("Sine")
                .field("amplitude", amplitude)
                .field("omega", omega)
                .field("phase", phase)
                .field("offset", offset)
                .finish(),
            Self::Table(t) => f.debug_tuple("Table").field(&t.len()).finish(),
            Self::Held(h) => f.debug_tuple("Held").field(&h.get()).finish(),
            Self::Function(_) => f.write_str("Function(..)"),
        }
    }
}

/// Gauss–Legendre nodes and weights on `[−1, 1]`, 5 points.
const GL5: [(f64, f64); 5] = [
    (0.0, 0.568_888_888_888_888_9),
    (-0.538_469_310_105_683_1, 0.478_628_670_499_366_47),
    (0.538_469_310_105_683_1, 0.478_628_670_499_366_47),
    (-0.906_179_845_938_664, 0.236_926_885_056_189_08),
    (0.906_179_845_938_664, 0.236_926_885_056_189_08),
];

impl<T: Real> Signal<T> {
    /// A piecewise-linear table; `None` unless it has at least one point, its times strictly
    /// increase and every value is finite.
    pub fn table(points: &[(T, T)]) -> Option<Self> {
        let ok = !points.is_empty()
            && points.iter().all(|(t, v)| t.is_finite() && v.is_finite())
            && points.windows(2).all(|w| w[0].0 < w[1].0);
        ok.then(|| Self::Table(points.into()))
    }

    /// A signal from any function of time.
    pub fn function(f: impl Fn(T) -> T + Send + Sync + 'static) -> Self {
        Self::Function(Arc::new(f))
    }

    /// `u(t)`.
    pub fn value(&self, t: T) -> T {
        match self {
            Self::Constant(c) => *c,
            Self::Step { at, before, after } => {
                if t < *at {
                    *before
                } else {
                    *after
                }
            }
            Self::Ramp {
                start,
                end,
                from,
                to,
            } => linear(&[(*start, *from), (*end, *to)], t),
            Self::Sine {
                amplitude,
                omega,
                phase,
                offset,
            } => *offset + *amplitude * (*omega * t + *phase).sin(),
            Self::Table(points) => linear(points, t),
            Self::Held(h) => T::lit(h.get()),
            Self::Function(f) => f(t),
        }
    }

    /// Appends the times where `u` or its derivative jumps: a step's switch, a ramp's two
    /// ends, a table's points. A smooth signal, a held one (it changes between the embedder's
    /// steps, which land on them) or a function (whose kinks are not known) appends none. An
    /// adaptive flow lands on them ([`AdaptiveOptions::breakpoints`](crate::flow::AdaptiveOptions::breakpoints)):
    /// a step across one is not the smooth expansion its error estimate assumes.
    pub fn breakpoints(&self, out: &mut Vec<T>) {
        match self {
            Self::Step { at, .. } => out.push(*at),
            Self::Ramp { start, end, .. } => out.extend([*start, *end]),
            Self::Table(points) => out.extend(points.iter().map(|p| p.0)),
            Self::Constant(_) | Self::Sine { .. } | Self::Held(_) | Self::Function(_) => {}
        }
    }

    /// `∫_a^b u(t) dt` (negative when `b < a`).
    pub fn integral(&self, a: T, b: T) -> T {
        let half = T::lit(0.5);
        match self {
            Self::Constant(c) => *c * (b - a),
            Self::Held(h) => T::lit(h.get()) * (b - a),
            Self::Sine {
                amplitude,
                omega,
                phase,
                offset,
            } => {
                let w = *omega * (b - a);
                // A/ω (cos(ωa+φ) − cos(ωb+φ)) = A (b−a) sin(ω(a+b)/2 + φ) sinc(ω(b−a)/2).
                let mid = *omega * (a + b) * half + *phase;
                let x = w * half;
                let sinc = if x.abs() < T::lit(1e-4) {
                    T::one() - x * x / T::lit(6.0)
                } else {
                    x.sin() / x
                };
                *offset * (b - a) + *amplitude * (b - a) * mid.sin() * sinc
            }
            Self::Step { at, before, after } => {
                let pts = [(*at, *before), (*at, *after)];
                piecewise_integral(&pts, a, b, true)
            }
            Self::Ramp {
                start,
                end,
                from,
                to,
            } => piecewise_integral(&[(*start, *from), (*end, *to)], a, b, false),
            Self::Table(points) => piecewise_integral(points, a, b, false),
            Self::Function(f) => {
                let (c, r) = ((a + b) * half, (b - a) * half);
                GL5.iter()
                    .fold(T::zero(), |s, &(x, w)| s + T::lit(w) * f(c + r * T::lit(x)))
                    * r
            }
        }
    }
}

/// The piecewise-linear interpolant through `points`, constant outside.
fn linear<T: Real>(points: &[(T, T)], t: T) -> T {
    let (first, last) = (points[0], points[points.len() - 1]);
    if t <= first.0 {
        return first.1;
    }
    if t >= last.0 {
        return last.1;
    }
    let i = points.partition_point(|p| p.0 <= t).max(1);
    let (p, q) = (points[i - 1], points[i]);
    p.1 + (q.1 - p.1) * (t - p.0) / (q.0 - p.0)
}

/// `∫_a^b` of the piecewise-linear function through `points` (constant outside), summed over
/// the pieces that `[a, b]` overlaps: exact, and computed from the pieces' own lengths. With
/// `jump`, the two points share a time (a step): left value before it, right value after.
fn piecewise_integral<T: Real>(points: &[(T, T)], a: T, b: T, jump: bool) -> T {
    if b < a {
        return -piecewise_integral(points, b, a, jump);
    }
    let value = |t: T, right: bool| -> T {
        if jump {
            if t < points[0].0 || (t == points[0].0 && !right) {
                points[0].1
            } else {
                points[1].1
            }
        } else {
            linear(points, t)
        }
    };
    let mut total = T::zero();
    let mut lo = a;
    for &(knot, _) in points {
        if knot <= lo {
            continue;
        }
        if knot >= b {
            break;
        }
        total = total + (knot - lo) * (value(lo, true) + value(knot, false)) * T::lit(0.5);
        lo = knot;
    }
    total + (b - lo) * (value(lo, true) + value(b, false)) * T::lit(0.5)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn integrals_are_exact_for_the_closed_forms() {
        let s = Signal::Sine {
            amplitude: 2.0,
            omega: 3.0,
            phase: 0.5,
            offset: 0.25,
        };
        let exact = |a: f64, b: f64| {
            0.25 * (b - a) + 2.0 / 3.0 * ((3.0 * a + 0.5).cos() - (3.0 * b + 0.5).cos())
        };
        for (a, b) in [(0.0, 1.0), (1.3, 1.3001), (2.0, -1.0)] {
            assert!((s.integral(a, b) - exact(a, b)).abs() < 1e-15);
        }
        let step = Signal::Step {
            at: 1.0,
            before: 1.0,
            after: 3.0,
        };
        assert_eq!(step.integral(0.5, 2.0), 0.5 + 3.0);
        assert_eq!(step.integral(2.0, 0.5), -3.5);
        let table = Signal::<f64>::table(&[(0.0, 0.0), (1.0, 2.0), (3.0, 0.0)]).unwrap();
        assert!((table.integral(-1.0, 4.0) - 3.0).abs() < 1e-15);
        assert!((table.integral(0.5, 2.0) - (0.75 + 1.5)).abs() < 1e-15);
        let ramp = Signal::<f64>::Ramp {
            start: 1.0,
            end: 2.0,
            from: 0.0,
            to: 1.0,
        };
        assert!((ramp.integral(0.0, 3.0) - 1.5).abs() < 1e-15);
        let cubic = Signal::function(|t: f64| t * t * t);
        assert!((cubic.integral(1.0, 2.0) - 3.75).abs() < 1e-14);
        assert!(Signal::<f64>::table(&[(1.0, 0.0), (1.0, 1.0)]).is_none());
    }

    #[test]
    fn held_values_are_set_through_any_clone() {
        let h = Held::new(1.5);
        let s = Signal::<f64>::Held(h.clone());
        assert_eq!(s.integral(0.0, 2.0), 3.0);
        h.set(-1.0);
        assert_eq!(s.value(7.0), -1.0);
    }
}
