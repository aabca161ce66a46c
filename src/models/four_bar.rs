//! The N-four-bar mechanism (IFToMM multibody benchmark A02; after Bayo & Avello 1994): `N`
//! four-bar windows of `2N + 1` bars, each 1 m long with 1 kg spread uniformly, under gravity
//! `9.81` along `−y`. Crank `i` turns about the fixed point `Aᵢ = (i, 0)` to its tip `Bᵢ`,
//! coupler `i` joins `Bᵢ` and `Bᵢ₊₁`. When every bar lies on the horizontal line the
//! constraint Jacobian loses rank: one degree of freedom becomes `N + 1` for an instant.
//!
//! Natural coordinates: the state is the tips `q = (B₀ … B_N) ∈ R^{2(N+1)}` and `p = M q'`. A
//! uniform bar between points `a` and `b` has kinetic energy `(|a'|² + a'·b' + |b'|²)/6` and
//! potential `g (a_y + b_y)/2`, so `M` is constant and tridiagonal in each axis
//! (`M = T ⊗ I₂`, `Tᵢᵢ = 1/3 + (couplers at i)/3`, `Tᵢ,ᵢ₊₁ = 1/6`) and
//!
//! ```text
//! H = ½ pᵀ M⁻¹ p + Σᵢ wᵢ g Bᵢ,y,    gᵢ = (|Bᵢ − Aᵢ|² − 1)/2 (cranks),
//!                                    g_{N+1+i} = (|Bᵢ₊₁ − Bᵢ|² − 1)/2 (couplers),
//! ```
//!
//! `wᵢ` the weight each tip carries (½ per bar at it). The exact flows are the drift
//! `q += h M⁻¹ p` (a tridiagonal solve per axis) and the constant kick `p −= h ∇U`, so the
//! natural scheme is RATTLE with a non-diagonal constant mass matrix.

use crate::error::StepError;
use crate::flow::{Coupling, FlowExt, FnFlow, ProjectionOptions, from_fn};
use crate::nonlinear::NewtonOptions;
use crate::system::{Canonical, Case, Hamiltonian, HolonomicConstraint, System};
use crate::vector::Vector;

/// Gravity of the benchmark, m/s².
pub const GRAVITY: f64 = 9.81;

/// The mechanism with `N` windows (its Hamiltonian; [`Bars`] are its constraints).
#[derive(Debug, Clone, PartialEq)]
pub struct NFourBar {
    windows: usize,
    /// Diagonal and off-diagonal of `T`, and its LDLᵀ factors (`d`, `l`) for the drift.
    diag: Vec<f64>,
    off: f64,
    d: Vec<f64>,
    l: Vec<f64>,
    /// Weight (bars' mass) on each tip.
    weight: Vec<f64>,
}

/// The `2N + 1` bar-length constraints of an [`NFourBar`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bars {
    windows: usize,
}

impl NFourBar {
    /// `N ≥ 1` windows.
    pub fn new(windows: usize) -> Self {
        let n = windows.max(1) + 1;
        let couplers = |i: usize| (i > 0) as usize + (i + 1 < n) as usize;
        let diag: Vec<f64> = (0..n).map(|i| (1.0 + couplers(i) as f64) / 3.0).collect();
        let off = 1.0 / 6.0;
        // LDLᵀ of the symmetric tridiagonal T: d₀ = T₀₀, lᵢ = off/dᵢ₋₁, dᵢ = Tᵢᵢ − lᵢ off.
        let (mut d, mut l) = (vec![0.0; n], vec![0.0; n]);
        d[0] = diag[0];
        for i in 1..n {
            l[i] = off / d[i - 1];
            d[i] = diag[i] - l[i] * off;
        }
        let weight = (0..n).map(|i| (1.0 + couplers(i) as f64) / 2.0).collect();
        Self {
            windows: n - 1,
            diag,
            off,
            d,
            l,
            weight,
        }
    }

    /// The number of tips `N + 1`.
    pub fn tips(&self) -> usize {
        self.windows + 1
    }

    /// The state length `4 (N + 1)`.
    pub fn state_len(&self) -> usize {
        4 * self.tips()
    }

    /// The model as a [`System`].
    pub fn system(&self) -> System<Canonical, Self, Bars> {
        System::new(
            Canonical,
            self.clone(),
            Bars {
                windows: self.windows,
            },
        )
    }

