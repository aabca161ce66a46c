//! ns/step of the generic composed scheme on the paper's example against a hand-written,
//! model-specific loop of the same algorithm (same multiplier equations, same tolerance, same
//! warm start), in the same process.
//!
//! Also the paper's §2 scheme against its §3 scheme, same process: generic (nested and one
//! Newton system), written by hand as the same algorithm, and optimized by hand with the
//! model's structure (what the scheme costs at best).
//!
//! ```text
//! cargo bench --bench paper_example
//! ```

use criterion::{Criterion, criterion_group, criterion_main};
use lieflow::flow::coefficients::{CompositionTable, KAHAN_LI8, TRIPLE_JUMP};
use lieflow::models::paper;
use lieflow::prelude::*;
use nalgebra::SVector;
use std::hint::black_box;

type V = SVector<f64, 4>;

/// The §3 scheme written out for this model only: `λ_k` by scalar Newton with the analytic
/// derivative on `g(y(λ)) = 0`, then `λ_{k+1}` in closed form (the hidden constraint is linear
/// in it). Same tolerance and stopping rule as the generic code's defaults (`|g| ≤ 2ε`, or
/// `|g| ≤ 200ε` with an update at round-off or a residual that stopped halving) and the same
/// warm start (`λ_k` predicted from the last `λ_{k+1}` plus the last offset per unit step).
#[derive(Clone, Copy, Default)]
struct HandWritten {
    /// The last `λ_{k+1}`.
    mu: f64,
    /// `(λ_k − previous λ_{k+1}) / h` of the last step.
    offset: f64,
    steps: u64,
}

impl HandWritten {
    /// `λ` from `g(drift_h(x + h/2 M Gᵀ λ)) = 0` by scalar Newton from `l`, and `y` (positions
    /// after the drift, momenta after the half-step, which the drift does not change).
    #[inline(always)]
    fn lambda_k(h: f64, x: &V, mut l: f64) -> (f64, V) {
        let (x1, x2, x3, x4) = (x[0], x[1], x[2], x[3]);
        let (ftol, xtol) = (2.0 * f64::EPSILON, 16.0 * f64::EPSILON);
        let (mut y1, mut y2);
        let (mut r_prev, mut step) = (f64::INFINITY, f64::INFINITY);
        let mut it = 0;
        loop {
            // x̂ = x + h/2 M Gᵀ λ = (x1, x2, x3 − h/2 x1 λ, x4 − h x2 λ); y = drift(x̂).
            y1 = x1 + h * (x3 - 0.5 * h * x1 * l);
            y2 = x2 + h * (x4 - h * x2 * l);
            let g = 0.5 * (y1 * y1 + y2 * y2 - 1.0);
            let r = g.abs();
            if r <= ftol
                || (r <= 100.0 * ftol && (step <= xtol * (1.0 + l.abs()) || r >= 0.5 * r_prev))
                || it == 25
            {
                break;
            }
            let dg = -h * h * (0.5 * y1 * x1 + y2 * x2);
            let dl = -g / dg;
            l += dl;
            step = dl.abs();
            r_prev = r;
            it += 1;
        }
        (l, V::new(y1, y2, x3 - 0.5 * h * x1 * l, x4 - h * x2 * l))
    }

    /// The second half-step: `μ` in closed form (`φ` is linear in it), `x_{k+1}`.
    #[inline(always)]
    fn finish(&mut self, h: f64, y: &V, x: &mut V) {
        let (y1, y2, y3, y4) = (y[0], y[1], y[2], y[3]);
        // φ(y + h/2 M Gᵀ μ) = y1 y3 + y2 y4 − μ h/2 (y1² + 2 y2²) = 0.
        let mu = (y1 * y3 + y2 * y4) / (0.5 * h * (y1 * y1 + 2.0 * y2 * y2));
        self.mu = mu;
        self.steps += 1;
        *x = V::new(y1, y2, y3 - 0.5 * h * y1 * mu, y4 - h * y2 * mu);
    }

