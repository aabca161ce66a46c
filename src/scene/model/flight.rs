//! The exact flow of the kinetic term under `M`, with uniform gravity joined to it when no body
//! has a magnetic field: each body's free flight — a drift, a free fall, or rotated about the
//! magnetic field and damped in closed form.

use super::SceneModel;
use crate::error::StepError;
use crate::flow::fall_series;
use crate::flow::{EXACT, Flow, Ledger};
use crate::real::Real;
use crate::vector::Vector;
use std::sync::Arc;

/// The free flight of one body under `M`: what its kinetic flow has to do.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Flight<T> {
    /// `q += t p/m`.
    Drift,
    /// Under the constant force `F` (uniform gravity): `q += t p/m + t² F/(2m)`, `p += t F`.
    Fall { force: [T; 3] },
    /// The closed form with `γ = c/m` and `ω⃗ = e B/m`, no force.
    Exact { gamma: T, omega: [T; 3] },
    /// Damped (`γ = c/m > 0`) under the constant force `F`, no field.
    DampedFall { gamma: T, force: [T; 3] },
}

/// What a body's flight for time `t` needs that depends on `t` only: computed once per sub-step
/// length and kept ([`FlightCache`]), since a scheme calls its flight with few lengths.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct FlightCoefficients<T> {
    /// `e^{−γt}`.
    decay: T,
    /// `φ = ∫₀ᵗ e^{−γs} ds = (1 − e^{−γt})/γ`.
    phi: T,
    /// The field's direction `b̂ = ω⃗/ω`, and whether there is a field (`ω > 0`).
    axis: [T; 3],
    turning: bool,
    /// `(a + ib) = (e^{zt} − 1)/z`, `z = −γ + iω` (field only).
    a: T,
    b: T,
    cos: T,
    sin: T,
    /// `1 − e^{−2γt}`: the fraction of `|p|²` the damping removes without a force.
    lost: T,
    /// `ψ = ∫₀ᵗ φ(s) ds` (force only).
    psi: T,
    /// `∫₀ᵗ e^{−2γs} ds` and `∫₀ᵗ φ(s)² ds` (damped fall: the dissipated energy).
    i1: T,
    i3: T,
}

impl<T: Real> Flight<T> {
    /// The coefficients of this flight for time `t`.
    pub(super) fn coefficients(&self, t: T) -> FlightCoefficients<T> {
        let zero = T::lit(0.0);
        let mut c = FlightCoefficients {
            decay: T::one(),
            phi: t,
            axis: [zero; 3],
            turning: false,
            a: zero,
            b: zero,
            cos: T::one(),
            sin: zero,
            lost: zero,
            psi: T::lit(0.5) * t * t,
            i1: t,
            i3: t * t * t / T::lit(3.0),
        };
        match *self {
            Flight::Drift | Flight::Fall { .. } => {}
            Flight::Exact { gamma, omega } => {
                let x = gamma * t;
                c.decay = (-x).exp();
                if gamma != zero {
                    c.phi = -(-x).exp_m1() / gamma;
                    c.lost = -(T::lit(-2.0) * x).exp_m1();
                }
                let om = norm3(omega);
                if om != zero {
                    let (s, co) = (om * t).sin_cos();
                    let half = (T::lit(0.5) * om * t).sin();
                    // e^{zt} − 1 = (e^{−γt} cos ωt − 1) + i e^{−γt} sin ωt, the real part
                    // without cancellation.
                    let nr = (-x).exp_m1() * co - T::lit(2.0) * half * half;
                    let ni = c.decay * s;
                    // (nr + i ni) / z with z scaled by max(γ, ω) first, so that a field so weak
                    // that γ² + ω² underflows still divides correctly.
                    let scale = gamma.max(om);
                    let (zr, zi) = (-gamma / scale, om / scale);
                    let den = (zr * zr + zi * zi) * scale;
                    c.a = (zr * nr + zi * ni) / den;
                    c.b = (zr * ni - zi * nr) / den;
                    c.cos = co;
                    c.sin = s;
                    c.axis = omega.map(|o| o / om);
                    c.turning = true;
                }
            }
            Flight::DampedFall { gamma, .. } => {
                let x = gamma * t;
                c.decay = (-x).exp();
                c.phi = -(-x).exp_m1() / gamma;
                c.psi = t * t * fall_series(x, 2);
                c.i1 = -(T::lit(-2.0) * x).exp_m1() / (T::lit(2.0) * gamma);
                c.i3 = t * t * t * fall_series(x, 3);
            }
        }
        c
    }

