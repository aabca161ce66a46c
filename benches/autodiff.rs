//! What automatic derivatives cost: ns/step of a projected scheme on a model written once as
//! autodiff elements against the same scheme on the hand-derived model, same process, same
//! state: the paper's example (projected drift, the small stack path: both give Hessian
//! products) and a planar chain of 1000 links (RATTLE, sparse multiplier systems: both give
//! Jacobian entries). docs/performance.md records a run.
//!
//! ```text
//! cargo bench --features autodiff --bench autodiff
//! ```

#[path = "../tests/common/ad_models.rs"]
mod ad_models;

use ad_models::{ad_paper, ad_paper_whole, chain_rattle_pair};
use criterion::{Criterion, criterion_group, criterion_main};
use faer::Col;
use lieflow::models::{PendulumChain, paper};
use lieflow::prelude::*;
use nalgebra::SVector;
use std::hint::black_box;

type V4 = SVector<f64, 4>;

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("paper_projected_drift");
    let x0: V4 = paper::initial_state();
    let (h, con) = ad_paper();
    let ad_sys = System::new(paper::Structure, h, con);
    let mut ad = paper::drift()
        .projected(ad_sys, &x0, ProjectionOptions::default())
        .unwrap();
    let mut hand = paper::drift()
        .projected(paper::system(), &x0, ProjectionOptions::default())
        .unwrap();
    let mut x = x0;
    g.bench_function("hand", |b| {
        b.iter(|| hand.step(black_box(0.1), &mut x).unwrap())
    });
    let mut x = x0;
    g.bench_function("autodiff", |b| {
        b.iter(|| ad.step(black_box(0.1), &mut x).unwrap())
    });
    // The same functions written on the whole state (one element each, as in the README).
    let (h, con) = ad_paper_whole();
    let mut ad_whole = paper::drift()
        .projected(
            System::new(paper::Structure, h, con),
            &x0,
            ProjectionOptions::default(),
        )
        .unwrap();
    let mut x = x0;
    g.bench_function("autodiff_whole_state", |b| {
        b.iter(|| ad_whole.step(black_box(0.1), &mut x).unwrap())
    });
    // Which half costs: the energy by AD with the hand-written circle, and the reverse.
    let (h, con) = ad_paper();
    let mut ad_h = paper::drift()
        .projected(
            System::new(paper::Structure, h, paper::Circle),
            &x0,
            ProjectionOptions::default(),
        )
        .unwrap();
    let mut ad_g = paper::drift()
        .projected(
            System::new(paper::Structure, paper::Energy, con),
            &x0,
            ProjectionOptions::default(),
        )
        .unwrap();
    let mut x = x0;
    g.bench_function("autodiff_energy_only", |b| {
        b.iter(|| ad_h.step(black_box(0.1), &mut x).unwrap())
    });
    let mut x = x0;
    g.bench_function("autodiff_constraint_only", |b| {
        b.iter(|| ad_g.step(black_box(0.1), &mut x).unwrap())
    });
    g.finish();

    let links = 1000;
    let mut g = c.benchmark_group("chain1000_rattle");
    g.sample_size(20);
    let chain = PendulumChain::<f64>::uniform(2, links).unwrap();
    let x0: Col<f64> = chain.at_rest(|i| 0.3 + 0.001 * i as f64);
    let (mut ad, mut hand) = chain_rattle_pair(&chain, links, &x0);
    let mut x = x0.clone();
    g.bench_function("hand", |b| {
        b.iter(|| hand.step(black_box(1e-5), &mut x).unwrap())
    });
    let mut x = x0;
    g.bench_function("autodiff", |b| {
        b.iter(|| ad.step(black_box(1e-5), &mut x).unwrap())
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