    #[inline]
    fn step(&mut self, h: f64, x: &mut V) {
        let (l, y) = Self::lambda_k(h, x, self.mu + h * self.offset);
        if self.steps > 0 {
            self.offset = (l - self.mu) / h;
        }
        self.finish(h, &y, x);
    }

    /// The composition stage by stage: every stage projects twice.
    fn composed(&mut self, table: &CompositionTable, h: f64, x: &mut V) {
        for i in 0..table.stages {
            self.step(table.gamma(i) * h, x);
        }
    }

    /// The composition fused as the generic code runs it: one `λ` per stage, the combined
    /// `λ̃ = λ_k + (h_{i−1}/h_i) λ_{k+1}`, predicted from the force estimate `λ̃/(1 + h_{i−1}/h_i)`
    /// of the previous stage; `μ` only at the last stage.
    fn composed_fused(&mut self, table: &CompositionTable, h: f64, x: &mut V) {
        let mut h_prev = table.gamma(0) * h;
        let (l, mut y) = Self::lambda_k(h_prev, x, self.mu + h_prev * self.offset);
        if self.steps > 0 {
            self.offset = (l - self.mu) / h_prev;
        }
        let mut force = l;
        for i in 1..table.stages {
            let hi = table.gamma(i) * h;
            let grow = 1.0 + h_prev / hi;
            let (l, y_next) = Self::lambda_k(hi, &y, force * grow);
            force = if grow.abs() >= 1e-3 { l / grow } else { force };
            y = y_next;
            h_prev = hi;
        }
        self.finish(h_prev, &y, x);
        self.steps += table.stages as u64 - 1;
    }
}

/// The paper's §2 scheme written out for this model only, the same algorithm as
/// `ProjectedMidpoint` with `paper::modified_energy()`: Newton on the midpoint increment `δ`
/// and `λ_k` together (5 unknowns, the exact Jacobian built at the first iterate, its LU
/// factors with partial pivoting kept while each iteration contracts the scaled residual
/// fourfold), the same stopping rules (`|F₁| ≤ ε(2|x| + 8|δ₀|)` and `|g| ≤ 2ε`,
/// the round-off floor, the contraction estimate), the explicit Euler predictor, the same
/// warm start of `λ_k`, and `λ_{k+1}` in closed form.
#[derive(Clone, Copy, Default)]
struct HandSection2 {
    mu: f64,
    offset: f64,
    steps: u64,
}

/// `M ∇K` at `z` for `K = H + μ g` (gradient `(q₁μ, q₂μ, p₁, p₂)`) and `μ`, `1/D`.
#[inline(always)]
fn section2_field(z: &[f64; 4]) -> ([f64; 4], f64, f64) {
    let inv_d = 1.0 / (z[0] * z[0] + 2.0 * z[1] * z[1]);
    let mu = (z[2] * z[2] + z[3] * z[3]) * inv_d;
    ([z[2], z[3], -z[0] * mu, -2.0 * z[1] * mu], mu, inv_d)
}

/// LU factors of a 5 × 5 matrix with partial pivoting, in place (`piv[c]` the row swapped
/// with row `c`); `false` when a pivot vanishes.
#[inline(always)]
#[allow(clippy::needless_range_loop)]
fn factor5(a: &mut [[f64; 5]; 5], piv: &mut [usize; 5]) -> bool {
    for c in 0..5 {
        let mut p = c;
        for r in c + 1..5 {
            if a[r][c].abs() > a[p][c].abs() {
                p = r;
            }
        }
        piv[c] = p;
        a.swap(c, p);
        if a[c][c] == 0.0 {
            return false;
        }
        for r in c + 1..5 {
            let f = a[r][c] / a[c][c];
            a[r][c] = f;
            for j in c + 1..5 {
                a[r][j] -= f * a[c][j];
            }
        }
    }
    true
}

