//! Scaling of the sparse path: one RATTLE step (projected kick–drift–kick) of the N-link
//! pendulum chain for N = 10³, 10⁴, 10⁵ with the sparse LU, and N = 10², 10³ with the dense LU
//! for comparison. Same shape, same step `h = 10⁻⁶` (below the chain's stability bound `h ≤ 1/N`
//! for every N, so the Newton work per step is comparable).
//!
//! After criterion's measurements, the bench times every configuration again in the same
//! process (median of 9 runs of about 0.25 s each), prints the table and the ratio
//! `ns/step(10⁵) / ns/step(10⁴)` (linear cost: about 10), and writes `chain_scaling.csv` and
//! the log-log plot `chain_scaling.svg` into `$LIEFLOW_FIGURES` when that is set:
//!
//! ```text
//! LIEFLOW_FIGURES=docs/figures cargo bench --bench chain
//! ```
//!
//! Last, the Newton matrix of a chain's reduced implicit step, `[[A, C], [G, 0]]` with all
//! positions before all multipliers (3000 planar links), factored and solved by faer's sparse
//! LU and by `AutoLu` built from the pattern (the band solver on the reverse Cuthill–McKee
//! renumbering), in the same process.

use criterion::{Criterion, criterion_group};
use faer::Col;
use lieflow::linalg::{AutoLu, LinearSolver, Sink, SolverChoice, SolverKind, Structure};
use lieflow::models::PendulumChain;
use lieflow::prelude::*;
use std::hint::black_box;
use std::time::Instant;

type V = Col<f64>;

const H: f64 = 1e-6;

/// A chain of `n` links, its RATTLE flow with the given backend, and a state after 3 steps
/// (warm multipliers and Jacobians).
fn setup(n: usize, kind: SolverKind) -> (impl Flow<V>, V) {
    let model = PendulumChain::<f64>::uniform(2, n).unwrap();
    let mut x: V = model.at_rest(|i| 0.1 * (std::f64::consts::PI * i as f64 / n as f64).sin());
    let options = model.projection_options();
    let options = options.with_newton(options.newton.with_solver(SolverChoice::Force(kind)));
    let mut flow = model
        .kick::<V>()
        .strang(model.drift())
        .projected(model.system(), &x, options)
        .unwrap();
    for _ in 0..3 {
        flow.step(H, &mut x).unwrap();
    }
    (flow, x)
}

/// RATTLE for the planar, pinned chain written out by hand: the same equations as the generic
/// projected kick–drift–kick, the same tolerance and stopping rule (the chain's
/// `projection_options`: `|g| ≤ ftol = 16 ε l L`, or `≤ 100 ftol` with an update at round-off or
/// a stalled residual), the same warm start for `λ_k` (the last `λ_{k+1}` plus the last offset
/// per unit step). `λ_k` by Newton with the exact tridiagonal Jacobian
/// `∂g(y)/∂λ = −(h²/2) G(y) M⁻¹ G(x)ᵀ`, `λ_{k+1}` from the linear system
/// `(h/2) G(y) M⁻¹ G(y)ᵀ μ = G(y) M⁻¹ p_y`, both by the Thomas algorithm.
struct HandChain {
    n: usize,
    inv_m: Vec<f64>,
    weight: Vec<f64>,
    l2: Vec<f64>,
    ftol: f64,
    mu: Vec<f64>,
    offset: Vec<f64>,
    lam: Vec<f64>,
    steps: u64,
    /// Rod vectors at x and at y, the λ-free part of q_y, q_y, and the Thomas workspace.
    dx: Vec<[f64; 2]>,
    dy: Vec<[f64; 2]>,
    qb: Vec<[f64; 2]>,
    qy: Vec<[f64; 2]>,
    g: Vec<f64>,
    sub: Vec<f64>,
    diag: Vec<f64>,
    sup: Vec<f64>,
}