    /// The energy the damping of this flight removes from a body (`w = 1/m`) that starts with
    /// momentum `p` under the constant force `f`, as a quadratic form in `(p, f)`: what
    /// [`apply`](Self::apply) returns is `form.eval(p, f)` (the consistent account evaluates it
    /// on their constraint-consistent parts, `consistent.rs`).
    pub(super) fn form(&self, c: &FlightCoefficients<T>, w: T) -> BodyForm {
        let zero = T::lit(0.0);
        let f = |x: T| x.to_f64_lossy();
        match *self {
            Flight::Exact { gamma, .. } if gamma != zero => BodyForm {
                p2: f(T::lit(0.5) * w * c.lost),
                ..BodyForm::default()
            },
            Flight::DampedFall { gamma, .. } => BodyForm {
                p2: f(gamma * w * c.i1),
                pf: f(gamma * w * c.phi * c.phi),
                f2: f(gamma * w * c.i3),
            },
            _ => BodyForm::default(),
        }
    }

    /// The flight without its force: the linear part of the (affine) flow, its tangent map.
    fn homogeneous(&self) -> Self {
        match *self {
            Flight::Fall { .. } => Flight::Drift,
            Flight::DampedFall { gamma, .. } => Flight::Exact {
                gamma,
                omega: [T::lit(0.0); 3],
            },
            other => other,
        }
    }

    /// Advances one body (`w = 1/m`, `qb`, `pb` of length `d`) by the flight with coefficients
    /// `c`; returns the energy the damping removed, `∫₀ᵗ vᵀ R v ds ≥ 0`.
    #[inline(always)]
    pub(super) fn apply(&self, c: &FlightCoefficients<T>, w: T, qb: &mut [T], pb: &mut [T]) -> T {
        let d = qb.len();
        let zero = T::lit(0.0);
        match *self {
            Flight::Drift => {
                for k in 0..d {
                    qb[k] = qb[k] + (c.phi * w * pb[k]);
                }
                zero
            }
            Flight::Fall { force } => {
                for k in 0..d {
                    qb[k] = qb[k] + w * (c.phi * pb[k] + c.psi * force[k]);
                    pb[k] = pb[k] + c.phi * force[k];
                }
                zero
            }
            Flight::Exact { gamma, .. } => {
                let p = load3(pb);
                let p2 = dot3(p, p);
                if !c.turning {
                    for k in 0..d {
                        qb[k] = qb[k] + w * c.phi * p[k];
                        pb[k] = c.decay * p[k];
                    }
                } else {
                    let bh = c.axis;
                    let along = dot3(bh, p);
                    let par = [along * bh[0], along * bh[1], along * bh[2]];
                    let perp = [p[0] - par[0], p[1] - par[1], p[2] - par[2]];
                    let wv = cross(bh, perp);
                    for k in 0..d {
                        qb[k] = qb[k] + w * (c.phi * par[k] + c.a * perp[k] - c.b * wv[k]);
                        pb[k] = c.decay * (par[k] + c.cos * perp[k] - c.sin * wv[k]);
                    }
                }
                // |p|² − |p(t)|² = (1 − e^{−2γt}) |p|² (the field only turns p).
                if gamma != zero {
                    T::lit(0.5) * w * c.lost * p2
                } else {
                    zero
                }
            }
            Flight::DampedFall { gamma, force } => {
                let p = load3(pb);
                for k in 0..d {
                    qb[k] = qb[k] + w * (c.phi * p[k] + c.psi * force[k]);
                    pb[k] = c.decay * p[k] + c.phi * force[k];
                }
                // γ w ∫|p(s)|² ds with p(s) = e^{−γs} p + φ(s) F and ∫ e^{−γs} φ(s) ds = φ²/2:
                // a sum whose exact value is ≥ 0.
                let removed = gamma
                    * w
                    * (c.i1 * dot3(p, p)
                        + c.phi * c.phi * dot3(p, force)
                        + c.i3 * dot3(force, force));
                removed.max(zero)
            }
        }
    }
}

/// A body's 2 or 3 coordinates as a 3-vector, built from values (see `rod_vector`: a stack
/// array written per coordinate and loaded as a vector stalls on store forwarding).
#[inline]
fn load3<T: Real>(s: &[T]) -> [T; 3] {
    if s.len() == 3 {
        [s[0], s[1], s[2]]
    } else {
        [s[0], s[1], T::lit(0.0)]
    }
}