/// Solves with the factors of [`factor5`], in place.
#[inline(always)]
#[allow(clippy::needless_range_loop)]
fn solve5(lu: &[[f64; 5]; 5], piv: &[usize; 5], b: &mut [f64; 5]) {
    for c in 0..5 {
        b.swap(c, piv[c]);
    }
    for r in 0..5 {
        for j in 0..r {
            b[r] -= lu[r][j] * b[j];
        }
    }
    for r in (0..5).rev() {
        for j in r + 1..5 {
            b[r] -= lu[r][j] * b[j];
        }
        b[r] /= lu[r][r];
    }
}

/// The iterate at which a §2 Newton matrix is built: `x̄`, `μ(x̄)`, `1/D(x̄)` and `y`.
struct Section2Iterate {
    xbar: [f64; 4],
    mu: f64,
    inv_d: f64,
    y: [f64; 4],
}

impl Section2Iterate {
    /// `J f` at `x̄`: rows 0, 1 unit rows (`f₁ = p₁`, `f₂ = p₂`), rows 2, 3 from
    /// `∇μ = (−2q₁μ, −4q₂μ, 2p₁, 2p₂)/D`.
    #[inline(always)]
    fn jf(&self) -> [[f64; 4]; 4] {
        let (mu, inv_d) = (self.mu, self.inv_d);
        let [q1, q2, p1, p2] = self.xbar;
        let dmu = [
            -2.0 * q1 * mu * inv_d,
            -4.0 * q2 * mu * inv_d,
            2.0 * p1 * inv_d,
            2.0 * p2 * inv_d,
        ];
        let mut jf = [[0.0; 4]; 4];
        jf[0][2] = 1.0;
        jf[1][3] = 1.0;
        for j in 0..4 {
            jf[2][j] = -q1 * dmu[j];
            jf[3][j] = -2.0 * q2 * dmu[j];
        }
        jf[2][0] -= mu;
        jf[3][1] -= 2.0 * mu;
        jf
    }
}

impl HandSection2 {
    /// One §2 step: the Newton iteration on `(δ, λ_k)` and the closed-form `λ_{k+1}`, with the
    /// linear algebra left to `solver`, so that the plain and the optimized hand-written steps
    /// run the same iteration.
    #[inline(always)]
    fn step_with(&mut self, h: f64, x: &mut V, solver: &mut impl Section2Solver) {
        let eps = f64::EPSILON;
        let (ftol, half) = (2.0 * eps, 0.5 * h);
        let (x1, x2, x3, x4) = (x[0], x[1], x[2], x[3]);
        // x̂ = x + (h/2) λ M Gᵀ = (x1, x2, x3 − (h/2) λ x1, x4 − h λ x2).
        let xhat = |l: f64| [x1, x2, x3 - half * l * x1, x4 - h * l * x2];
        let mut l = self.mu + h * self.offset;
        let (f0, _, _) = section2_field(&xhat(l));
        let mut delta = f0.map(|f| h * f);
        let amax = |v: &[f64]| v.iter().fold(0.0f64, |a, b| a.max(b.abs()));
        let tol1 = eps * (2.0 * amax(x.as_slice()) + 8.0 * amax(&delta));
        let (inv_tol1, inv_ftol) = (1.0 / tol1, 1.0 / ftol);
        let (mut have, mut prev, mut last_update) = (false, f64::INFINITY, f64::INFINITY);
        let mut y;
        let mut it = 0;
        loop {
            let xh = xhat(l);
            let xbar: [f64; 4] = core::array::from_fn(|i| xh[i] + 0.5 * delta[i]);
            let (f, mu, inv_d) = section2_field(&xbar);
            let r1: [f64; 4] = core::array::from_fn(|i| delta[i] - h * f[i]);
            y = core::array::from_fn::<f64, 4, _>(|i| xh[i] + delta[i]);
            let g = 0.5 * (y[0] * y[0] + y[1] * y[1] - 1.0);
            let scaled = (amax(&r1) * inv_tol1).max(g.abs() * inv_ftol);
            if scaled <= 1.0 || (scaled <= 100.0 && scaled >= 0.5 * prev) || it == 25 {
                break;
            }
            if !have || scaled > 0.25 * prev {
                solver.factor(h, x, &Section2Iterate { xbar, mu, inv_d, y });
                have = true;
            }
            prev = scaled;
            let b = solver.solve([-r1[0], -r1[1], -r1[2], -r1[3], -g]);
            for i in 0..4 {
                delta[i] += b[i];
            }
            l += b[4];
            it += 1;
            let update = amax(&b[..4]) * inv_tol1;
            if last_update.is_finite()
                && update < last_update
                && update * update <= 0.5 * (last_update - update)
            {
                let xh = xhat(l);
                y = core::array::from_fn(|i| xh[i] + delta[i]);
                if (0.5 * (y[0] * y[0] + y[1] * y[1] - 1.0)).abs() <= ftol {
                    break;
                }
            }
            last_update = update;
        }
        if self.steps > 0 {
            self.offset = (l - self.mu) / h;
        }
        // λ_{k+1} in closed form, as in the §3 hand-written step.
        let (y1, y2, y3, y4) = (y[0], y[1], y[2], y[3]);
        let mu = (y1 * y3 + y2 * y4) / (half * (y1 * y1 + 2.0 * y2 * y2));
        self.mu = mu;
        self.steps += 1;
        *x = V::new(y1, y2, y3 - half * y1 * mu, y4 - h * y2 * mu);
    }

