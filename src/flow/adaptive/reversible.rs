//! Reversible variable steps for conservative symmetric schemes: the step density of Hairer &
//! Söderlind, advanced explicitly and symmetrically beside the state.

use super::{AdaptiveOptions, AdaptiveStats, StepDensity};
use crate::error::{SetupError, StepError};
use crate::flow::{Flow, FlowStats, Ledger, MAX_ROWS, Multipliers};
use crate::real::Real;
use crate::vector::Vector;
use num_traits::{Float as _, One as _, Zero as _};

/// Variable steps that keep a symmetric scheme time-reversible (Hairer & Söderlind, *Explicit,
/// time reversible, adaptive step size control*, SIAM J. Sci. Comput. 26, 2005): the step density
/// `ρ ≈ 1/s(x)` of a [`StepDensity`] is carried beside the state and each step is
///
/// ```text
/// ρ_{n+½} = ρ_n + (ε/2) G(x_n),   x_{n+1} = S_{ε/ρ_{n+½}}(x_n),   ρ_{n+1} = ρ_{n+½} + (ε/2) G(x_{n+1}),
/// ```
///
/// a Strang splitting in the extended variables `(x, ρ)` with the fixed step `ε` of the
/// transformed time `dτ = ρ dt`. With `S` symmetric, the step taken from `(x_{n+1}, ρ_{n+1})`
/// with `−ε` returns to `(x_n, ρ_n)`: N steps forward and N back end where they started, to
/// round-off — which no error-controlled step sequence does (its steps depend on the
/// direction). On a reversible integrable problem the scheme then keeps the long-time
/// behaviour of the fixed-step one (no drift of energy or actions, errors growing linearly),
/// with the steps where the motion needs them (Hairer, Lubich & Wanner, *Geometric Numerical
/// Integration*, §VIII.3).
///
/// `ε` is set once and then frozen (a step-by-step error control would break the symmetry):
/// given ([`with_parameter`](Self::with_parameter)), or calibrated at the first step to the
/// tolerances — the first step `h₀` whose local error, estimated by step doubling
/// (`‖S_{h/2}² x − S_h x‖ / (2^p − 1)` in the weighted norm), is at the tolerance, and
/// `ε = h₀ ρ(x₀)`. So the tolerance sets the step scale, not an error bound; the global error
/// is what the scheme's order gives for that scale. `h_max` caps a step (a function of
/// `ρ_{n+½}` alone, so the cap keeps the symmetry); `h_min`, `max_order` are not used.
///
/// The scheme must be symmetric and conservative: a dissipative flow is refused (damping run
/// backwards is unstable, and a reversible step sequence has no meaning for it — use the error
/// controller, [`AdaptiveExtrapolation`](super::AdaptiveExtrapolation)). `step(h)` lands on
/// `t + h` by a last step of a smaller `ε` (outputs at communication points are then not part
/// of a reversible sequence); [`Flow::step_own`] takes the steps as the density gives them.
/// A failing base step (a Newton failure) is reported, not retried with a smaller step, which
/// would break the symmetry. `ε` and `ρ` are part of the flow's memory, so a checkpoint's
/// continuation is bit-identical.
#[derive(Debug)]
pub struct ReversibleSteps<V: Vector, F, D> {
    base: F,
    density: D,
    options: AdaptiveOptions<V::Real>,
    /// The step of the transformed time (`None`: calibrated at the first step).
    epsilon: Option<V::Real>,
    /// `ρ` at the current state (`None` before the first step).
    rho: Option<V::Real>,
    stats: AdaptiveStats,
    /// Workspace: the call's start (what a failure restores), and two trial states.
    whole: V,
    trial: V,
    halves: V,
    memory: Vec<V::Real>,
    /// The memory at the call's start (`ε`, `ρ`, the base flow's).
    whole_memory: Vec<V::Real>,
}

