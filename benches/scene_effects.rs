//! What each effect costs: ns/step of `scenes/all_effects.toml` (19 bodies, 11 constraint rows)
//! as its effects are switched on one by one, from the bare constrained bodies (kinetic term and
//! constraints only) to the full scene; and the same chain as a scene and as the built-in
//! `PendulumChain` (the generic scene model against the hand-specialized one, same process);
//! and `scenes/damped_pendulum.toml` (with the model's unit gravity; compiled onto a stack
//! state, as every splitting of one to three bodies is) against the same pendulum written as a
//! Rust model (`models::DampedPendulum`, its exact damped flow projected), nothing observed on
//! either side — the model stepped bare by `Flow::step` and through the crate's `Stepper`, which
//! guards a step as the scene's `Simulation::step` does.
//! A switched-off effect has no term and no sub-flow, so each row adds only its own work.
//!
//! ```text
//! cargo bench --bench scene_effects
//! ```

use criterion::{Criterion, criterion_group, criterion_main};
use faer::Col;
use lieflow::Flow;
use lieflow::flow::FlowExt;
use lieflow::models::DampedPendulum;
use lieflow::models::pendulum_chain::PendulumChain;
use lieflow::prelude::ProjectionOptions;
use lieflow::scene::Scene;
use lieflow::stepper::Stepper;
use nalgebra::SVector;
use std::time::{Duration, Instant};

const ALL_EFFECTS: &str = include_str!("../scenes/all_effects.toml");

/// The kinds in the order they are switched on.
const ORDER: [&str; 6] = ["gravity", "springs", "pair", "trap", "magnetic", "damping"];

fn scene_with(on: usize) -> Scene {
    let mut s = Scene::from_toml(ALL_EFFECTS, "all_effects.toml").expect("parses");
    for (i, flag) in ORDER.iter().enumerate() {
        s.file.flags.set_named(flag, i < on).expect("a flag");
    }
    s
}

/// Times `iters` calls of `step`, in chunks of at most `chunk` from a fresh `setup` (untimed),
/// so that the state stays within the run's first seconds whatever criterion's iteration count.
fn time_chunked<S>(
    iters: u64,
    chunk: u64,
    mut setup: impl FnMut() -> S,
    mut step: impl FnMut(&mut S),
) -> Duration {
    let mut total = Duration::ZERO;
    let mut done = 0;
    while done < iters {
        let mut state = setup();
        let n = chunk.min(iters - done);
        let start = Instant::now();
        for _ in 0..n {
            step(&mut state);
        }
        total += start.elapsed();
        done += n;
    }
    total
}

/// Times `iters` steps of `scene`, recompiled (untimed) every `chunk` steps.
fn time_steps(scene: &Scene, iters: u64, chunk: u64) -> Duration {
    time_chunked(
        iters,
        chunk,
        || scene.compile().expect("compiles").simulation,
        |sim| sim.step().expect("a step"),
    )
}

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("scene_effects");
    group.measurement_time(Duration::from_secs(3));
    for on in 0..=ORDER.len() {
        let scene = scene_with(on);
        let name = if on == 0 {
            "bodies+constraints".to_owned()
        } else {
            format!("+{}", ORDER[on - 1])
        };
        group.bench_function(name, |b| {
            b.iter_custom(|iters| time_steps(&scene, iters, 2000))
        });
    }
    group.finish();

    // The same 64-link chain under gravity, RATTLE, h = 1e-3: scene against built-in model.
    let links = 64;
    let angle = 0.5f64;
    let text = format!(
        "version = 1\ndim = 2\n[[chains]]\nname = \"c\"\nlinks = {links}\ndirection = [{}, {}]\nlength = {}\nmass = 1.0\n[[effects]]\ntype = \"gravity\"\ng = [0.0, -1.0]\n[integrator]\ndt = 1e-3\nt_end = 1.0\ndiagnostics = []\n",
        angle.sin(),
        -angle.cos(),
        1.0 / links as f64
    );
    let scene = Scene::from_toml(&text, "chain.toml").expect("parses");
    let mut group = c.benchmark_group("chain64_step");
    group.bench_function("scene", |b| {
        b.iter_custom(|iters| time_steps(&scene, iters, 1000))
    });
    let chain = PendulumChain::<f64>::uniform(2, links).expect("a chain");
    group.bench_function("built_in_model", |b| {
        b.iter_custom(|iters| {
            time_chunked(
                iters,
                1000,
                || {
                    let x: Col<f64> = chain.at_rest(|_| angle);
                    let flow = chain
                        .kick()
                        .strang(chain.drift())
                        .projected(chain.system(), &x, chain.projection_options())
                        .expect("a projection");
                    (flow, x)
                },
                |(flow, x)| flow.step(1e-3, x).expect("a step"),
            )
        })
    });
    group.finish();

    // The damped pendulum, h = 0.01: the scene (Strang with the exact damping flow, projected)
    // against the model written in Rust (its exact damped flow, projected). The same pendulum
    // on both sides: the model's unit gravity (the scene file has 9.81, whose faster swing
    // takes more multiplier iterations a step at this h), damping 0.5, from 60° at rest.
    let text = include_str!("../scenes/damped_pendulum.toml")
        .replace("g = [0.0, -9.81]", "g = [0.0, -1.0]")
        .replace("[integrator]", "[integrator]\ndiagnostics = []");
    assert!(
        text.contains("g = [0.0, -1.0]"),
        "the scene's gravity is set to the model's"
    );
    let scene = Scene::from_toml(&text, "damped_pendulum.toml").expect("parses");
    let mut group = c.benchmark_group("damped_pendulum_step");
    group.bench_function("scene", |b| {
        b.iter_custom(|iters| time_steps(&scene, iters, 1000))
    });
    // The same scene for a caller that reads no energy books (`lieflow run --off energy`): the
    // damping's account on the motion the rod allows is skipped, as the Rust model books none.
    group.bench_function("scene_unbooked", |b| {
        b.iter_custom(|iters| {
            time_chunked(
                iters,
                1000,
                || {
                    let mut sim = scene.compile().expect("compiles").simulation;
                    sim.read_books(false);
                    sim
                },
                |sim| sim.step().expect("a step"),
            )
        })
    });
    let model = DampedPendulum::try_new(0.5).expect("a model");
    let projected = || {
        let x: SVector<f64, 4> = model.state(std::f64::consts::FRAC_PI_3, 0.0);
        let flow = model
            .free_flow()
            .expect("a flow")
            .projected(model.system(), &x, ProjectionOptions::default())
            .expect("a projection");
        (flow, x)
    };
    group.bench_function("rust_model", |b| {
        b.iter_custom(|iters| {
            time_chunked(iters, 1000, projected, |(flow, x)| {
                flow.step(0.01, x).expect("a step")
            })
        })
    });
    // The same Rust model in the crate's step loop (`Stepper`: time, ledger, the rollback of a
    // non-finite step), as `sim.step()` runs the scene: the difference to `rust_model` is the
    // loop's own cost, the difference to `scene` the compiled scene's.
    group.bench_function("rust_model_stepper", |b| {
        b.iter_custom(|iters| {
            time_chunked(
                iters,
                1000,
                || {
                    let (flow, x) = projected();
                    Stepper::new(flow, x, 0.0, 0.01).expect("a stepper")
                },
                |stepper| stepper.step().expect("a step"),
            )
        })
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