    /// The same algorithm as `ProjectedMidpoint`: the full 5 × 5 Newton matrix, LU with partial
    /// pivoting.
    #[inline]
    fn step(&mut self, h: f64, x: &mut V) {
        self.step_with(h, x, &mut Full::default());
    }
}

/// The linear algebra of a hand-written §2 step: build and factor the Newton matrix at an
/// iterate, and solve with the kept factors.
trait Section2Solver {
    fn factor(&mut self, h: f64, x: &V, it: &Section2Iterate);
    fn solve(&self, b: [f64; 5]) -> [f64; 5];
}

/// The full 5 × 5 Newton matrix's LU factors with partial pivoting.
#[derive(Default)]
struct Full {
    lu: [[f64; 5]; 5],
    piv: [usize; 5],
}

impl Section2Solver for Full {
    #[inline(always)]
    fn factor(&mut self, h: f64, x: &V, it: &Section2Iterate) {
        let half = 0.5 * h;
        let jf = it.jf();
        // ∂F₁/∂δ = I − (h/2) J f; ∂F₁/∂λ = −h J f (h/2) d, d = (0, 0, −x1, −2x2);
        // ∂F₂/∂δ = (y1, y2, 0, 0); ∂F₂/∂λ = 0.
        let d = [0.0, 0.0, -x[0], -2.0 * x[1]];
        let jac = &mut self.lu;
        for i in 0..4 {
            for j in 0..4 {
                jac[i][j] = if i == j { 1.0 } else { 0.0 } - half * jf[i][j];
            }
            jac[i][4] = -h * half * (jf[i][2] * d[2] + jf[i][3] * d[3]);
        }
        jac[4] = [it.y[0], it.y[1], 0.0, 0.0, 0.0];
        assert!(factor5(jac, &mut self.piv), "singular Newton matrix");
    }
    #[inline(always)]
    fn solve(&self, mut b: [f64; 5]) -> [f64; 5] {
        solve5(&self.lu, &self.piv, &mut b);
        b
    }
}