    /// `out = M⁻¹ p` for the momenta `p` (one tridiagonal solve per axis).
    fn solve(&self, p: &[f64], out: &mut [f64]) {
        let n = self.tips();
        for axis in 0..2 {
            // Forward (L), diagonal (D), backward (Lᵀ).
            let mut prev = 0.0;
            for i in 0..n {
                let y = p[2 * i + axis] - self.l[i] * prev;
                out[2 * i + axis] = y;
                prev = y;
            }
            for i in 0..n {
                out[2 * i + axis] /= self.d[i];
            }
            for i in (0..n - 1).rev() {
                out[2 * i + axis] -= self.l[i + 1] * out[2 * (i + 1) + axis];
            }
        }
    }

    /// The exact drift `q += h M⁻¹ p`.
    pub fn drift<V: Vector<Real = f64>>(&self) -> FnFlow<impl FnMut(f64, &mut V) + Clone + use<V>> {
        let model = self.clone();
        let mut v = vec![0.0; 2 * self.tips()];
        from_fn(move |h: f64, x: &mut V| {
            let (q, p) = x.as_mut_slice().split_at_mut(2 * model.tips());
            model.solve(p, &mut v);
            for (qi, vi) in q.iter_mut().zip(&v) {
                *qi += h * vi;
            }
        })
    }

    /// The exact kick of gravity `p_y −= h wᵢ g`.
    pub fn kick<V: Vector<Real = f64>>(&self) -> FnFlow<impl FnMut(f64, &mut V) + Clone + use<V>> {
        let weight = self.weight.clone();
        from_fn(move |h: f64, x: &mut V| {
            let n = weight.len();
            let p = &mut x.as_mut_slice()[2 * n..];
            for (i, w) in weight.iter().enumerate() {
                p[2 * i + 1] -= h * w * GRAVITY;
            }
        })
        .kick()
    }

    /// The benchmark's start as used here: cranks vertical (`Bᵢ = (i, 1)`) and every tip moving
    /// at `(1, 0)` m/s (the mechanism's one degree of freedom, `B₀'` = 1 m/s along `x`). From
    /// there it falls through the horizontal, singular position.
    pub fn initial_state<V: Vector<Real = f64>>(&self) -> V {
        let n = self.tips();
        let mut x = V::zeros(4 * n);
        let s = x.as_mut_slice();
        for i in 0..n {
            s[2 * i] = i as f64;
            s[2 * i + 1] = 1.0;
        }
        // p = M q' with q' = (1, 0) at every tip: row sums of T in x.
        for i in 0..n {
            let row = self.diag[i]
                + if i > 0 { self.off } else { 0.0 }
                + if i + 1 < n { self.off } else { 0.0 };
            s[2 * n + 2 * i] = row;
        }
        x
    }

    /// RATTLE's options: the degenerate, decoupled case, residuals to a few ulps of the unit
    /// lengths.
    pub fn projection_options(&self) -> ProjectionOptions<f64> {
        ProjectionOptions::default()
            .with_case(Case::Degenerate)
            .with_coupling(Coupling::Decoupled)
            .with_newton(
                NewtonOptions::default().with_ftol(16.0 * f64::EPSILON * self.tips() as f64),
            )
    }
}

/// What [`NFourBar::benchmark_run`] measured.
#[derive(Debug, Clone, PartialEq)]
pub struct BenchmarkRun {
    /// Steps taken (all of them, or up to the failing one).
    pub steps: usize,
    /// Times `B₀` crossed the horizontal line (the singular position).
    pub crossings: usize,
    /// `max |g|` over the run.
    pub max_g: f64,
    /// `H(x₀)`.
    pub energy: f64,
    /// `max |H − H₀|` over the first and over the last tenth of the run.
    pub first_tenth: f64,
    /// See `first_tenth`.
    pub last_tenth: f64,
    /// The most Newton iterations one step took.
    pub newton_max: u64,
    /// The step error that stopped the run, if one did (the state is then the last good one).
    pub error: Option<StepError>,
    /// The final state is finite.
    pub finite: bool,
}

impl NFourBar {
    /// RATTLE (projected kick–drift–kick) from [`initial_state`](Self::initial_state) for
    /// `steps` steps of `h`, measuring what the benchmark asks: the crossings of the singular
    /// position, the constraint residual and the energy error.
    pub fn benchmark_run(
        &self,
        h: f64,
        steps: usize,
    ) -> Result<BenchmarkRun, crate::error::SetupError> {
        type V = faer::Col<f64>;
        let x0: V = self.initial_state();
        let mut flow = self.kick().strang(self.drift()).projected(
            self.system(),
            &x0,
            self.projection_options(),
        )?;
        let s = self.system();
        let e0 = Hamiltonian::<V>::energy(self, &x0);
        let mut x = x0;
        let (mut last_y, mut crossings) = (x[1], 0);
        let t = super::tracked_run(
            &mut flow,
            &mut x,
            (h, steps),
            &s.constraint,
            self,
            |x: &V| {
                if x[1].signum() != last_y.signum() {
                    crossings += 1;
                }
                last_y = x[1];
            },
        );
        Ok(BenchmarkRun {
            steps: t.steps,
            crossings,
            max_g: t.max_g,
            energy: e0,
            first_tenth: t.first_tenth,
            last_tenth: t.last_tenth,
            newton_max: t.newton_max,
            error: t.error,
            finite: t.finite,
        })
    }
}