impl<V: Vector, F: Flow<V>, D: StepDensity<V>> ReversibleSteps<V, F, D> {
    /// Reversible steps of `base` along `density`, `ε` calibrated to `options.tolerances`.
    ///
    /// # Errors
    /// [`SetupError::Scheme`] when `base` is not symmetric or dissipates;
    /// [`SetupError::InvalidParameter`] for bad step bounds.
    pub fn try_new(
        base: F,
        density: D,
        options: AdaptiveOptions<V::Real>,
    ) -> Result<Self, SetupError> {
        if !base.is_symmetric() {
            return Err(SetupError::Scheme {
                what: format!(
                    "the reversible controller needs a symmetric scheme; this one (order {}) is not",
                    base.order()
                ),
            });
        }
        if base.dissipates() {
            return Err(SetupError::Scheme {
                what: "the reversible controller needs a conservative scheme; this one dissipates (damping would run backwards on the way back): use the error controller (adaptive extrapolation)".to_owned(),
            });
        }
        options.check()?;
        Ok(Self {
            base,
            density,
            options,
            epsilon: None,
            rho: None,
            stats: AdaptiveStats {
                smallest: f64::INFINITY,
                ..AdaptiveStats::default()
            },
            whole: V::zeros(0),
            trial: V::zeros(0),
            halves: V::zeros(0),
            memory: Vec::new(),
            whole_memory: Vec::new(),
        })
    }

    /// Fixes the step of the transformed time, `ε > 0` (no calibration).
    ///
    /// # Errors
    /// [`SetupError::InvalidParameter`] when `ε` is not positive and finite.
    pub fn with_parameter(mut self, epsilon: V::Real) -> Result<Self, SetupError> {
        let e = epsilon.to_f64_lossy();
        if !(e > 0.0 && e.is_finite()) {
            return Err(SetupError::InvalidParameter {
                name: "epsilon".to_owned(),
                value: e,
                requirement: "positive and finite",
            });
        }
        self.epsilon = Some(epsilon);
        Ok(self)
    }

    /// `ε`, the step of the transformed time (`None` until calibrated).
    pub fn parameter(&self) -> Option<V::Real> {
        self.epsilon
    }

    /// `ρ` at the current state (`None` before the first step).
    pub fn density_now(&self) -> Option<V::Real> {
        self.rho
    }

    /// The base step.
    pub fn base(&self) -> &F {
        &self.base
    }

    /// Reads `ρ(x)` and calibrates `ε` (trying `h` first) when not yet done.
    fn start(&mut self, h: V::Real, x: &V) -> Result<(), StepError> {
        if self.rho.is_none() {
            let rho = self.density.density(x);
            if !(rho > V::Real::zero() && rho.is_finite()) {
                return Err(not_positive(V::Real::zero(), rho));
            }
            self.rho = Some(rho);
        }
        if self.epsilon.is_none() {
            let h0 = self.calibrate(h, x)?;
            self.epsilon = self.rho.map(|rho| h0 * rho);
        }
        Ok(())
    }

    /// The step `h₀` whose step-doubling error estimate is at the tolerance, from `h`.
    fn calibrate(&mut self, h: V::Real, x: &V) -> Result<V::Real, StepError> {
        let h_max = self.options.h_max.unwrap_or_else(V::Real::infinity);
        let mut h = self.options.first_step.unwrap_or(h.abs()).min(h_max);
        self.memory.clear();
        self.base.save_memory(&mut self.memory);
        let p = self.base.order().min(30);
        let scale = f64::from(2u32.pow(p) - 1);
        let mut last = None;
        for _ in 0..40 {
            let tried = self.double_step(h, x);
            let mut from = self.memory.as_slice();
            self.base.restore_memory(&mut from);
            let err = match tried {
                Ok(()) => {
                    self.options
                        .tolerances
                        .error(
                            self.halves.as_slice(),
                            self.trial.as_slice(),
                            x.as_slice(),
                            self.halves.as_slice(),
                        )
                        .to_f64_lossy()
                        / scale
                }
                Err(_) => f64::INFINITY,
            };
            last = Some(err);
            if (0.5..=1.0).contains(&err) || (err <= 1.0 && h >= h_max) {
                self.stats.last_error = err;
                return Ok(h);
            }
            let fac = if err.is_finite() {
                0.85 * err.powf(-1.0 / f64::from(p + 1))
            } else {
                0.25
            };
            h = (h * V::Real::lit(fac.clamp(0.1, 4.0))).min(h_max);
        }
        Err(StepError::StepSizeTooSmall {
            t: 0.0,
            h: h.to_f64_lossy(),
            h_min: self.options.h_min.to_f64_lossy(),
            cause: format!(
                "the reversible controller found no first step at the tolerance (last estimate {:.3e})",
                last.unwrap_or(f64::NAN)
            ),
        })
    }

