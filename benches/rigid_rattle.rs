//! What the general projection costs on one rigid body: lieflow's RATTLE (the projection around
//! kick ∘ drift ∘ kick of a [`Multibody`], METHOD §8) against the same RATTLE written by hand
//! for that one body — fixed-size nalgebra arrays, the body's rows and their Jacobian in closed
//! form, Newton on `λ` with the exact Jacobian `G(q') W⁻¹ G(q)ᵀ` (refactored each iteration) or
//! the simplified one `G(q) W⁻¹ G(q)ᵀ` (one Cholesky factor a step; the faster of the two is the
//! baseline), a Cholesky solve for `μ` — on a free asymmetric box and a heavy top on a ball
//! joint. Both start from the same state, take the same steps and must agree to round-off
//! before they are timed (the same map, not merely the same method).
//!
//! ```text
//! cargo bench --bench rigid_rattle
//! ```
//!
//! Besides criterion's groups it prints one line per model with the median ns/step of each and
//! the median of their ratios over 15 interleaved rounds (same process; each round times one
//! run of about 0.1 s of the library and of both hand-written steps, the faster of which is the
//! baseline). `RIGID_RATTLE_COUNT` runs one variant alone, for instruction counts (see
//! `count_only`).

use criterion::{Criterion, criterion_group};
use lieflow::prelude::*;
use lieflow::rigid::{Ball, BodyRef, Inertia, Multibody, RigidBody, Rotation, cross};
use nalgebra::{Const, DimMin, SMatrix, SVector};
use std::hint::black_box;
use std::time::Instant;

type V = SVector<f64, 24>;
const H: f64 = 1e-3;

/// One rigid body by hand: `q = (c, d₁, d₂, d₃)`, `p` likewise, `W⁻¹ = diag(1/m, 1/Eᵢ)`,
/// `V = m g c_z`; rows `dᵢ·dⱼ − δᵢⱼ` (`i ≤ j`) and, for `M = 9`, the pivot `c − l d₃ = 0`.
struct Hand<const M: usize> {
    w: [f64; 12],
    mg: f64,
    l: f64,
    lambda: SVector<f64, M>,
    simplified: bool,
}

const PAIRS: [(usize, usize); 6] = [(0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)];

impl<const M: usize> Hand<M>
where
    Const<M>: DimMin<Const<M>, Output = Const<M>>,
{
    fn new(mass: f64, e: [f64; 3], g: f64, l: f64, simplified: bool) -> Self {
        let mut w = [1.0 / mass; 12];
        for (k, &ek) in e.iter().enumerate() {
            w[3 + 3 * k..6 + 3 * k].fill(1.0 / ek);
        }
        Self {
            w,
            mg: mass * g,
            l,
            lambda: SVector::zeros(),
            simplified,
        }
    }

    fn rows(&self, q: &[f64]) -> SVector<f64, M> {
        let d = |i: usize| &q[3 + 3 * i..6 + 3 * i];
        let mut r = SVector::<f64, M>::zeros();
        for (row, &(i, j)) in PAIRS.iter().enumerate() {
            let dot: f64 = d(i).iter().zip(d(j)).map(|(a, b)| a * b).sum();
            r[row] = dot - if i == j { 1.0 } else { 0.0 };
        }
        for k in 0..M.saturating_sub(6) {
            r[6 + k] = q[k] - self.l * q[9 + k];
        }
        r
    }

    fn jacobian(&self, q: &[f64]) -> SMatrix<f64, M, 12> {
        let mut g = SMatrix::<f64, M, 12>::zeros();
        for (row, &(i, j)) in PAIRS.iter().enumerate() {
            for k in 0..3 {
                g[(row, 3 + 3 * i + k)] += q[3 + 3 * j + k];
                g[(row, 3 + 3 * j + k)] += q[3 + 3 * i + k];
            }
        }
        for k in 0..M.saturating_sub(6) {
            g[(6 + k, k)] = 1.0;
            g[(6 + k, 9 + k)] = -self.l;
        }
        g
    }

    fn step(&mut self, h: f64, x: &mut [f64]) {
        let (q, p) = x.split_at_mut(12);
        let half = 0.5 * h;
        p[2] -= half * self.mg;
        let g0 = self.jacobian(q);
        // q' = q̄ − (h²/2) W⁻¹ G(q)ᵀ λ
        let mut wg0t = g0.transpose();
        for (r, &w) in self.w.iter().enumerate() {
            wg0t.row_mut(r).scale_mut(w);
        }
        let qbar: [f64; 12] = core::array::from_fn(|r| q[r] + h * self.w[r] * p[r]);
        let c = half * h;
        let simplified = self.simplified.then(|| (g0 * wg0t * c).cholesky().unwrap());
        let mut qn = [0.0; 12];
        let mut last = f64::INFINITY;
        for _ in 0..30 {
            let shift = wg0t * self.lambda;
            for r in 0..12 {
                qn[r] = qbar[r] - c * shift[r];
            }
            let res = self.rows(&qn);
            let norm = res.amax();
            if norm <= 4.0 * f64::EPSILON || norm >= last {
                break;
            }
            last = norm;
            let delta = match &simplified {
                Some(chol) => chol.solve(&res),
                None => (self.jacobian(&qn) * wg0t * c).lu().solve(&res).unwrap(),
            };
            self.lambda += delta;
        }
        let force = g0.transpose() * self.lambda;
        for (pr, f) in p.iter_mut().zip(force.iter()) {
            *pr -= half * f;
        }
        q.copy_from_slice(&qn);
        p[2] -= half * self.mg;
        // μ from G(q') W⁻¹ p' = 0, p' = p − (h/2) G(q')ᵀ μ.
        let g1 = self.jacobian(q);
        let mut wg1t = g1.transpose();
        for (r, &w) in self.w.iter().enumerate() {
            wg1t.row_mut(r).scale_mut(w);
        }
        let pv = SVector::<f64, 12>::from_column_slice(p);
        let mu = (g1 * wg1t * half)
            .cholesky()
            .unwrap()
            .solve(&(wg1t.transpose() * pv));
        let force = g1.transpose() * mu;
        for r in 0..12 {
            p[r] -= half * force[r];
        }
    }
}