impl<V: Vector<Real = f64>> Hamiltonian<V> for NFourBar {
    fn energy(&self, x: &V) -> f64 {
        let n = self.tips();
        let (q, p) = x.as_slice().split_at(2 * n);
        let mut v = vec![0.0; 2 * n];
        self.solve(p, &mut v);
        let kinetic: f64 = p.iter().zip(&v).map(|(a, b)| a * b).sum::<f64>() * 0.5;
        kinetic
            + (0..n)
                .map(|i| self.weight[i] * GRAVITY * q[2 * i + 1])
                .sum::<f64>()
    }
    fn gradient(&self, x: &V, out: &mut V) {
        let n = self.tips();
        let p = &x.as_slice()[2 * n..];
        let (oq, op) = out.as_mut_slice().split_at_mut(2 * n);
        for i in 0..n {
            oq[2 * i] = 0.0;
            oq[2 * i + 1] = self.weight[i] * GRAVITY;
        }
        self.solve(p, op);
    }
    /// `∇²H = diag(0, M⁻¹)`.
    fn hessian_apply(&self, _x: &V, v: &V, out: &mut V) -> bool {
        let n = self.tips();
        let vp = &v.as_slice()[2 * n..];
        let (oq, op) = out.as_mut_slice().split_at_mut(2 * n);
        oq.fill(0.0);
        self.solve(vp, op);
        true
    }
    fn is_quadratic(&self) -> bool {
        true
    }
}

impl Bars {
    /// Row `r`: `(a, b)` with `a = None` for the fixed point `A_b = (b, 0)`.
    fn ends(&self, r: usize) -> (Option<usize>, usize) {
        let n = self.windows + 1;
        if r < n {
            (None, r)
        } else {
            (Some(r - n), r - n + 1)
        }
    }
    fn vector(&self, q: &[f64], r: usize) -> [f64; 2] {
        match self.ends(r) {
            (None, b) => [q[2 * b] - b as f64, q[2 * b + 1]],
            (Some(a), b) => [q[2 * b] - q[2 * a], q[2 * b + 1] - q[2 * a + 1]],
        }
    }
}

impl<V: Vector<Real = f64>> HolonomicConstraint<V> for Bars {
    fn dim(&self) -> usize {
        2 * self.windows + 1
    }
    fn residual(&self, x: &V, out: &mut [f64]) {
        let q = x.as_slice();
        for (r, o) in out.iter_mut().enumerate() {
            let u = self.vector(q, r);
            *o = (u[0] * u[0] + u[1] * u[1] - 1.0) * 0.5;
        }
    }
    fn jacobian_apply(&self, x: &V, v: &V, out: &mut [f64]) {
        let (q, v) = (x.as_slice(), v.as_slice());
        for (r, o) in out.iter_mut().enumerate() {
            let u = self.vector(q, r);
            let w = match self.ends(r) {
                (None, b) => [v[2 * b], v[2 * b + 1]],
                (Some(a), b) => [v[2 * b] - v[2 * a], v[2 * b + 1] - v[2 * a + 1]],
            };
            *o = u[0] * w[0] + u[1] * w[1];
        }
    }
    fn jacobian_transpose_apply_add(&self, x: &V, mu: &[f64], alpha: f64, out: &mut V) {
        let q = x.as_slice();
        let o = out.as_mut_slice();
        for (r, &m) in mu.iter().enumerate() {
            let u = self.vector(q, r);
            let (a, b) = self.ends(r);
            for k in 0..2 {
                o[2 * b + k] += alpha * m * u[k];
                if let Some(a) = a {
                    o[2 * a + k] -= alpha * m * u[k];
                }
            }
        }
    }
    // No `jacobian_entries`: `M⁻¹` (the inverse of a tridiagonal matrix) couples every tip, so
    // the multiplier systems `G M⁻¹ Gᵀ` are dense, not the pattern of `G Gᵀ` the sparse path
    // would assume (it would stop with `PatternIncomplete`); dense `G` takes the dense path.
}