impl HandChain {
    fn new(model: &PendulumChain<f64>) -> Self {
        let n = model.links();
        let (masses, lengths, gravity) = model.parameters();
        let l_min = lengths.iter().fold(f64::INFINITY, |a, &b| a.min(b));
        let total: f64 = lengths.iter().sum();
        let z = || vec![0.0; n];
        let z2 = || vec![[0.0; 2]; n];
        Self {
            n,
            inv_m: masses.iter().map(|m| 1.0 / m).collect(),
            weight: masses.iter().map(|m| m * gravity).collect(),
            l2: lengths.iter().map(|l| l * l).collect(),
            ftol: 16.0 * f64::EPSILON * l_min * total.max(l_min),
            mu: z(),
            offset: z(),
            lam: z(),
            steps: 0,
            dx: z2(),
            dy: z2(),
            qb: z2(),
            qy: z2(),
            g: z(),
            sub: z(),
            diag: z(),
            sup: z(),
        }
    }

    /// `q_y = q_b − (h²/2) M⁻¹ G(x)ᵀ λ` and `g(q_y)`; returns `‖g‖∞`.
    fn residual(&mut self, h: f64) -> f64 {
        let n = self.n;
        let mut r = 0.0f64;
        for i in 0..n {
            let c = 0.5 * h * h * self.inv_m[i];
            // (Gᵀλ)_i = λ_i dx_i − λ_{i+1} dx_{i+1}
            let (l0, l1) = (self.lam[i], if i + 1 < n { self.lam[i + 1] } else { 0.0 });
            let d1 = if i + 1 < n { self.dx[i + 1] } else { [0.0; 2] };
            let f = [
                l0 * self.dx[i][0] - l1 * d1[0],
                l0 * self.dx[i][1] - l1 * d1[1],
            ];
            self.qy[i] = [self.qb[i][0] - c * f[0], self.qb[i][1] - c * f[1]];
            let prev = if i > 0 { self.qy[i - 1] } else { [0.0; 2] };
            self.dy[i] = [self.qy[i][0] - prev[0], self.qy[i][1] - prev[1]];
            let gi =
                0.5 * (self.dy[i][0] * self.dy[i][0] + self.dy[i][1] * self.dy[i][1] - self.l2[i]);
            self.g[i] = gi;
            r = r.max(gi.abs());
        }
        r
    }

    /// Solves the tridiagonal system (sub, diag, sup) in place of `rhs` (Thomas algorithm).
    fn thomas(sub: &[f64], diag: &mut [f64], sup: &[f64], rhs: &mut [f64]) {
        let n = diag.len();
        for i in 1..n {
            let w = sub[i] / diag[i - 1];
            diag[i] -= w * sup[i - 1];
            rhs[i] -= w * rhs[i - 1];
        }
        rhs[n - 1] /= diag[n - 1];
        for i in (0..n - 1).rev() {
            rhs[i] = (rhs[i] - sup[i] * rhs[i + 1]) / diag[i];
        }
    }

