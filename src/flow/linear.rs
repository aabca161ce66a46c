//! The exact flow of an affine system `x' = A x + b` by the matrix exponential.

use super::linear_drift::Drift;
use super::{EXACT, Flow};
use crate::error::{SetupError, StepError};
use crate::real::Real;
use crate::vector::{Vector, ops};

/// How many step sizes a [`LinearFlow`] keeps exponentials for (a composition uses a few
/// distinct sub-step sizes, each recurring every step).
pub const LINEAR_FLOW_CACHE: usize = 8;

/// The exact flow of the affine system `x' = A x + b` (`A` constant, `n × n`):
///
/// ```text
/// x(t + h) = e^{hA} x(t) + h φ₁(hA) b,     φ₁(z) = (e^z − 1)/z,
/// ```
///
/// both read off the exponential of the augmented matrix `h [[A, b], [0, 0]]` (Van Loan,
/// IEEE TAC 23, 1978). The exponential is computed by scaling and squaring with a Taylor
/// polynomial (Moler & Van Loan, SIAM Rev. 45, 2003, method 3): the matrix is scaled by `2^{-s}`
/// to 1-norm ≤ 1/2, the series is summed until its terms fall below `ε`, and the result is
/// squared `s` times. The series' matrices `Ĝᵏ/k!` of the normalised generator
/// `Ĝ = G/‖G‖₁` are formed once, when the flow is built, so a new step size costs the sum
/// `Σ cᵏ Ĝᵏ/k!` (`c = 2^{-s} h ‖G‖₁`, `(n+1)²` multiply–adds a term) and the squarings only. Stiff decay is reproduced exactly: with `A = −10⁶`, `h = 0.1` the flow
/// returns `e^{−10⁵} = 0`, where an explicit or a split backward step would overflow.
///
/// Typical uses: a damped kinetic drift `q' = p, p' = −c p − ∇V₀` with constant force, the
/// damping part `p' = −R p` of a port-Hamiltonian splitting, or a whole linear model
/// `x' = (J − R) Q x`. Exponentials are cached for the last [`LINEAR_FLOW_CACHE`] step sizes, so
/// a step is one dense matrix–vector product (`n²` multiply–adds, no allocation); a new step size
/// costs `O(n³ log ‖hA‖)`. This is a dense method: use it for small `n`.
///
/// When `A` is a damped drift — `x = (q, p)`, `q_i' = w_i p_i`, `p_i' = −c_i p_i` (plus
/// the forcing), a mechanical model's free motion with diagonal masses and viscous damping —
/// the flow is taken in closed form coordinate by coordinate instead (`e^{−ch}` and two
/// integrals of it per coordinate and step size, `O(n)` a step): the same exact flow, with
/// no matrix exponential to form for each new step size.
///
/// The flow reports [`Flow::dissipates`] when `trace A < 0` (it contracts volume, so a backward
/// sub-step expands it exponentially), or when marked with [`dissipative`](Self::dissipative).
#[derive(Debug, Clone)]
pub struct LinearFlow<T> {
    n: usize,
    /// The augmented generator `[[A, b], [0, 0]]`, row-major, `(n+1)²`.
    generator: Vec<T>,
    cache: Vec<CachedExp<T>>,
    clock: u64,
    /// `‖G‖₁` of the generator.
    generator_norm: T,
    /// The Taylor terms `Ĝᵏ/k!` of the normalised generator `Ĝ = G/‖G‖₁`, `k = 0, 1, …`,
    /// `(n+1)²` entries each, as many as a scaled argument of norm ≤ 1/2 needs.
    series: Vec<T>,
    /// `‖Ĝᵏ/k!‖₁` of each term.
    series_norms: Vec<T>,
    /// Workspace for the squarings: one product (`(n+1)²`).
    work: Vec<T>,
    tmp: Vec<T>,
    dissipative: bool,
    /// The cache slot of the last step (its tangent map).
    last: Option<usize>,
    /// The closed form when `A` is a damped drift (see the type docs).
    drift: Option<Drift<T>>,
}

#[derive(Debug, Clone)]
struct CachedExp<T> {
    h: T,
    used: u64,
    valid: bool,
    /// `e^{h·generator}`, row-major `(n+1)²`; its last column holds `h φ₁(hA) b`.
    exp: Vec<T>,
}