/// The §2 step above optimized by hand, to measure what the scheme costs at best: the same
/// Newton iteration, predictor, stopping rules, warm start and closed-form `λ_{k+1}`
/// ([`HandSection2::step_with`]), with the model's structure used in the linear algebra. Rows 0
/// and 1 of `J f` are unit rows, so the first two equations give `Δδ₁`, `Δδ₂` in terms of the
/// others and the 5 × 5 Newton system reduces to 3 × 3 (`Δδ₃`, `Δδ₄`, `Δλ`), factored with
/// partial pivoting and reciprocal pivots (no division in the solves).
#[derive(Clone, Copy, Default)]
struct FastSection2(HandSection2);

/// Factors of [`FastSection2`]'s reduced system: the 3 × 3 LU, its reciprocal pivots and row
/// swaps, the entries of the full matrix the right-hand side is reduced with
/// (`J₂₀, J₂₁, J₃₀, J₃₁, y₁, y₂`), the `λ` column of rows 0, 1, and `h/2`.
#[derive(Default)]
struct Reduced {
    r: [[f64; 3]; 3],
    rinv: [f64; 3],
    piv: [usize; 3],
    w: [f64; 6],
    c: [f64; 2],
    half: f64,
}

impl FastSection2 {
    #[inline]
    fn step(&mut self, h: f64, x: &mut V) {
        self.0.step_with(h, x, &mut Reduced::default());
    }
}

impl Section2Solver for Reduced {
    #[inline(always)]
    #[allow(clippy::needless_range_loop)] // index loops read best for elimination
    fn factor(&mut self, h: f64, x: &V, it: &Section2Iterate) {
        let half = 0.5 * h;
        // ∂x̂/∂λ = (0, 0, e₃, e₄); the λ column of row i is −h (J f)ᵢ · ∂x̂/∂λ.
        let (e3, e4) = (-half * x[0], -h * x[1]);
        let (c0, c1) = (-h * e3, -h * e4);
        let jf = it.jf();
        let (jf2, jf3) = (jf[2], jf[3]);
        // Rows 2 and 3 of the Newton matrix and their λ column.
        let j2 = [
            -half * jf2[0],
            -half * jf2[1],
            1.0 - half * jf2[2],
            -half * jf2[3],
        ];
        let j3 = [
            -half * jf3[0],
            -half * jf3[1],
            -half * jf3[2],
            1.0 - half * jf3[3],
        ];
        let c2 = -h * (jf2[2] * e3 + jf2[3] * e4);
        let c3 = -h * (jf3[2] * e3 + jf3[3] * e4);
        let y = it.y;
        // Δδ₁ = b₀ + (h/2) Δδ₃ − c₀ Δλ and Δδ₂ = b₁ + (h/2) Δδ₄ − c₁ Δλ substituted into rows
        // 2, 3 and the constraint row (y₁, y₂, 0, 0, 0).
        self.r = [
            [
                j2[2] + half * j2[0],
                j2[3] + half * j2[1],
                c2 - j2[0] * c0 - j2[1] * c1,
            ],
            [
                j3[2] + half * j3[0],
                j3[3] + half * j3[1],
                c3 - j3[0] * c0 - j3[1] * c1,
            ],
            [half * y[0], half * y[1], -(y[0] * c0 + y[1] * c1)],
        ];
        self.w = [j2[0], j2[1], j3[0], j3[1], y[0], y[1]];
        self.c = [c0, c1];
        self.half = half;
        let r = &mut self.r;
        for c in 0..3 {
            let mut p = c;
            for i in c + 1..3 {
                if r[i][c].abs() > r[p][c].abs() {
                    p = i;
                }
            }
            self.piv[c] = p;
            r.swap(c, p);
            assert!(r[c][c] != 0.0, "singular Newton matrix");
            self.rinv[c] = 1.0 / r[c][c];
            for i in c + 1..3 {
                let m = r[i][c] * self.rinv[c];
                r[i][c] = m;
                for j in c + 1..3 {
                    r[i][j] -= m * r[c][j];
                }
            }
        }
    }
    #[inline(always)]
    #[allow(clippy::needless_range_loop)]
    fn solve(&self, b: [f64; 5]) -> [f64; 5] {
        let (r, w) = (&self.r, &self.w);
        let mut rb = [
            b[2] - w[0] * b[0] - w[1] * b[1],
            b[3] - w[2] * b[0] - w[3] * b[1],
            b[4] - w[4] * b[0] - w[5] * b[1],
        ];
        for k in 0..3 {
            rb.swap(k, self.piv[k]);
        }
        for i in 1..3 {
            for j in 0..i {
                rb[i] -= r[i][j] * rb[j];
            }
        }
        for i in (0..3).rev() {
            for j in i + 1..3 {
                rb[i] -= r[i][j] * rb[j];
            }
            rb[i] *= self.rinv[i];
        }
        let (u2, u3, ul) = (rb[0], rb[1], rb[2]);
        let (half, c) = (self.half, self.c);
        [
            b[0] + half * u2 - c[0] * ul,
            b[1] + half * u3 - c[1] * ul,
            u2,
            u3,
            ul,
        ]
    }
}