#[inline]
pub(super) fn dot3<T: Real>(a: [T; 3], b: [T; 3]) -> T {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[inline]
fn norm3<T: Real>(a: [T; 3]) -> T {
    dot3(a, a).sqrt()
}

#[inline]
pub(super) fn cross<T: Real>(a: [T; 3], b: [T; 3]) -> [T; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// The flights' coefficients, one per body, for the last sub-step length — and, set aside, for
/// the few lengths before it: a flow that calls the free flight with the same `t` again (every
/// step of a fixed-step run) recomputes no exponential, and one that alternates between a few
/// lengths (the rows of an extrapolation, sub-steps `h/1 … h/k` in turn) swaps the kept ones
/// back in instead of recomputing the damped fall's exponentials and series.
#[derive(Debug, Clone, Default)]
pub struct FlightCache<T> {
    t: Option<T>,
    coefficients: Vec<FlightCoefficients<T>>,
    /// Earlier lengths, at most [`FLIGHT_KEPT`], the oldest replaced first.
    kept: Vec<(T, Vec<FlightCoefficients<T>>)>,
    next: usize,
}

/// Earlier sub-step lengths a [`FlightCache`] keeps besides the current one (an extrapolation
/// to order 16 alternates between 8).
const FLIGHT_KEPT: usize = 8;

impl<T: Real> FlightCache<T> {
    /// Makes the current coefficients those of `t`: kept, swapped in, or computed (the current
    /// ones are set aside either way).
    #[cold]
    fn switch(&mut self, t: T, flights: &[Flight<T>]) {
        let found = self
            .kept
            .iter()
            .position(|(s, c)| *s == t && c.len() == flights.len());
        let i = match found {
            Some(i) => i,
            None if self.kept.len() < FLIGHT_KEPT => {
                self.kept.push((t, Vec::with_capacity(flights.len())));
                self.kept.len() - 1
            }
            None => {
                let i = self.next;
                self.next = (self.next + 1) % FLIGHT_KEPT;
                i
            }
        };
        let slot = &mut self.kept[i];
        std::mem::swap(&mut slot.1, &mut self.coefficients);
        let previous = self.t.replace(t);
        if found.is_none() {
            self.coefficients.clear();
            self.coefficients
                .extend(flights.iter().map(|f| f.coefficients(t)));
        }
        match previous {
            Some(p) => slot.0 = p,
            // Nothing was current: the slot holds no coefficients worth keeping.
            None => slot.1.clear(),
        }
    }
}

impl<T: Real> SceneModel<T> {
    /// The exact flow of the kinetic term under `M` for time `t` — with uniform gravity when it
    /// is joined to it (no magnetic term): per body, `q' = v = p/m`, `p' = F + e v × B − c v`
    /// (`F = m g`). With `γ = c/m`, `ω⃗ = e B/m = ω b̂`, `p = p∥ + p⊥` along and across `b̂`,
    /// `w = b̂ × p⊥` and `z = −γ + iω`, without force:
    ///
    /// ```text
    /// p(t) = e^{−γt} (p∥ + cos(ωt) p⊥ − sin(ωt) w),
    /// q(t) = q + (1/m) (φ p∥ + a p⊥ − b w),   φ = (1 − e^{−γt})/γ,   a + ib = (e^{zt} − 1)/z,
    /// ```
    ///
    /// and under a force without field `p(t) = e^{−γt} p + φ F`, `q(t) = q + (φ p + ψ F)/m`,
    /// `ψ = ∫₀ᵗ φ = (γt − 1 + e^{−γt})/γ²` (free fall `t²/2` at `γ = 0`); all evaluated without
    /// cancellation (`expm1`, `1 − cos = 2 sin²`, series for small `γt`). Bodies without field,
    /// damping and gravity take the plain drift `q += t p/m`.
    ///
    /// Returns the energy the damping removed, `∫₀ᵗ vᵀ R v ds` over the damped bodies, exactly:
    /// `(1 − e^{−2γt}) |p|²/(2m)` without force, `γ/m (|p|² ∫e^{−2γs} + (p·F) φ² + |F|² ∫φ²)`
    /// with one.
    pub fn free_flight(&self, t: T, x: &mut [T]) -> T {
        let mut cache = FlightCache::default();
        self.free_flight_cached(t, x, &mut cache)
    }

    /// [`free_flight`](Self::free_flight) with the coefficients of `t` kept in `cache` (computed
    /// only when `t` differs from the last call's).
    #[inline(always)]
    pub fn free_flight_cached(&self, t: T, x: &mut [T], cache: &mut FlightCache<T>) -> T {
        if cache.t != Some(t) || cache.coefficients.len() != self.flights.len() {
            cache.switch(t, &self.flights);
        }
        let mut removed = T::lit(0.0);
        let d = self.dim;
        let nq = d * self.masses.len();
        let (q, p) = x.split_at_mut(nq);
        // One count for every term the flight evaluates (the kinetic term, damping, field,
        // joined gravity): the reports add it to each of them.
        self.flight_counter.hit();
        for (b, (flight, c)) in self.flights.iter().zip(&cache.coefficients).enumerate() {
            let (qb, pb) = (&mut q[b * d..b * d + d], &mut p[b * d..b * d + d]);
            removed = removed + flight.apply(c, self.inv_masses[b], qb, pb);
        }
        removed
    }
}

/// The free flight of a scene's bodies as a [`Flow`] (see [`SceneModel::free_flight`]): exact
/// and symmetric, dissipative when the scene declares damping (it books the removed energy in
/// the [`Ledger`]), with its coefficients cached per sub-step length, and its tangent map — the
/// flight is affine in `x`, so `DΦ_t v` is the flight of `v` without the force — for the
/// Jacobian of a projection's `λ_k` system, which then converges quadratically.
#[derive(Debug)]
pub struct FreeFlight<T: Real> {
    model: Arc<SceneModel<T>>,
    cache: FlightCache<T>,
    /// The damping's account on the consistent motion, when damped bodies are constrained
    /// (`consistent.rs`, set by [`with_account`](Self::with_account)), with the state before
    /// the flight.
    account: Option<Accounting>,
}

/// The flight's account on the consistent motion, the state before the flight and the bodies'
/// books it is given.
#[derive(Debug)]
struct Accounting {
    account: Box<dyn DampingAccount>,
    before: Vec<f64>,
    books: BodyBooks,
}

/// A body's closed-form dissipation over a flight as a quadratic form in its initial momentum
/// `p` and the constant force `F` on it: `max(0, p2 |p|² + pf p·F + f2 |F|²)` (the damped
/// fall's `γ w (I₁ |p|² + φ² p·F + I₃ |F|²)`, `½ w (1 − e^{−2γt}) |p|²` without a force).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct BodyForm {
    pub p2: f64,
    pub pf: f64,
    pub f2: f64,
}

impl BodyForm {
    /// The form at `p`, `f` (a planar body's third entries zero), clamped at zero.
    #[inline]
    pub(crate) fn eval(&self, p: [f64; 3], f: [f64; 3]) -> f64 {
        (self.p2 * dot3(p, p) + self.pf * dot3(p, f) + self.f2 * dot3(f, f)).max(0.0)
    }
}

/// Body `b`'s `d` entries of `v` (stride `d`) as a 3-vector.
#[inline]
pub(crate) fn body3(v: &[f64], b: usize, d: usize) -> [f64; 3] {
    load3(&v[b * d..b * d + d])
}

/// What the flight gives its account for each body: the closed form of its dissipation and the
/// constant force on it (`d` entries per body), for the sub-step `t` they were made for.
#[derive(Debug, Default)]
pub(crate) struct BodyBooks {
    pub forms: Vec<BodyForm>,
    pub forces: Vec<f64>,
    pub t: Option<f64>,
}

/// How a flight's damping is booked when it is not the flight's own account: the
/// constraint-consistent account of `consistent.rs`, given to the flight by the scheme that
/// builds it (so that the flight does not depend on the constraints' linear algebra).
pub(crate) trait DampingAccount: core::fmt::Debug {
    /// The booked dissipation kept for a flight of `t` from positions `q` (a Newton iteration
    /// at the positions and sub-step of the last evaluation), if any.
    fn kept_for(&self, t: f64, q: &[f64]) -> Option<f64>;
    /// The dissipation of the flight of `t` from `(q, p)`, body `b`'s closed form and force
    /// being `books.forms[b]` and `books.forces[b d..]`. `None`: keep the flight's own account.
    fn removed(&mut self, t: f64, q: &[f64], p: &[f64], books: &BodyBooks) -> Option<f64>;
    /// Forgets what it keeps (the state was changed from outside a step).
    fn forget(&mut self);
}

impl<T: Real> FreeFlight<T> {
    /// The free flight of `model`'s bodies.
    pub fn new(model: Arc<SceneModel<T>>) -> Self {
        Self {
            model,
            cache: FlightCache::default(),
            account: None,
        }
    }

    /// The same flight booking its damping through `account`.
    pub(crate) fn with_account(mut self, account: Box<dyn DampingAccount>) -> Self {
        self.account = Some(Accounting {
            account,
            before: Vec::new(),
            books: BodyBooks::default(),
        });
        self
    }

    /// The account's booking of the flight just taken from `before` (`None`: keep the
    /// flight's own).
    #[cold]
    fn account_removed(&mut self, t: T) -> Option<f64> {
        let accounting = self.account.as_mut()?;
        let model = &*self.model;
        let d = model.dim;
        let nq = d * model.masses.len();
        let (q, p) = accounting.before.split_at(nq);
        let books = &mut accounting.books;
        let t64 = t.to_f64_lossy();
        // The forms depend on the sub-step length only (a scheme takes few): made again when
        // it changes.
        if books.t != Some(t64) {
            books.forms.clear();
            books.forces.clear();
            for ((flight, c), &w) in model
                .flights
                .iter()
                .zip(&self.cache.coefficients)
                .zip(&model.inv_masses)
            {
                books.forms.push(flight.form(c, w));
                let force = match *flight {
                    Flight::Fall { force } | Flight::DampedFall { force, .. } => force,
                    _ => [T::lit(0.0); 3],
                };
                books
                    .forces
                    .extend(force[..d].iter().map(|x| x.to_f64_lossy()));
            }
            books.t = Some(t64);
        }
        accounting.account.removed(t64, q, p, &accounting.books)
    }
}

impl<T: Real, V: Vector<Real = T>> Flow<V> for FreeFlight<T> {
    fn step(&mut self, h: T, x: &mut V) -> Result<(), StepError> {
        self.model
            .free_flight_cached(h, x.as_mut_slice(), &mut self.cache);
        Ok(())
    }
    #[inline(always)]
    fn step_at(&mut self, ledger: &mut Ledger<T>, h: T, x: &mut V) -> Result<(), StepError> {
        // The consistent account of a Newton iteration at the positions and sub-step of the
        // last evaluation is that evaluation's (see `consistent.rs`): looked up before the
        // flight moves `x`, computed after it otherwise.
        // Nothing booked when the run reads no books: the account's work is skipped too.
        let books = self.model.is_dissipative() && self.model.books.on();
        let kept = match self.account.as_mut().filter(|_| books) {
            Some(Accounting {
                account, before, ..
            }) => {
                let nq = self.model.dim * self.model.masses.len();
                let xs = x.as_slice();
                before.resize(xs.len(), 0.0);
                for (b, v) in before.iter_mut().zip(xs) {
                    *b = v.to_f64_lossy();
                }
                Some(account.kept_for(h.to_f64_lossy(), &before[..nq]))
            }
            None => None,
        };
        let removed = self
            .model
            .free_flight_cached(h, x.as_mut_slice(), &mut self.cache);
        if books {
            let booked = match kept {
                None => removed,
                Some(Some(booked)) => T::lit(booked),
                Some(None) => self.account_removed(h).map_or(removed, T::lit),
            };
            ledger.dissipated = ledger.dissipated + booked;
        }
        Ok(())
    }
    fn order(&self) -> u32 {
        EXACT
    }
    fn is_symmetric(&self) -> bool {
        true
    }
    fn is_fallible(&self) -> bool {
        false
    }
    fn dissipates(&self) -> bool {
        self.model.is_dissipative()
    }
    fn prepare(&mut self, _x: &V) {
        if let Some(accounting) = self.account.as_mut() {
            accounting.account.forget();
        }
    }
    fn save_memory(&mut self, _out: &mut Vec<T>) {
        if let Some(accounting) = self.account.as_mut() {
            accounting.account.forget();
        }
    }
    fn restore_memory(&mut self, _from: &mut &[T]) {
        if let Some(accounting) = self.account.as_mut() {
            accounting.account.forget();
        }
    }
    /// The flight is affine in `x` (linear per body, with a constant force).
    fn lead_is_affine(&self) -> bool {
        true
    }
    /// Without damping the flight books nothing, whatever the state.
    fn lead_ledger_is_constant(&self) -> bool {
        !self.model.is_dissipative()
    }
    fn is_affine_in_momenta(&self) -> bool {
        true
    }
    #[inline(always)]
    fn tangent_apply(&mut self, v: &V, out: &mut V) -> bool {
        if self.cache.t.is_none() || self.cache.coefficients.len() != self.model.flights.len() {
            return false;
        }
        out.copy_from(v);
        let model = &*self.model;
        let d = model.dim;
        let nq = d * model.masses.len();
        let (q, p) = out.as_mut_slice().split_at_mut(nq);
        for (b, (flight, c)) in model
            .flights
            .iter()
            .zip(&self.cache.coefficients)
            .enumerate()
        {
            let (qb, pb) = (&mut q[b * d..b * d + d], &mut p[b * d..b * d + d]);
            flight.homogeneous().apply(c, model.inv_masses[b], qb, pb);
        }
        true
    }
}