    /// `trial = S_h x`, `halves = S_{h/2}² x` (the base flow's memory changes).
    fn double_step(&mut self, h: V::Real, x: &V) -> Result<(), StepError> {
        let mut ledger = Ledger::default();
        self.trial.copy_from(x);
        self.base.step_at(&mut ledger, h, &mut self.trial)?;
        self.halves.copy_from(x);
        let half = h * V::Real::lit(0.5);
        self.base
            .step_repeated(&mut Ledger::default(), half, 2, &mut self.halves)?;
        self.stats.base_steps += 3;
        Ok(())
    }

    /// One step in the direction `sign`, at most `left` long (a shorter `ε` when the density's
    /// step would pass it); returns its length.
    fn one_step(
        &mut self,
        ledger: &mut Ledger<V::Real>,
        sign: V::Real,
        left: V::Real,
        x: &mut V,
    ) -> Result<V::Real, StepError> {
        let (Some(rho), Some(eps)) = (self.rho, self.epsilon) else {
            unreachable!("started before stepping")
        };
        let half = V::Real::lit(0.5);
        let g0 = self.density.log_rate(x);
        let mut e = sign * eps;
        let mut mid = rho + half * e * g0;
        if !(mid > V::Real::zero() && mid.is_finite()) {
            return Err(not_positive(ledger.t, mid));
        }
        let mut h = e / mid;
        if let Some(h_max) = self.options.h_max
            && h.abs() > h_max
        {
            h = sign * h_max;
        }
        if h.abs() >= left {
            // The ε whose step is exactly `left`: h = e/(ρ + e G/2).
            h = sign * left;
            e = h * rho / (V::Real::one() - half * h * g0);
            mid = rho + half * e * g0;
        }
        self.base.step_at(ledger, h, x)?;
        let rho_next = mid + half * e * self.density.log_rate(x);
        self.rho = Some(rho_next);
        let s = &mut self.stats;
        s.accepted += 1;
        s.base_steps += 1;
        s.orders[((self.base.order() / 2) as usize).min(MAX_ROWS)] += 1;
        let hf = h.abs().to_f64_lossy();
        s.smallest = s.smallest.min(hf);
        s.largest = s.largest.max(hf);
        Ok(h.abs())
    }

    /// Keeps what a failure restores; `false` for a zero step.
    fn begin(&mut self, h: V::Real, x: &V) -> Result<bool, StepError> {
        if !crate::flow::check_step(h, x)? {
            return Ok(false);
        }
        if !self.options.tolerances.fits(x.len()) {
            return Err(StepError::StateLength {
                flow: "reversible steps (per-component tolerances)",
                expected: self.options.tolerances.components(),
                got: x.len(),
            });
        }
        self.prepare(x);
        self.whole.copy_from(x);
        let mut saved = core::mem::take(&mut self.whole_memory);
        saved.clear();
        self.save_memory(&mut saved);
        self.whole_memory = saved;
        Ok(true)
    }

    /// On failure: the state, the ledger, `ρ`, `ε` and the base flow's memory of the call's
    /// start.
    fn undo(&mut self, ledger: &mut Ledger<V::Real>, l0: Ledger<V::Real>, x: &mut V) {
        x.copy_from(&self.whole);
        *ledger = l0;
        let saved = core::mem::take(&mut self.whole_memory);
        let mut from = saved.as_slice();
        self.restore_memory(&mut from);
        self.whole_memory = saved;
    }
}