fn check_same_algorithm() {
    let x0: V = paper::initial_state();
    let mut generic = paper::drift()
        .projected(paper::system(), &x0, ProjectionOptions::default())
        .unwrap();
    let mut hand = HandWritten::default();
    let (mut a, mut b) = (x0, x0);
    for _ in 0..1000 {
        generic.step(0.1, &mut a).unwrap();
        hand.step(0.1, &mut b);
    }
    let d = (a - b).amax();
    assert!(
        d < 1e-12,
        "generic and hand-written schemes differ by {d:e}"
    );
    // The §2 scheme, generic (ProjectedMidpoint) and hand-written.
    let mut generic: ProjectedMidpoint<V, _, _> = ProjectedMidpoint::try_new(
        paper::system(),
        paper::modified_energy(),
        &x0,
        ProjectionOptions::default(),
    )
    .unwrap();
    let mut hand = HandSection2::default();
    let (mut a, mut b) = (x0, x0);
    for _ in 0..1000 {
        generic.step(0.1, &mut a).unwrap();
        hand.step(0.1, &mut b);
    }
    let d = (a - b).amax();
    assert!(
        d < 1e-12,
        "generic and hand-written §2 schemes differ by {d:e}"
    );
    let mut fast = FastSection2::default();
    let mut c = x0;
    for _ in 0..1000 {
        fast.step(0.1, &mut c);
    }
    let d = (a - c).amax();
    assert!(
        d < 1e-12,
        "generic and optimized hand-written §2 schemes differ by {d:e}"
    );
    // The compositions: generic (fused), hand-written stage by stage and fused.
    let mut generic = paper::drift()
        .projected(paper::system(), &x0, ProjectionOptions::default())
        .unwrap()
        .composed(&KAHAN_LI8);
    let (mut staged, mut fused) = (HandWritten::default(), HandWritten::default());
    let (mut a, mut b, mut c) = (x0, x0, x0);
    for _ in 0..300 {
        generic.step(0.1, &mut a).unwrap();
        staged.composed(&KAHAN_LI8, 0.1, &mut b);
        fused.composed_fused(&KAHAN_LI8, 0.1, &mut c);
    }
    let (d1, d2) = ((a - b).amax(), (a - c).amax());
    assert!(
        d1 < 1e-12 && d2 < 1e-12,
        "Kahan-Li 8: generic differs from hand-written by {d1:e} (staged), {d2:e} (fused)"
    );
}