impl<T: Real> LinearFlow<T> {
    /// The flow of `x' = A x` for `A` given row-major (`n²` entries).
    pub fn try_new(n: usize, a: &[T]) -> Result<Self, SetupError> {
        if n == 0 || a.len() != n * n {
            return Err(SetupError::Dimension {
                what: format!(
                    "a linear flow of dimension {n} needs {} matrix entries, got {}",
                    n * n,
                    a.len()
                ),
            });
        }
        if let Some(component) = ops::first_non_finite(a) {
            return Err(SetupError::NonFiniteState { component });
        }
        let n1 = n + 1;
        let mut generator = vec![T::zero(); n1 * n1];
        for i in 0..n {
            generator[i * n1..i * n1 + n].copy_from_slice(&a[i * n..(i + 1) * n]);
        }
        let trace = (0..n).fold(T::zero(), |s, i| s + a[i * n + i]);
        let mut flow = Self {
            n,
            generator,
            generator_norm: T::zero(),
            series: Vec::new(),
            series_norms: Vec::new(),
            cache: (0..LINEAR_FLOW_CACHE)
                .map(|_| CachedExp {
                    h: T::zero(),
                    used: 0,
                    valid: false,
                    exp: vec![T::zero(); n1 * n1],
                })
                .collect(),
            clock: 0,
            work: vec![T::zero(); n1 * n1],
            tmp: vec![T::zero(); n],
            dissipative: trace < T::zero(),
            last: None,
            drift: Drift::detect(n, a, &vec![T::zero(); n]),
        };
        flow.form_series();
        Ok(flow)
    }

    /// Forms the Taylor terms `Ĝᵏ/k!` of the normalised generator, as many as an argument of
    /// 1-norm ≤ 1/2 needs for its terms to fall below `ε/4` (at most 200).
    fn form_series(&mut self) {
        let n1 = self.n + 1;
        let m = n1 * n1;
        self.generator_norm = norm1(&self.generator, n1);
        let mut unit = self.generator.clone();
        if self.generator_norm > T::zero() {
            let inv = T::one() / self.generator_norm;
            for u in &mut unit {
                *u = *u * inv;
            }
        }
        self.series.clear();
        self.series.resize(m, T::zero());
        identity(&mut self.series, n1);
        self.series_norms.clear();
        self.series_norms.push(T::one());
        if self.generator_norm == T::zero() {
            return;
        }
        let (half, eps) = (T::lit(0.5), T::epsilon() * T::lit(0.25));
        let mut bound = T::one();
        for k in 1..200 {
            let previous = self.series.len() - m;
            self.series.resize(previous + 2 * m, T::zero());
            let (head, next) = self.series.split_at_mut(previous + m);
            matmul(&head[previous..], &unit, next, n1);
            let inv_k = T::one() / T::lit(k as f64);
            for t in next.iter_mut() {
                *t = *t * inv_k;
            }
            let norm = norm1(next, n1);
            self.series_norms.push(norm);
            bound = bound * half;
            if norm * bound <= eps {
                break;
            }
        }
    }

    /// The flow of `x' = A x` with `A[i][j] = f(i, j)`.
    pub fn from_fn(n: usize, mut f: impl FnMut(usize, usize) -> T) -> Result<Self, SetupError> {
        let a: Vec<T> = (0..n * n).map(|k| f(k / n, k % n)).collect();
        Self::try_new(n, &a)
    }

    /// Adds the constant forcing `b`: the flow of `x' = A x + b`.
    pub fn with_forcing(mut self, b: &[T]) -> Result<Self, SetupError> {
        if b.len() != self.n {
            return Err(SetupError::Dimension {
                what: format!(
                    "forcing of length {} for a linear flow of dimension {}",
                    b.len(),
                    self.n
                ),
            });
        }
        if let Some(component) = ops::first_non_finite(b) {
            return Err(SetupError::NonFiniteState { component });
        }
        let n1 = self.n + 1;
        for (i, &bi) in b.iter().enumerate() {
            self.generator[i * n1 + self.n] = bi;
        }
        for c in &mut self.cache {
            c.valid = false;
        }
        if self.drift.is_some() {
            let a: Vec<T> = (0..self.n * self.n)
                .map(|k| self.generator[(k / self.n) * n1 + k % self.n])
                .collect();
            self.drift = Drift::detect(self.n, &a, b);
        }
        self.form_series();
        Ok(self)
    }

    /// Marks the flow as dissipative regardless of its trace (see [`Flow::dissipates`]).
    pub fn dissipative(mut self) -> Self {
        self.dissipative = true;
        self
    }

    /// The dimension `n`.
    pub fn dim(&self) -> usize {
        self.n
    }

    /// `true` when the flow is a damped drift taken in closed form, coordinate by coordinate,
    /// instead of by the matrix exponential (see the type docs).
    pub fn is_drift(&self) -> bool {
        self.drift.is_some()
    }