/// The heavy top of `examples/spinning_top.rs`: a cylinder of 1 kg (radius 0.1, height 0.2),
/// its base's centre on a ball joint at the origin, tilted 0.5 rad, spinning at 60 rad/s on its
/// slow steady precession. With `pivot = false` the same body flies free without gravity.
fn top(pivot: bool) -> (Multibody, Inertia, f64) {
    let (m, r, height, theta, spin) = (1.0, 0.1, 0.2, 0.5f64, 60.0);
    let g = if pivot { 9.81 } else { 0.0 };
    let l = 0.5 * height;
    let inertia = Inertia::solid_cylinder(m, r, height).unwrap();
    let j = inertia.moments();
    let (i1, i3) = (j[0] + m * l * l, j[2]);
    let c = theta.cos();
    let s = if pivot {
        (i3 * spin - (i3 * i3 * spin * spin - 4.0 * i1 * c * m * g * l).sqrt()) / (2.0 * i1 * c)
    } else {
        1.3
    };
    let tilt = Rotation::from_axis_angle([0.0, 1.0, 0.0], theta).unwrap();
    let axis = tilt.column(2);
    let omega: [f64; 3] =
        core::array::from_fn(|k| s * [0.0, 0.0, 1.0][k] + (spin - s * c) * axis[k]);
    let mut model = Multibody::new([0.0, 0.0, -g]);
    let mut body = RigidBody::at_rest(m, inertia, axis.map(|a| l * a));
    body.orientation = tilt;
    body.angular_velocity = omega;
    body.velocity = cross(omega, body.position);
    let id = model.add_rigid(body).unwrap();
    if pivot {
        model
            .add_joint(&Ball {
                a: BodyRef::Body(id),
                anchor_a: [0.0, 0.0, -l],
                b: BodyRef::World,
                anchor_b: [0.0; 3],
            })
            .unwrap();
    }
    (model, inertia, l)
}

fn library(model: &Multibody) -> (impl Flow<V> + use<>, V) {
    let x0: V = model.initial_state();
    let flow = model
        .kick::<V>()
        .strang(model.drift::<V>())
        .projected(model.system::<f64>(), &x0, model.projection_options())
        .unwrap();
    (flow, x0)
}

fn hand<const M: usize>(pivot: bool, simplified: bool) -> (Hand<M>, V)
where
    Const<M>: DimMin<Const<M>, Output = Const<M>>,
{
    let (model, inertia, l) = top(pivot);
    let g = if pivot { 9.81 } else { 0.0 };
    let hand = Hand::<M>::new(1.0, inertia.director_masses(), g, l, simplified);
    (hand, model.initial_state())
}

/// The hand-written step and the library's agree after 2000 steps (to 1e-9 of the state:
/// both stop Newton at round-off, and their roundings differ).
fn check_same_map<const M: usize>(pivot: bool, simplified: bool)
where
    Const<M>: DimMin<Const<M>, Output = Const<M>>,
{
    let (model, ..) = top(pivot);
    let (mut flow, x0) = library(&model);
    let (mut hand, _) = hand::<M>(pivot, simplified);
    let (mut a, mut b) = (x0, x0);
    for _ in 0..2000 {
        flow.step(H, &mut a).unwrap();
        hand.step(H, b.as_mut_slice());
    }
    let diff = (a - b).amax();
    assert!(
        diff < 1e-9,
        "hand and library differ by {diff:e} (pivot {pivot})"
    );
}