    fn step(&mut self, h: f64, x: &mut [f64]) {
        let n = self.n;
        let (q, p) = x.split_at_mut(2 * n);
        // Rod vectors at x and the λ-independent part of q_y (kick h/2, drift h).
        let mut prev = [0.0; 2];
        for i in 0..n {
            let qi = [q[2 * i], q[2 * i + 1]];
            self.dx[i] = [qi[0] - prev[0], qi[1] - prev[1]];
            prev = qi;
            let w = self.inv_m[i] * h;
            self.qb[i] = [
                qi[0] + w * p[2 * i],
                qi[1] + w * (p[2 * i + 1] - 0.5 * h * self.weight[i]),
            ];
        }
        for i in 0..n {
            self.lam[i] = self.mu[i] + h * self.offset[i];
        }
        // λ_k: Newton with the exact tridiagonal Jacobian.
        let (xtol, noise) = (16.0 * f64::EPSILON, 100.0 * self.ftol);
        let (mut r_prev, mut step) = (f64::INFINITY, f64::INFINITY);
        let mut r = self.residual(h);
        for _ in 0..25 {
            let lmax = self.lam.iter().fold(0.0f64, |a, &b| a.max(b.abs()));
            if r <= self.ftol || (r <= noise && (step <= xtol * (1.0 + lmax) || r >= 0.5 * r_prev))
            {
                break;
            }
            for i in 0..n {
                let ci = 0.5 * h * h * self.inv_m[i];
                let cp = if i > 0 {
                    0.5 * h * h * self.inv_m[i - 1]
                } else {
                    0.0
                };
                let dot = |a: [f64; 2], b: [f64; 2]| a[0] * b[0] + a[1] * b[1];
                self.diag[i] = -(ci + cp) * dot(self.dy[i], self.dx[i]);
                self.sup[i] = if i + 1 < n {
                    ci * dot(self.dy[i], self.dx[i + 1])
                } else {
                    0.0
                };
                self.sub[i] = if i > 0 {
                    cp * dot(self.dy[i], self.dx[i - 1])
                } else {
                    0.0
                };
                self.g[i] = -self.g[i];
            }
            Self::thomas(&self.sub, &mut self.diag, &self.sup, &mut self.g);
            step = 0.0;
            for i in 0..n {
                self.lam[i] += self.g[i];
                step = step.max(self.g[i].abs());
            }
            r_prev = r;
            r = self.residual(h);
        }
        if self.steps > 0 {
            for i in 0..n {
                self.offset[i] = (self.lam[i] - self.mu[i]) / h;
            }
        }
        // y: q_y from the last residual; p_y = p − (h/2) Gᵀ(x) λ − h m γ e_vertical.
        for i in 0..n {
            let (l0, l1) = (self.lam[i], if i + 1 < n { self.lam[i + 1] } else { 0.0 });
            let d1 = if i + 1 < n { self.dx[i + 1] } else { [0.0; 2] };
            p[2 * i] -= 0.5 * h * (l0 * self.dx[i][0] - l1 * d1[0]);
            p[2 * i + 1] -= 0.5 * h * (l0 * self.dx[i][1] - l1 * d1[1]) + h * self.weight[i];
            q[2 * i] = self.qy[i][0];
            q[2 * i + 1] = self.qy[i][1];
        }
        // λ_{k+1}: (h/2) G(y) M⁻¹ G(y)ᵀ μ = G(y) M⁻¹ p_y, symmetric tridiagonal.
        let dot = |a: [f64; 2], b: [f64; 2]| a[0] * b[0] + a[1] * b[1];
        for i in 0..n {
            let vi = [p[2 * i] * self.inv_m[i], p[2 * i + 1] * self.inv_m[i]];
            let vp = if i > 0 {
                [
                    p[2 * i - 2] * self.inv_m[i - 1],
                    p[2 * i - 1] * self.inv_m[i - 1],
                ]
            } else {
                [0.0; 2]
            };
            self.g[i] = dot(self.dy[i], [vi[0] - vp[0], vi[1] - vp[1]]);
            let hm = 0.5 * h;
            let wp = if i > 0 { self.inv_m[i - 1] } else { 0.0 };
            self.diag[i] = hm * dot(self.dy[i], self.dy[i]) * (self.inv_m[i] + wp);
            self.sup[i] = if i + 1 < n {
                -hm * dot(self.dy[i], self.dy[i + 1]) * self.inv_m[i]
            } else {
                0.0
            };
            self.sub[i] = if i > 0 {
                -hm * dot(self.dy[i], self.dy[i - 1]) * wp
            } else {
                0.0
            };
        }
        Self::thomas(&self.sub, &mut self.diag, &self.sup, &mut self.g);
        for i in 0..n {
            let (m0, m1) = (self.g[i], if i + 1 < n { self.g[i + 1] } else { 0.0 });
            let d1 = if i + 1 < n { self.dy[i + 1] } else { [0.0; 2] };
            p[2 * i] -= 0.5 * h * (m0 * self.dy[i][0] - m1 * d1[0]);
            p[2 * i + 1] -= 0.5 * h * (m0 * self.dy[i][1] - m1 * d1[1]);
        }
        std::mem::swap(&mut self.mu, &mut self.g);
        self.steps += 1;
    }
}