    /// The cache slot holding `e^{h·generator}`, computing it if needed.
    fn slot(&mut self, h: T) -> Result<usize, StepError> {
        self.clock += 1;
        if let Some(i) = self.cache.iter().position(|c| c.valid && c.h == h) {
            self.cache[i].used = self.clock;
            return Ok(i);
        }
        let i = (0..self.cache.len())
            .min_by_key(|&i| (self.cache[i].valid, self.cache[i].used))
            .unwrap_or(0);
        let n1 = self.n + 1;
        let m = n1 * n1;
        let norm = h.abs() * self.generator_norm;
        if !norm.is_finite() {
            return Err(StepError::BadStepSize {
                h: h.to_f64_lossy(),
            });
        }
        // Scale to ‖·‖₁ ≤ 1/2.
        let mut squarings = 0u32;
        let mut scale = T::one();
        let half = T::lit(0.5);
        while norm * scale > half {
            scale = scale * half;
            squarings += 1;
            if squarings > 2000 {
                return Err(StepError::BadStepSize {
                    h: h.to_f64_lossy(),
                });
            }
        }
        // Taylor series: sum = Σ cᵏ Ĝᵏ/k!, summed until the term is below ε/4.
        let c = h * self.generator_norm * scale;
        let eps = T::epsilon() * T::lit(0.25);
        let sum = &mut self.cache[i].exp;
        sum.copy_from_slice(&self.series[..m]);
        let mut power = T::one();
        for (term, &tnorm) in self.series.chunks_exact(m).zip(&self.series_norms).skip(1) {
            power = power * c;
            ops::axpy(sum, power, term);
            if tnorm * power.abs() <= eps {
                break;
            }
        }
        let prod = &mut self.work;
        for _ in 0..squarings {
            matmul(sum, sum, prod, n1);
            sum.copy_from_slice(prod);
        }
        let c = &mut self.cache[i];
        c.h = h;
        c.used = self.clock;
        c.valid = true;
        Ok(i)
    }
}

fn identity<T: Real>(m: &mut [T], n: usize) {
    ops::fill_zero(m);
    for i in 0..n {
        m[i * n + i] = T::one();
    }
}

/// `out = a b` for row-major `n × n` matrices (`out` distinct from both).
fn matmul<T: Real>(a: &[T], b: &[T], out: &mut [T], n: usize) {
    ops::fill_zero(out);
    for i in 0..n {
        for k in 0..n {
            let aik = a[i * n + k];
            if aik == T::zero() {
                continue;
            }
            ops::axpy(&mut out[i * n..(i + 1) * n], aik, &b[k * n..(k + 1) * n]);
        }
    }
}

fn norm1<T: Real>(m: &[T], n: usize) -> T {
    (0..n).fold(T::zero(), |best, j| {
        best.max((0..n).fold(T::zero(), |a, r| a + m[r * n + j].abs()))
    })
}

impl<V: Vector> Flow<V> for LinearFlow<V::Real> {
    fn step(&mut self, h: V::Real, x: &mut V) -> Result<(), StepError> {
        if x.len() != self.n {
            return Err(StepError::StateLength {
                flow: "linear flow",
                expected: self.n,
                got: x.len(),
            });
        }
        // The closed form, whose result's check covers the state's (a non-finite state or
        // result is located below, by the scan and the product).
        if super::check_step_size(h)?
            && let Some(drift) = self.drift.as_mut()
            && drift.step(h, x.as_mut_slice())
        {
            return Ok(());
        }
        if !super::check_step(h, x)? {
            return Ok(());
        }
        let slot = self.slot(h)?;
        self.last = Some(slot);
        let n1 = self.n + 1;
        let e = &self.cache[slot].exp;
        let xs = x.as_slice();
        for (i, t) in self.tmp.iter_mut().enumerate() {
            let row = &e[i * n1..i * n1 + self.n];
            *t = row
                .iter()
                .zip(xs)
                .fold(e[i * n1 + self.n], |s, (&a, &b)| s + a * b);
        }
        if let Some(component) = ops::first_non_finite(&self.tmp) {
            return Err(StepError::NonFinite { component });
        }
        x.as_mut_slice().copy_from_slice(&self.tmp);
        Ok(())
    }
    fn order(&self) -> u32 {
        EXACT
    }
    fn is_symmetric(&self) -> bool {
        true
    }
    fn dissipates(&self) -> bool {
        self.dissipative
    }
    /// `x ↦ e^{hA} x + (forcing)` is affine.
    fn lead_is_affine(&self) -> bool {
        true
    }
    /// It books no energy in the ledger.
    fn lead_ledger_is_constant(&self) -> bool {
        true
    }
    fn is_affine_in_momenta(&self) -> bool {
        true
    }
    /// `DΦ_h v = e^{hA} v`: the last step's exponential without its affine column.
    fn tangent_apply(&mut self, v: &V, out: &mut V) -> bool {
        if let Some(drift) = self.drift.as_ref() {
            return v.len() == self.n
                && out.len() == self.n
                && drift.tangent(v.as_slice(), out.as_mut_slice());
        }
        let Some(slot) = self.last else {
            return false;
        };
        let cached = &self.cache[slot];
        if !cached.valid || v.len() != self.n || out.len() != self.n {
            return false;
        }
        let n1 = self.n + 1;
        let vs = v.as_slice();
        for (i, o) in out.as_mut_slice().iter_mut().enumerate() {
            let row = &cached.exp[i * n1..i * n1 + self.n];
            *o = row
                .iter()
                .zip(vs)
                .fold(V::Real::lit(0.0), |s, (&a, &b)| s + a * b);
        }
        true
    }
}