fn bench(c: &mut Criterion) {
    check_same_algorithm();
    let x0: V = paper::initial_state();

    let projected = || {
        paper::drift()
            .projected(paper::system(), &x0, ProjectionOptions::default())
            .unwrap()
    };
    let mut generic = projected();
    let mut hand = HandWritten::default();
    pair(
        c,
        "paper_projection_step",
        &x0,
        |h, x| generic.step(h, x).unwrap(),
        |h, x| hand.step(h, x),
    );
    let mut generic = projected().triple_jump();
    let mut hand = HandWritten::default();
    pair(
        c,
        "paper_triple_jump_step",
        &x0,
        |h, x| generic.step(h, x).unwrap(),
        |h, x| hand.composed(&TRIPLE_JUMP, h, x),
    );
    let mut generic = projected().triple_jump();
    let mut hand = HandWritten::default();
    pair(
        c,
        "paper_triple_jump_step_fused",
        &x0,
        |h, x| generic.step(h, x).unwrap(),
        |h, x| hand.composed_fused(&TRIPLE_JUMP, h, x),
    );
    let mut generic = projected().composed(&KAHAN_LI8);
    let mut hand = HandWritten::default();
    pair(
        c,
        "paper_kahan_li8_step",
        &x0,
        |h, x| generic.step(h, x).unwrap(),
        |h, x| hand.composed(&KAHAN_LI8, h, x),
    );
    // The paper's §2 scheme (projection around the implicit midpoint rule for H + μ g, the
    // closed-form derivatives of paper::ModifiedEnergy) against its §3 scheme, one step each.
    let inner: ImplicitMidpoint<V, _, _> = ImplicitMidpoint::try_new(
        paper::Structure,
        paper::modified_energy(),
        &x0,
        lieflow::nonlinear::NewtonOptions::default(),
    )
    .unwrap();
    let mut section2 = inner
        .projected(paper::system(), &x0, ProjectionOptions::default())
        .unwrap();
    // The same scheme with the midpoint increment and λ_k as one Newton system.
    let mut joint: ProjectedMidpoint<V, _, _> = ProjectedMidpoint::try_new(
        paper::system(),
        paper::modified_energy(),
        &x0,
        ProjectionOptions::default(),
    )
    .unwrap();
    let mut section3 = projected();
    let mut group = c.benchmark_group("paper_section2_vs_section3");
    let mut x = x0;
    group.bench_function("section2_modified", |b| {
        b.iter(|| section2.step(black_box(0.1), &mut x).unwrap())
    });
    let mut x = x0;
    group.bench_function("section2_joint", |b| {
        b.iter(|| joint.step(black_box(0.1), &mut x).unwrap())
    });
    let mut hand = HandSection2::default();
    let mut x = x0;
    group.bench_function("section2_hand_written", |b| {
        b.iter(|| hand.step(black_box(0.1), &mut x))
    });
    let mut fast = FastSection2::default();
    let mut x = x0;
    group.bench_function("section2_hand_optimized", |b| {
        b.iter(|| fast.step(black_box(0.1), &mut x))
    });
    let mut x = x0;
    group.bench_function("section3_projection", |b| {
        b.iter(|| section3.step(black_box(0.1), &mut x).unwrap())
    });
    group.finish();
    let mut generic = projected().composed(&KAHAN_LI8);
    let mut hand = HandWritten::default();
    pair(
        c,
        "paper_kahan_li8_step_fused",
        &x0,
        |h, x| generic.step(h, x).unwrap(),
        |h, x| hand.composed_fused(&KAHAN_LI8, h, x),
    );
}

/// One criterion group: the generic step against the hand-written one, each from `x0` at h = 0.1.
fn pair(
    c: &mut Criterion,
    name: &str,
    x0: &V,
    mut generic: impl FnMut(f64, &mut V),
    mut hand: impl FnMut(f64, &mut V),
) {
    let mut group = c.benchmark_group(name);
    let mut x = *x0;
    group.bench_function("generic", |b| b.iter(|| generic(black_box(0.1), &mut x)));
    let mut x = *x0;
    group.bench_function("hand_written", |b| b.iter(|| hand(black_box(0.1), &mut x)));
    group.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .warm_up_time(std::time::Duration::from_millis(500))
        .measurement_time(std::time::Duration::from_secs(2));
    targets = bench
}
criterion_main!(benches);