/// Steps per timed run of `step`: about 0.1 s each.
fn calibrate(step: &mut impl FnMut()) -> usize {
    for _ in 0..100 {
        step();
    }
    let start = Instant::now();
    for _ in 0..100 {
        step();
    }
    let one = start.elapsed().as_secs_f64() / 100.0;
    ((0.1 / one) as usize).clamp(5, 1_000_000)
}

/// ns/step of one timed run of `n` steps.
fn run_ns(step: &mut impl FnMut(), n: usize) -> f64 {
    let start = Instant::now();
    for _ in 0..n {
        step();
    }
    start.elapsed().as_nanos() as f64 / n as f64
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// The library's step against the faster of the two hand-written ones, in 15 rounds of one
/// run each (about 0.1 s), interleaved so that a shared machine's drift moves both alike: the
/// median ns/step of each and the median of the rounds' ratios.
fn summary<const M: usize>(name: &str, pivot: bool)
where
    Const<M>: DimMin<Const<M>, Output = Const<M>>,
{
    for simplified in [false, true] {
        check_same_map::<M>(pivot, simplified);
    }
    let (model, ..) = top(pivot);
    let (mut flow, mut x) = library(&model);
    let mut lib = || flow.step(black_box(H), &mut x).unwrap();
    let (mut hand_s, mut ys) = hand::<M>(pivot, true);
    let mut simplified = || hand_s.step(black_box(H), ys.as_mut_slice());
    let (mut hand_e, mut ye) = hand::<M>(pivot, false);
    let mut exact = || hand_e.step(black_box(H), ye.as_mut_slice());
    let (n_lib, n_s, n_e) = (
        calibrate(&mut lib),
        calibrate(&mut simplified),
        calibrate(&mut exact),
    );
    let (mut libs, mut hands, mut ratios) = (Vec::new(), Vec::new(), Vec::new());
    for _ in 0..15 {
        let l = run_ns(&mut lib, n_lib);
        let h = run_ns(&mut simplified, n_s).min(run_ns(&mut exact, n_e));
        libs.push(l);
        hands.push(h);
        ratios.push(l / h);
    }
    println!(
        "{{\"bench\":\"rigid_rattle\",\"model\":\"{name}\",\"library_ns\":{:.0},\"hand_ns\":{:.0},\"ratio\":{:.2}}}",
        median(libs),
        median(hands),
        median(ratios)
    );
}

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("rigid_rattle");
    group.sample_size(20);
    group.measurement_time(std::time::Duration::from_secs(2));
    for (name, pivot) in [("free_body", false), ("heavy_top", true)] {
        let (model, ..) = top(pivot);
        let (mut flow, mut x) = library(&model);
        group.bench_function(format!("{name}/library"), |b| {
            b.iter(|| flow.step(black_box(H), &mut x).unwrap())
        });
    }
    let (mut hand6, mut x6) = hand::<6>(false, true);
    group.bench_function("free_body/hand", |b| {
        b.iter(|| hand6.step(black_box(H), x6.as_mut_slice()))
    });
    let (mut hand9, mut x9) = hand::<9>(true, true);
    group.bench_function("heavy_top/hand", |b| {
        b.iter(|| hand9.step(black_box(H), x9.as_mut_slice()))
    });
    group.finish();
}

criterion_group!(benches, bench);

/// `RIGID_RATTLE_COUNT="<free_body|heavy_top>/<library|hand|hand_exact> N"`: only `N` steps of that one
/// variant, for an instruction count that repeats where wall-clock times on a shared machine do
/// not (`valgrind --tool=callgrind`, two `N` apart: the difference over the steps between them).
fn count_only(spec: &str) {
    let mut words = spec.split_whitespace();
    let (which, n) = (words.next().unwrap_or(""), words.next().unwrap_or("1000"));
    let n: usize = n.parse().expect("RIGID_RATTLE_COUNT: N is a step count");
    let pivot = which.starts_with("heavy_top");
    // `/hand` the simplified Newton (one Cholesky a step), `/hand_exact` the exact one.
    let simplified = !which.ends_with("/hand_exact");
    let mut x = if which.ends_with("/library") {
        let (model, ..) = top(pivot);
        let (mut flow, mut x) = library(&model);
        for _ in 0..n {
            flow.step(black_box(H), &mut x).unwrap();
        }
        x
    } else if pivot {
        let (mut hand, mut x) = hand::<9>(true, simplified);
        (0..n).for_each(|_| hand.step(black_box(H), x.as_mut_slice()));
        x
    } else {
        let (mut hand, mut x) = hand::<6>(false, simplified);
        (0..n).for_each(|_| hand.step(black_box(H), x.as_mut_slice()));
        x
    };
    println!(
        "{which} after {n} steps: |x| = {:e}",
        black_box(&mut x).amax()
    );
}

fn main() {
    if let Ok(spec) = std::env::var("RIGID_RATTLE_COUNT") {
        return count_only(&spec);
    }
    benches();
    Criterion::default().configure_from_args().final_summary();
    summary::<6>("free_body", false);
    summary::<9>("heavy_top", true);
}
