//! The blocks from Jacobian entries against the products through the model that they replace.

use super::super::problem::{Problem, Scratch};
use super::super::reduced::Stages;
use super::super::tables::Tables;
use super::ConstraintBlocks;
use crate::flow::schur::ReducedBlocks;
use crate::linalg::Triplets;
use crate::models::pendulum_chain::ChainLinks;
use crate::models::{PendulumChain, SphereParticles};
use crate::system::{Canonical, HolonomicConstraint, Model, System};
use nalgebra::DVector;

/// A deterministic, irregular value for index `i` of sequence `seed`, in `[−1, 1]`.
fn wave(seed: usize, i: usize) -> f64 {
    (1.7 * seed as f64 + 0.37 * i as f64 + 0.013 * (i * i) as f64).sin()
}

/// The step problem of `system` from `x0` at `h = 0.03`, on the manifold (`g0`).
fn problem<'a, Sys>(
    x0: &'a DVector<f64>,
    tables: &'a Tables<f64>,
    w: &'a mut Scratch<DVector<f64>>,
    system: &'a Sys,
    g0: &'a [f64],
) -> Problem<'a, DVector<f64>, Sys> {
    Problem {
        h: 0.03,
        x: x0,
        tables,
        w,
        system,
        g0,
        noise: 0.0,
        floor: 0.0,
        forcing: None,
    }
}

/// The reduced problem over `problem` (no momentum block: the products read none), with or
/// without the blocks.
fn stages<'a, 'b, Sys>(
    problem: &'b mut Problem<'a, DVector<f64>, Sys>,
    inv_mass: &'b [f64],
    u: &'b mut [f64],
    blocks: Option<&'b mut ConstraintBlocks<f64>>,
) -> Stages<'a, 'b, DVector<f64>, Sys> {
    Stages {
        full: problem,
        w: inv_mass,
        u,
        momentum_block: &[],
        blocks,
        keep: false,
    }
}

/// What the blocks give and what the model passes give for `C v`, `G v` and `S = G D⁻¹ C`:
/// `(blocks, model)` for each, `S` dense.
struct Both {
    columns: [Vec<f64>; 2],
    rows: [Vec<f64>; 2],
    schur: [Vec<f64>; 2],
}