/// The generic RATTLE and the hand-written one from the same state agree after `steps` steps.
fn check_same_algorithm(n: usize, steps: usize) {
    let model = PendulumChain::<f64>::uniform(2, n).unwrap();
    let x0: V = model.at_rest(|i| 0.1 * (std::f64::consts::PI * i as f64 / n as f64).sin());
    let mut flow = model
        .kick::<V>()
        .strang(model.drift())
        .projected(model.system(), &x0, model.projection_options())
        .unwrap();
    let mut hand = HandChain::new(&model);
    let (mut a, mut b) = (x0.clone(), x0.as_slice().to_vec());
    for _ in 0..steps {
        flow.step(H, &mut a).unwrap();
        hand.step(H, &mut b);
    }
    let d = a
        .as_slice()
        .iter()
        .zip(&b)
        .fold(0.0f64, |m, (u, v)| m.max((u - v).abs()));
    assert!(
        d < 1e-12,
        "generic and hand-written RATTLE differ by {d:e} at N = {n}"
    );
    println!(
        "hand-written RATTLE matches the generic one at N = {n} after {steps} steps: max diff {d:.1e}"
    );
}

const CONFIGS: [(SolverKind, &str, usize); 8] = [
    (SolverKind::Banded, "banded", 1_000),
    (SolverKind::Banded, "banded", 10_000),
    (SolverKind::Banded, "banded", 100_000),
    (SolverKind::Sparse, "sparse", 1_000),
    (SolverKind::Sparse, "sparse", 10_000),
    (SolverKind::Sparse, "sparse", 100_000),
    (SolverKind::Dense, "dense", 100),
    (SolverKind::Dense, "dense", 1_000),
];

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("chain_step");
    group.sample_size(10);
    group.warm_up_time(std::time::Duration::from_millis(500));
    group.measurement_time(std::time::Duration::from_secs(2));
    for (kind, name, n) in CONFIGS {
        let (mut flow, mut x) = setup(n, kind);
        group.bench_function(format!("{name}/{n}"), |b| {
            b.iter(|| flow.step(black_box(H), &mut x).unwrap())
        });
    }
    group.finish();
}

/// Median ns/step over 9 runs of about 0.25 s each (at least 5 steps per run): long enough
/// runs that scheduler noise on a shared machine averages out within a run, and a median over
/// runs against the outliers.
fn time_config(kind: SolverKind, n: usize) -> (f64, f64) {
    let (mut flow, mut x) = setup(n, kind);
    // Steps per run from one timed step.
    let start = Instant::now();
    flow.step(H, &mut x).unwrap();
    let one = start.elapsed().as_secs_f64();
    let per_run = ((0.25 / one) as usize).clamp(5, 2000);
    let before = flow.stats().newton_iterations;
    let mut runs: Vec<f64> = (0..9)
        .map(|_| {
            let start = Instant::now();
            for _ in 0..per_run {
                flow.step(H, &mut x).unwrap();
            }
            start.elapsed().as_nanos() as f64 / per_run as f64
        })
        .collect();
    runs.sort_by(f64::total_cmp);
    let iterations = (flow.stats().newton_iterations - before) as f64 / (9 * per_run) as f64;
    (runs[4], iterations)
}

/// Median ns/step of the hand-written RATTLE, timed like [`time_config`].
fn time_hand(n: usize) -> f64 {
    let model = PendulumChain::<f64>::uniform(2, n).unwrap();
    let x0: V = model.at_rest(|i| 0.1 * (std::f64::consts::PI * i as f64 / n as f64).sin());
    let mut hand = HandChain::new(&model);
    let mut x = x0.as_slice().to_vec();
    for _ in 0..3 {
        hand.step(H, &mut x);
    }
    let start = Instant::now();
    hand.step(H, &mut x);
    let one = start.elapsed().as_secs_f64();
    let per_run = ((0.25 / one) as usize).clamp(5, 2000);
    let mut runs: Vec<f64> = (0..9)
        .map(|_| {
            let start = Instant::now();
            for _ in 0..per_run {
                hand.step(black_box(H), &mut x);
            }
            start.elapsed().as_nanos() as f64 / per_run as f64
        })
        .collect();
    runs.sort_by(f64::total_cmp);
    runs[4]
}