/// The step density fell to `rho ≤ 0` (or overflowed) at `t`.
fn not_positive<T: Real>(t: T, rho: T) -> StepError {
    StepError::StepSizeTooSmall {
        t: t.to_f64_lossy(),
        h: 0.0,
        h_min: 0.0,
        cause: format!(
            "the reversible controller's step density fell to {:e}: its step ε is too large for how fast the density changes (ask for a tighter tolerance)",
            rho.to_f64_lossy()
        ),
    }
}

impl<V: Vector, F: Flow<V>, D: StepDensity<V>> Flow<V> for ReversibleSteps<V, F, D> {
    fn step(&mut self, h: V::Real, x: &mut V) -> Result<(), StepError> {
        self.step_at(&mut Ledger::default(), h, x)
    }

    /// Advances by exactly `h`: the density's steps, the last one shortened to land on `t + h`.
    fn step_at(
        &mut self,
        ledger: &mut Ledger<V::Real>,
        h: V::Real,
        x: &mut V,
    ) -> Result<(), StepError> {
        if !self.begin(h, x)? {
            return Ok(());
        }
        let l0 = *ledger;
        let span = h.abs();
        let mut done = V::Real::zero();
        let result = self.start(h, x).and_then(|()| {
            while done < span {
                let left = span - done;
                let taken = self.one_step(ledger, h.signum(), left, x)?;
                done = if taken >= left { span } else { done + taken };
            }
            Ok(())
        });
        match result {
            Ok(()) => {
                ledger.t = l0.t + h;
                Ok(())
            }
            Err(e) => {
                self.undo(ledger, l0, x);
                Err(e)
            }
        }
    }

    /// One step as the density gives it, at most `|max|`, in the direction of `max`.
    fn step_own(
        &mut self,
        ledger: &mut Ledger<V::Real>,
        max: V::Real,
        x: &mut V,
    ) -> Option<Result<V::Real, StepError>> {
        match self.begin(max, x) {
            Ok(false) => return Some(Ok(V::Real::zero())),
            Ok(true) => {}
            Err(e) => return Some(Err(e)),
        }
        let l0 = *ledger;
        let result = self
            .start(max, x)
            .and_then(|()| self.one_step(ledger, max.signum(), max.abs(), x));
        Some(match result {
            Ok(taken) => {
                let h = if taken >= max.abs() {
                    max
                } else {
                    max.signum() * taken
                };
                ledger.t = l0.t + h;
                Ok(h)
            }
            Err(e) => {
                self.undo(ledger, l0, x);
                Err(e)
            }
        })
    }

    fn order(&self) -> u32 {
        self.base.order()
    }

    /// The map of `(x, ρ)` is symmetric; the map of `x` alone (with `ρ` as memory, and a last
    /// step shortened to land on `t + h`) is not.
    fn is_symmetric(&self) -> bool {
        false
    }

    fn prepare(&mut self, x: &V) {
        if self.whole.len() != x.len() {
            self.whole = x.zeros_like();
            self.trial = x.zeros_like();
            self.halves = x.zeros_like();
        }
        self.base.prepare(x);
    }

    fn stats(&self) -> FlowStats {
        self.base.stats()
    }

    fn multipliers(&self) -> Option<Multipliers<'_, V::Real>> {
        self.base.multipliers()
    }

    fn save_memory(&mut self, out: &mut Vec<V::Real>) {
        let none = -V::Real::one();
        out.push(self.epsilon.unwrap_or(none));
        out.push(self.rho.unwrap_or(none));
        self.base.save_memory(out);
    }

    fn restore_memory(&mut self, from: &mut &[V::Real]) {
        if from.len() >= 2 {
            let (head, rest) = from.split_at(2);
            let known = |v: V::Real| (v > V::Real::zero()).then_some(v);
            self.epsilon = known(head[0]);
            self.rho = known(head[1]);
            *from = rest;
        }
        self.base.restore_memory(from);
    }

    fn adaptive_stats(&self) -> Option<AdaptiveStats> {
        Some(self.stats)
    }
}