/// `by_entries`: the blocks' values through the listed entries rather than by colour.
fn both<Sys: Model<DVector<f64>>>(
    system: &Sys,
    x0: &DVector<f64>,
    k: usize,
    by_entries: bool,
) -> Both {
    let (n, m) = (x0.len(), system.constraint().dim());
    let nq = n / 2;
    let s = k + 2;
    let tables = Tables::<f64>::new(k, s);
    let mut blocks = ConstraintBlocks::new(system.constraint(), x0, nq, &tables)
        .expect("the model lists its Jacobian entries");
    if by_entries {
        blocks = blocks.by_entries();
    }
    let mut w = Scratch::new(x0, k, s, m);
    // Quadrature points off x0, as within a step.
    for (r, x) in w.xs.iter_mut().enumerate() {
        *x = x0.clone();
        x.iter_mut()
            .enumerate()
            .for_each(|(i, v)| *v += 0.05 * wave(r, i));
    }
    let inv_mass: Vec<f64> = (0..nq)
        .map(|d| 1.0 / (1.0 + 0.3 * wave(7, d).abs()))
        .collect();
    let g0 = vec![0.0; m];
    let mut problem = problem(x0, &tables, &mut w, system, &g0);
    let mut u = vec![0.0; k * (n + m)];
    let vm: Vec<f64> = (0..k * m).map(|i| wave(3, i)).collect();
    let vq: Vec<f64> = (0..k * nq).map(|i| wave(5, i)).collect();
    // D_d⁻¹: near the identity, as for a resolved step.
    let inv_d: Vec<f64> = (0..nq * k * k)
        .map(|e| f64::from(u8::from((e % (k * k)).is_multiple_of(k + 1))) + 0.2 * wave(9, e))
        .collect();
    let mut results: Vec<(Vec<f64>, Vec<f64>, Vec<f64>)> = Vec::new();
    for with_blocks in [true, false] {
        let blocks = if with_blocks { Some(&mut blocks) } else { None };
        let mut stages = stages(&mut problem, &inv_mass, &mut u, blocks);
        let mut columns = vec![0.5; k * nq];
        stages.multiplier_columns_add(&vm, &mut columns);
        let mut rows = vec![0.0; k * m];
        stages.constraint_rows(&vq, &mut rows);
        let mut schur = vec![0.0; k * m * k * m];
        if with_blocks {
            let mut entries = Triplets::default();
            assert!(stages.schur_complement_add(&inv_d, &mut entries));
            for (i, j, v) in entries.entries {
                schur[i * k * m + j] += v;
            }
        } else {
            assert!(!stages.schur_complement_add(&inv_d, &mut Triplets::default()));
            // Column by column: G D⁻¹ C e_j.
            let (mut unit, mut col) = (vec![0.0; k * m], vec![0.0; k * m]);
            for j in 0..k * m {
                unit.iter_mut().for_each(|v| *v = 0.0);
                unit[j] = 1.0;
                let mut c = vec![0.0; k * nq];
                stages.multiplier_columns_add(&unit, &mut c);
                let mut dc = vec![0.0; k * nq];
                for d in 0..nq {
                    for i in 0..k {
                        dc[d * k + i] = (0..k)
                            .map(|l| inv_d[d * k * k + i * k + l] * c[d * k + l])
                            .sum();
                    }
                }
                stages.constraint_rows(&dc, &mut col);
                for (i, &v) in col.iter().enumerate() {
                    schur[i * k * m + j] = v;
                }
            }
        }
        results.push((columns, rows, schur));
    }
    let (b, p) = (results.remove(0), results.remove(0));
    Both {
        columns: [b.0, p.0],
        rows: [b.1, p.1],
        schur: [b.2, p.2],
    }
}

/// `max |a − b| / max |b|`.
fn relative(pair: &[Vec<f64>; 2]) -> f64 {
    let scale = pair[1].iter().fold(0.0f64, |s, v| s.max(v.abs()));
    assert!(scale > 0.0, "a product that vanishes tests nothing");
    let diff = pair[0]
        .iter()
        .zip(&pair[1])
        .fold(0.0f64, |s, (a, b)| s.max((a - b).abs()));
    diff / scale
}

/// Both sum the same `O(s k²)` products of `O(1)` factors per entry, in another order: they
/// agree to a few hundred roundings.
const TOL: f64 = 256.0 * f64::EPSILON;

fn check(both: &Both) {
    for (what, pair) in [
        ("C v", &both.columns),
        ("G v", &both.rows),
        ("S", &both.schur),
    ] {
        let e = relative(pair);
        assert!(e <= TOL, "{what}: blocks and model passes differ by {e:e}");
    }
}

#[test]
fn blocks_agree_with_model_passes_on_particles_on_spheres() {
    // Block-diagonal S: each constraint touches its own particle.
    let model = SphereParticles::<f64>::row(4, 0.5).unwrap();
    let x0: DVector<f64> = model.at_rest(|i| 0.3 + 0.2 * i as f64, |i| 0.1 * i as f64);
    for (k, by_entries) in [(1, false), (2, false), (3, false), (4, false), (2, true)] {
        check(&both(&model.system(), &x0, k, by_entries));
    }
}

#[test]
fn blocks_agree_with_model_passes_on_a_chain() {
    // Banded S: consecutive rods share a body, so off-diagonal blocks (b ≠ a) appear.
    let model = PendulumChain::<f64>::uniform(3, 5).unwrap();
    let x0: DVector<f64> = model.at_rest(|i| 0.2 + 0.1 * i as f64);
    for (k, by_entries) in [(1, false), (2, false), (3, false), (4, false), (2, true)] {
        let both = both(&model.system(), &x0, k, by_entries);
        let km = k * model.constraints();
        let off = (0..km)
            .flat_map(|i| (0..km).map(move |j| (i, j)))
            .filter(|&(i, j)| i / k != j / k)
            .any(|(i, j)| both.schur[1][i * km + j] != 0.0);
        assert!(off, "the chain's S couples neighbouring rods");
        check(&both);
    }
}