fn scaling_summary() {
    check_same_algorithm(1000, 20);
    println!("\nchain scaling (h = {H}, median of 9 runs of ~0.25 s, same process):");
    println!(
        "{:<8} {:>8} {:>14} {:>16}",
        "backend", "N", "ns/step", "Newton it./step"
    );
    let mut rows = Vec::new();
    for (kind, name, n) in CONFIGS {
        let (ns, it) = time_config(kind, n);
        println!("{name:<8} {n:>8} {ns:>14.0} {it:>16.2}");
        rows.push((name, n, ns, it));
    }
    let ns = |name: &str, n: usize| {
        rows.iter()
            .find(|r| r.0 == name && r.1 == n)
            .map(|r| r.2)
            .unwrap()
    };
    for backend in ["banded", "sparse"] {
        let ratio = ns(backend, 100_000) / ns(backend, 10_000);
        println!("{backend} ns/step ratio N = 1e5 / N = 1e4: {ratio:.2} (linear: 10)");
    }
    println!(
        "dense / sparse at N = 1000: {:.1}",
        ns("dense", 1000) / ns("sparse", 1000)
    );
    let mut hand_rows = Vec::new();
    for n in [10_000, 100_000] {
        let hand = time_hand(n);
        println!(
            "hand-written RATTLE (Thomas) N = {n}: {hand:.0} ns/step; generic / hand-written: banded {:.2}, sparse {:.2}",
            ns("banded", n) / hand,
            ns("sparse", n) / hand
        );
        hand_rows.push(hand);
    }
    println!(
        "hand-written ns/step ratio N = 1e5 / N = 1e4: {:.2}",
        hand_rows[1] / hand_rows[0]
    );
    if let Ok(dir) = std::env::var("LIEFLOW_FIGURES") {
        let dir = std::path::Path::new(&dir);
        rows.push(("hand-written", 10_000, hand_rows[0], f64::NAN));
        rows.push(("hand-written", 100_000, hand_rows[1], f64::NAN));
        let mut csv = String::from("backend,links,ns_per_step,newton_iterations_per_step\n");
        for (name, n, ns, it) in &rows {
            csv.push_str(&format!("{name},{n},{ns:.0},{it:.2}\n"));
        }
        std::fs::write(dir.join("chain_scaling.csv"), csv).unwrap();
        plot(&dir.join("chain_scaling.svg"), &rows).unwrap();
        println!("wrote {}", dir.join("chain_scaling.svg").display());
    }
}

fn plot(
    path: &std::path::Path,
    rows: &[(&str, usize, f64, f64)],
) -> Result<(), Box<dyn std::error::Error>> {
    use plotters::prelude::*;
    let root = SVGBackend::new(path, (640, 440)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption("N-link chain, one RATTLE step", ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d((50f64..2e5).log_scale(), (1e4f64..1e9).log_scale())?;
    chart
        .configure_mesh()
        .x_desc("links N")
        .y_desc("ns / step")
        .x_label_formatter(&|v| format!("{v:.0e}"))
        .y_label_formatter(&|v| format!("{v:.0e}"))
        .draw()?;
    for (name, color) in [
        ("banded", GREEN),
        ("sparse", BLUE),
        ("dense", RED),
        ("hand-written", BLACK),
    ] {
        let pts: Vec<(f64, f64)> = rows
            .iter()
            .filter(|r| r.0 == name)
            .map(|r| (r.1 as f64, r.2))
            .collect();
        chart
            .draw_series(LineSeries::new(pts.clone(), color.stroke_width(2)))?
            .label(if name == "hand-written" {
                "hand-written RATTLE (Thomas)".to_string()
            } else {
                format!("{name} LU")
            })
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color));
        chart.draw_series(pts.iter().map(|&p| Circle::new(p, 4, color.filled())))?;
    }
    // The linear reference through the sparse N = 1000 point.
    if let Some(r) = rows.iter().find(|r| r.0 == "sparse" && r.1 == 1000) {
        let c = r.2 / 1000.0;
        chart
            .draw_series(LineSeries::new(
                [(1e3, c * 1e3), (1e5, c * 1e5)],
                BLACK.mix(0.4).stroke_width(1),
            ))?
            .label("linear")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK.mix(0.4)));
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .position(SeriesLabelPosition::UpperLeft)
        .draw()?;
    root.present()?;
    Ok(())
}