/// A scene's entries: the blocks take them at every point, by colour and entry by entry (no
/// fallback to the model passes), and agree with those passes.
#[cfg(feature = "scene")]
#[test]
fn blocks_agree_with_model_passes_on_scenes() {
    let chain = include_str!("../../../scenes/chain1000.toml").replace("links = 1000", "links = 8");
    for text in [include_str!("../../../scenes/shell_damped.toml"), &chain] {
        let (model, x0) = super::super::test_scenes::scene(text);
        let (k, nq) = (2, x0.len() / 2);
        let tables = Tables::<f64>::new(k, k + 2);
        let constraint = Model::<DVector<f64>>::constraint(&model);
        let mut blocks = ConstraintBlocks::new(constraint, &x0, nq, &tables)
            .expect("a scene of more than four constraints lists its entries");
        // Spheres: one colour; a chain's rods share a body with their neighbours: two.
        assert!((1..=2).contains(&blocks.colors()), "{}", blocks.colors());
        let xs = vec![x0.clone(); k + 2];
        let mut scratch = x0.clone();
        assert!(blocks.refresh(constraint, &xs, 0.01, &vec![1.0; nq], &mut scratch));
        let mut entries = blocks.clone().by_entries();
        entries.stale();
        assert!(entries.refresh(constraint, &xs, 0.01, &vec![1.0; nq], &mut scratch));
        check(&both(&model, &x0, k, false));
        check(&both(&model, &x0, k, true));
    }
}

/// A chain of five links in 3-D, its order-4 stages (`s = 4`), two sets of unknowns `z1`, `z2`
/// and multipliers `vm` to apply the columns to: what the tests of the blocks' points run on.
struct Chain {
    system: System<Canonical, PendulumChain<f64>, ChainLinks<f64>>,
    x0: DVector<f64>,
    tables: Tables<f64>,
    w: Scratch<DVector<f64>>,
    blocks: ConstraintBlocks<f64>,
    inv_mass: Vec<f64>,
    g0: Vec<f64>,
    u: Vec<f64>,
    z1: Vec<f64>,
    z2: Vec<f64>,
    vm: Vec<f64>,
    out: Vec<f64>,
    /// `k n_q`: the length of `C v`.
    columns: usize,
}

impl Chain {
    fn new() -> Self {
        let model = PendulumChain::<f64>::uniform(3, 5).unwrap();
        let x0: DVector<f64> = model.at_rest(|i| 0.2 + 0.1 * i as f64);
        let system = model.system();
        let (n, m, k) = (x0.len(), model.constraints(), 2);
        let (nq, s) = (n / 2, k + 2);
        let tables = Tables::<f64>::new(k, s);
        let constraint = Model::<DVector<f64>>::constraint(&system);
        let blocks = ConstraintBlocks::new(constraint, &x0, nq, &tables).unwrap();
        let dim = k * (nq + m);
        Self {
            w: Scratch::new(&x0, k, s, m),
            blocks,
            inv_mass: vec![1.0; nq],
            g0: vec![0.0; m],
            u: vec![0.0; k * (n + m)],
            z1: (0..dim).map(|i| 0.3 * wave(11, i)).collect(),
            z2: (0..dim).map(|i| 0.3 * wave(13, i)).collect(),
            vm: (0..k * m).map(|i| wave(3, i)).collect(),
            out: vec![0.0; dim],
            columns: k * nq,
            system,
            x0,
            tables,
        }
    }
}

/// `C v` by the stages' products (`len` entries).
fn columns<Sys: Model<DVector<f64>>>(
    stages: &mut Stages<'_, '_, DVector<f64>, Sys>,
    v: &[f64],
    len: usize,
) -> Vec<f64> {
    let mut c = vec![0.0; len];
    stages.multiplier_columns_add(v, &mut c);
    c
}

/// The blocks follow the points of the last residual: filled at one `z`, a residual at
/// another makes the next product fill them again (a product that kept the first points
/// would differ by the points' change).
#[test]
fn products_follow_the_last_residual() {
    use crate::nonlinear::NonlinearProblem;
    let mut c = Chain::new();
    let mut problem = problem(&c.x0, &c.tables, &mut c.w, &c.system, &c.g0);
    let mut both = [Vec::new(), Vec::new()];
    for (with_blocks, columns_at_z2) in [true, false].into_iter().zip(&mut both) {
        let blocks = if with_blocks {
            Some(&mut c.blocks)
        } else {
            None
        };
        let mut stages = stages(&mut problem, &c.inv_mass, &mut c.u, blocks);
        stages.residual(&c.z1, &mut c.out).unwrap();
        columns(&mut stages, &c.vm, c.columns);
        stages.residual(&c.z2, &mut c.out).unwrap();
        *columns_at_z2 = columns(&mut stages, &c.vm, c.columns);
    }
    let e = relative(&both);
    assert!(e <= TOL, "blocks at stale points: {e:e}");
}

/// Kept (`keep_matrix(true)`, the Schur iteration on a kept complement), the blocks stay those
/// of their last fill while a residual moves the points, exactly; released, they follow the
/// next residual's points again.
#[test]
fn kept_blocks_keep_the_points_of_their_fill() {
    use crate::nonlinear::NonlinearProblem;
    let mut c = Chain::new();
    let mut problem = problem(&c.x0, &c.tables, &mut c.w, &c.system, &c.g0);
    let mut stages = stages(&mut problem, &c.inv_mass, &mut c.u, Some(&mut c.blocks));
    stages.residual(&c.z1, &mut c.out).unwrap();
    let first = columns(&mut stages, &c.vm, c.columns);
    stages.keep_matrix(true);
    stages.residual(&c.z2, &mut c.out).unwrap();
    let kept = columns(&mut stages, &c.vm, c.columns);
    assert_eq!(kept, first, "kept blocks at the first points");
    stages.keep_matrix(false);
    let second = columns(&mut stages, &c.vm, c.columns);
    stages.residual(&c.z2, &mut c.out).unwrap();
    assert_eq!(columns(&mut stages, &c.vm, c.columns), second);
    let e = relative(&[first, second]);
    assert!(e > 1e3 * TOL, "the points moved the blocks: {e:e}");
}

/// On the damped shell the stages' solves converge in one update from the predictor, so the
/// next step keeps the factored Schur complement: after the first steps (no predictor yet) a
/// factorization follows only a solve that needed a second update, or one that stalled on the
/// kept complement, each of which adds at least one update beyond one a step. With a fresh
/// complement every step there would be one factorization a step.
#[cfg(feature = "scene")]
#[test]
fn the_shell_keeps_its_schur_complement_across_steps() {
    use crate::flow::{Flow, PetrovGalerkin, ProjectionOptions};
    let (model, x0) =
        super::super::test_scenes::scene(include_str!("../../../scenes/shell_damped.toml"));
    let mut flow: PetrovGalerkin<DVector<f64>, _> =
        PetrovGalerkin::try_new(model, &x0, 4, ProjectionOptions::default()).unwrap();
    let mut x = x0;
    let steps = 400u64;
    for _ in 0..steps {
        flow.step(0.01, &mut x).unwrap();
    }
    let st = flow.stats();
    let extra = st.newton_iterations - st.newton_solves;
    assert!(st.factorizations <= 1 + 2 * extra, "{st:?}");
    assert!(st.factorizations <= steps / 4, "{st:?}");
    eprintln!("{st:?}");
}