criterion_group!(benches, bench);

/// The entries of a planar `n`-link chain's reduced Newton matrix in block order: `A = I` plus
/// the curvature couplings of the bodies a rod joins, `C = W⁻¹G_qᵀ`, `G` (rod `a` joins bodies
/// `a − 1` and `a`, body −1 the anchor).
fn kkt_entries(n: usize) -> Vec<(usize, usize, f64)> {
    let nq = 2 * n;
    let dir = [0.5, -0.866];
    let mut e: Vec<(usize, usize, f64)> = (0..nq).map(|i| (i, i, 1.0 + 1e-3)).collect();
    for a in 0..n {
        let bodies = [a.checked_sub(1), Some(a)];
        for (side, body) in bodies.iter().enumerate() {
            let Some(b) = *body else { continue };
            let sign = if side == 0 { -1.0 } else { 1.0 };
            for (c, &d) in dir.iter().enumerate() {
                let (q, row) = (2 * b + c, nq + a);
                e.push((row, q, sign * d));
                e.push((q, row, 1e3 * sign * d));
                if let Some(other) = bodies[1 - side] {
                    e.push((q, 2 * other + c, -1e-3));
                }
            }
        }
    }
    e
}

/// Median ns of one assembly, factorization and solve of `lin` over 9 runs.
fn time_kkt(lin: &mut AutoLu<f64>, entries: &[(usize, usize, f64)], k: usize) -> f64 {
    let rhs: Vec<f64> = (0..k).map(|i| (i % 7) as f64 - 3.0).collect();
    let mut x = rhs.clone();
    let mut once = |lin: &mut AutoLu<f64>| {
        lin.clear();
        for &(r, c, v) in entries {
            lin.add(r, c, v);
        }
        lin.factor().unwrap();
        x.copy_from_slice(&rhs);
        lin.solve_in_place(&mut x).unwrap();
        black_box(&x);
    };
    once(lin);
    let mut runs: Vec<f64> = (0..9)
        .map(|_| {
            let start = Instant::now();
            for _ in 0..20 {
                once(lin);
            }
            start.elapsed().as_nanos() as f64 / 20.0
        })
        .collect();
    runs.sort_by(f64::total_cmp);
    runs[4]
}

fn kkt_summary() {
    let n = 3000;
    let k = 3 * n;
    let entries = kkt_entries(n);
    let pattern: Vec<(usize, usize)> = entries.iter().map(|&(r, c, _)| (r, c)).collect();
    let mut sparse = AutoLu::<f64>::with_structure(
        k,
        Structure::of_pattern(&pattern),
        SolverChoice::Force(SolverKind::Sparse),
    )
    .unwrap();
    let mut auto = AutoLu::<f64>::with_pattern(k, &pattern, SolverChoice::Auto).unwrap();
    let (ts, ta) = (
        time_kkt(&mut sparse, &entries, k),
        time_kkt(&mut auto, &entries, k),
    );
    let band = match &auto {
        AutoLu::Reordered(r) => format!("renumbered band {:?}", r.bandwidth()),
        other => format!("{:?}", other.kind()),
    };
    println!(
        "\nchain Newton matrix, {n} links ({k} unknowns, block order), assemble + factor + solve:\n\
         sparse LU {ts:.0} ns, AutoLu from the pattern ({band}) {ta:.0} ns: {:.1}x",
        ts / ta
    );
}

fn main() {
    benches();
    Criterion::default().configure_from_args().final_summary();
    scaling_summary();
    kkt_summary();
}
