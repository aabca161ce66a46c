//! The mechanical form (`H = ½ pᵀW⁻¹p + V(q)`, `M = [[0, I], [−I, B]]`, position constraints):
//! `ProjectedMidpoint` eliminates the momenta from its joint Newton system and solves on
//! `(δq, λ_k)` with the model's sparsity (and so does the constrained discrete gradient, tested
//! in `mechanical_discrete_gradient.rs`; a long chain for both here). The same map as the full `n + m` system, the
//! constraint at round-off, and a declaration that contradicts the model refused.

use faer::Col;
use lieflow::prelude::*;
use lieflow::scene::Scene;
use lieflow::system::MechanicalForm;
use std::sync::Arc;

use crate::scene_text;
use scene_text::moving_shell;

type V = Col<f64>;
type Model = Arc<lieflow::scene::SceneModel>;

fn compile(text: &str) -> (Model, V) {
    let c = Scene::from_toml(text, "test.toml")
        .unwrap_or_else(|e| panic!("{e}"))
        .compile()
        .unwrap_or_else(|e| panic!("{e}"));
    let x0 = V::from_fn(c.simulation.state().len(), |i| c.simulation.state()[i]);
    (c.model.expect("a scene of bodies"), x0)
}

/// A Hamiltonian that hides its mechanical form (everything else forwarded): the flows then
/// solve the full `n + m` system.
struct Opaque(Model);

impl Hamiltonian<V> for Opaque {
    fn energy(&self, x: &V) -> f64 {
        self.0.energy(x)
    }
    fn gradient(&self, x: &V, out: &mut V) {
        self.0.gradient(x, out)
    }
    fn hessian_apply(&self, x: &V, v: &V, out: &mut V) -> bool {
        self.0.hessian_apply(x, v, out)
    }
}

/// A Hamiltonian that declares twice its inverse masses.
struct Lying(Model);

impl Hamiltonian<V> for Lying {
    fn energy(&self, x: &V) -> f64 {
        self.0.energy(x)
    }
    fn gradient(&self, x: &V, out: &mut V) {
        self.0.gradient(x, out)
    }
    fn kinetic_inverse_mass(&self, w: &mut [f64]) -> bool {
        let ok = Hamiltonian::<V>::kinetic_inverse_mass(&self.0, w);
        w.iter_mut().for_each(|e| *e *= 2.0);
        ok
    }
}

fn g_norm(model: &Model, x: &V) -> f64 {
    let mut r = vec![0.0; HolonomicConstraint::<V>::dim(model)];
    model.residual(x, &mut r);
    r.iter().fold(0.0, |a, &b| a.max(b.abs()))
}

/// Steps the scene's system around the midpoint rule of `K` from `x0` (momenta set off rest so
/// that the pair forces, damping and magnetic terms all act).
fn run<K: Hamiltonian<V>>(model: &Model, inner: K, x0: &V, h: f64, steps: usize) -> Vec<V> {
    let system = System::new(model.clone(), model.clone(), model.clone());
    let mut flow: ProjectedMidpoint<V, _, _> =
        ProjectedMidpoint::try_new(system, inner, x0, ProjectionOptions::default()).unwrap();
    let mut x = x0.clone();
    let mut out = Vec::new();
    for _ in 0..steps {
        flow.step(h, &mut x).unwrap();
        assert!(g_norm(model, &x) <= 1e-14, "|g| = {:e}", g_norm(model, &x));
        out.push(x.clone());
    }
    out
}

/// Ten particles on spheres of their own (m = 10 > 4: the general path), pair repulsion,
/// damping, a magnetic field, a dashpot: the reduced solve and the full one give the same
/// trajectory (both converge to the increment's rounding; differences grow only by the
/// flow's own error propagation over 60 steps). With a stiff spring added (`k = 10⁴`, so that
/// `(h²/4) k/m = 1`: the Schur iteration without the force Jacobian cannot contract and the
/// reduced solve goes on by Newton on its full matrix) the same holds.
#[test]
fn the_reduced_system_is_the_same_map_as_the_full_one() {
    let fields = "[[effects]]\ntype = \"magnetic\"\nfield = [0.0, 0.0, 0.7]\n\n\
         [[effects]]\ntype = \"dashpot\"\nbodies = [\"p.0\", \"p.3\"]\ncoefficient = 0.3\n";
    let stiff = "[[effects]]\ntype = \"spring\"\nbodies = [\"p.1\", \"p.6\"]\nstiffness = 1e4\n";
    for extra in [fields.to_owned(), format!("{fields}\n{stiff}")] {
        the_same_map(&extra);
    }
}

fn the_same_map(extra: &str) {
    let (model, x0) = moving_shell(extra);
    assert!(
        MechanicalForm::of(
            &System::new(model.clone(), model.clone(), model.clone()),
            &model,
            &x0
        )
        .unwrap()
        .is_some()
    );
    let reduced = run(&model, model.clone(), &x0, 0.02, 60);
    let full = run(&model, Opaque(model.clone()), &x0, 0.02, 60);
    let worst = reduced
        .iter()
        .zip(&full)
        .map(|(a, b)| (a - b).norm_max())
        .fold(0.0, f64::max);
    assert!(worst <= 1e-12, "reduced and full differ by {worst:e}");
}

/// A step the forces do not make stiff needs no force Jacobian: on the moving damped shell at
/// `h = 0.01` the pair Hessian enters the reduced Newton matrix as `(h²/4) W⁻¹∇²V`, about
/// `10⁻⁴` of its identity block, so the Schur iteration (the matrix without it) contracts by
/// about that much per iteration and reaches round-off from the extrapolated predictor (error
/// `O(h⁴)`, the first steps' Euler predictor `O(h²)`) in at most four iterations, with one
/// `m × m` factorization per step; the `λ_{k+1}` projection adds one iteration and at most one
/// factorization. The constrained discrete gradient takes the same path.
#[test]
fn a_step_the_forces_do_not_make_stiff_needs_no_force_jacobian() {
    let (model, x0) = moving_shell("");
    let steps = 200;
    let system = || System::new(model.clone(), model.clone(), model.clone());
    let mut midpoint: ProjectedMidpoint<V, _, _> =
        ProjectedMidpoint::try_new(system(), model.clone(), &x0, ProjectionOptions::default())
            .unwrap();
    let mut dg =
        ConstrainedDiscreteGradient::<V, _>::try_new(system(), &x0, Default::default()).unwrap();
    for flow in [&mut midpoint as &mut dyn Flow<V>, &mut dg] {
        let mut x = x0.clone();
        for _ in 0..steps {
            flow.step(0.01, &mut x).unwrap();
            assert!(
                g_norm(&model, &x) <= 1e-14,
                "|g| = {:e}",
                g_norm(&model, &x)
            );
        }
        let s = flow.stats();
        let per = |v: u64| v as f64 / steps as f64;
        eprintln!(
            "{:.2} iterations, {:.2} factorizations, {:.2} residuals per step",
            per(s.newton_iterations),
            per(s.factorizations),
            per(s.residual_evaluations)
        );
        assert!(per(s.newton_iterations) <= 5.0, "{s:?}");
        assert!(per(s.factorizations) <= 2.0, "{s:?}");
    }
}

/// A declaration the model's own gradient contradicts is refused at construction with a
/// typed error that says what failed.
#[test]
fn a_false_declaration_is_refused() {
    let (model, mut x0) = compile(include_str!("../../scenes/shell_damped.toml"));
    let n = x0.nrows();
    // Momenta that are not zero (the probe of ∇H's momentum part needs them).
    for b in 0..n / 6 {
        x0[n / 2 + 3 * b] = -x0[3 * b + 1];
        x0[n / 2 + 3 * b + 1] = x0[3 * b];
    }
    let system = System::new(model.clone(), model.clone(), model.clone());
    let err = MechanicalForm::of(&system, &Lying(model.clone()), &x0).unwrap_err();
    assert!(
        matches!(&err, SetupError::Declaration { what } if what.contains("W^-1 p")),
        "{err}"
    );
    let err = ProjectedMidpoint::<V, _, _>::try_new(
        system,
        Lying(model),
        &x0,
        ProjectionOptions::default(),
    )
    .unwrap_err();
    assert!(matches!(err, SetupError::Declaration { .. }), "{err}");
}

/// A damped chain of 300 links (gravity: no Hessian; 1200 + 300 unknowns, above the scenes'
/// limit for a dense joint system): the midpoint projection, the discrete gradient and the
/// Petrov–Galerkin scheme (two stages: 2 (600 + 300) unknowns) all take the reduced system and
/// agree with RATTLE (Strang around the exact flight) to RATTLE's `O(h²)` accuracy.
#[test]
fn a_long_damped_chain_runs_the_reduced_schemes_and_agrees_with_rattle() {
    let text = |scheme: &str| {
        format!(
            "version = 1\ndim = 2\n[[chains]]\nname = \"c\"\nlinks = 300\nanchor = [0.0, 0.0]\n\
             direction = [1.0, -1.0]\nlength = 0.01\nmass = 0.01\n\
             [[effects]]\ntype = \"gravity\"\ng = [0.0, -9.81]\n\
             [[effects]]\ntype = \"damping\"\ncoefficient = 0.01\n\
             [integrator]\nscheme = \"{scheme}\"\ndt = 1e-4\nt_end = 0.01\n"
        )
    };
    let run_scene = |scheme: &str| {
        let mut c = Scene::from_toml(&text(scheme), "chain.toml")
            .unwrap()
            .compile()
            .unwrap();
        for _ in 0..c.plan.steps {
            c.simulation.step().unwrap();
        }
        (c.simulation.state().to_vec(), c.assembly.scheme)
    };
    let (strang, _) = run_scene("strang");
    for (scheme, name) in [
        ("midpoint", "implicit midpoint"),
        ("discrete-gradient", "discrete gradient"),
        ("petrov-galerkin", "Petrov–Galerkin"),
    ] {
        let (x, assembled) = run_scene(scheme);
        assert!(assembled.contains(name), "{assembled}");
        let diff = x
            .iter()
            .zip(&strang)
            .fold(0.0f64, |a, (x, y)| a.max((x - y).abs()));
        // All are O(h²) accurate (RATTLE; Petrov–Galerkin of order 4 better) at h = 1e-4 over
        // 100 steps of a chain moving at ~1 m/s.
        assert!(diff < 1e-6, "{scheme} and RATTLE differ by {diff:e}");
    }
}

/// A 3000-link chain falling from rest: the first step has no past steps to predict from. For
/// the Petrov–Galerkin scheme its explicit Euler start satisfies the momentum rows exactly, so
/// the first Schur update grows the residual on its way to the root (before the first update
/// was let grow, that step went to the full Newton, which did not converge). The first steps of
/// every implicit scheme converge and keep the chain on its constraints.
#[test]
fn the_first_steps_of_a_long_chain_converge() {
    for (scheme, order) in [
        ("midpoint", 2),
        ("discrete-gradient", 2),
        ("petrov-galerkin", 4),
        ("petrov-galerkin", 6),
    ] {
        let text = format!(
            "version = 1\ndim = 2\n[[chains]]\nname = \"c\"\nlinks = 3000\nanchor = [0.0, 0.0]\n\
             direction = [1.0, -1.0]\nlength = 0.01\nmass = 0.01\n\
             [[effects]]\ntype = \"gravity\"\ng = [0.0, -9.81]\n\
             [[effects]]\ntype = \"damping\"\ncoefficient = 0.01\n\
             [integrator]\nscheme = \"{scheme}\"\n{}dt = 1e-4\nt_end = 3e-4\n",
            if scheme == "petrov-galerkin" {
                format!("order = {order}\n")
            } else {
                String::new()
            }
        );
        let mut c = Scene::from_toml(&text, "chain.toml")
            .unwrap()
            .compile()
            .unwrap();
        for step in 0..c.plan.steps {
            c.simulation
                .step()
                .unwrap_or_else(|e| panic!("{scheme} {order}, step {step}: {e}"));
        }
        let model = c.model.as_ref().unwrap();
        let x = c.simulation.state().to_vec();
        let x = faer::Col::<f64>::from_fn(x.len(), |i| x[i]);
        let g = g_norm(model, &x);
        let q_max = x.iter().fold(0.0f64, |a, &b| a.max(b.abs()));
        // ½(|q_i − q_j|² − ℓ²) with coordinates up to ~21: q_i − q_j rounds by ε q_max, which
        // moves g by that times ℓ; a few such roundings.
        let bound = 16.0 * f64::EPSILON * q_max * 0.01;
        eprintln!("{scheme} {order}: |g| = {g:e} (bound {bound:e})");
        assert!(g <= bound, "{scheme} {order}: |g| = {g:e} > {bound:e}");
    }
}

/// The Petrov–Galerkin scheme's reduced solve (positions eliminated, the stages' momenta and
/// multipliers by the Schur iteration) is the same map as its dense Newton on all `k(n + m)`
/// unknowns, which it takes when the Hamiltonian hides its mechanical form: both converge to
/// the stages' rounding, so 60 steps of the moving shell (pair forces, damping, a magnetic
/// field, a dashpot) differ only by its propagation. A model without a mechanical form above
/// the dense limit is refused with a typed error.
#[test]
fn the_reduced_petrov_galerkin_step_is_the_same_map_as_the_dense_one() {
    use lieflow::flow::PetrovGalerkin;
    let fields = "[[effects]]\ntype = \"magnetic\"\nfield = [0.0, 0.0, 0.7]\n\n\
         [[effects]]\ntype = \"dashpot\"\nbodies = [\"p.0\", \"p.3\"]\ncoefficient = 0.3\n";
    let (model, x0) = moving_shell(fields);
    for order in [4, 6] {
        let mut reduced: PetrovGalerkin<V, _> = PetrovGalerkin::try_new(
            System::new(model.clone(), model.clone(), model.clone()),
            &x0,
            order,
            ProjectionOptions::default(),
        )
        .unwrap();
        let mut dense: PetrovGalerkin<V, _> = PetrovGalerkin::try_new(
            System::new(model.clone(), Opaque(model.clone()), model.clone()),
            &x0,
            order,
            ProjectionOptions::default(),
        )
        .unwrap();
        assert!(format!("{reduced:?}").contains("mechanical: true"));
        assert!(format!("{dense:?}").contains("mechanical: false"));
        let (mut a, mut b) = (x0.clone(), x0.clone());
        let mut worst = 0.0f64;
        for _ in 0..60 {
            reduced.step(0.02, &mut a).unwrap();
            dense.step(0.02, &mut b).unwrap();
            worst = worst.max((&a - &b).norm_max());
            // The energy the hidden projection removes, `½|δp|²_W` with `δp = Gᵀν` (the
            // projected momenta's `G W⁻¹ p` at its tolerance): the reduced step's kinetic
            // difference against the dense step's difference of two energies, which rounds
            // at a few `ε|H|`. The states' difference `d` moves `δp` by about `d` (unit
            // masses), so the energy by `|δp| d`. Up to 1.2e-13 here: a sign or a factor
            // wrong in either is well above this bound (`16ε|H|` ≈ 5e-14).
            let (ra, rb) = (
                reduced.last_dissipation().unwrap(),
                dense.last_dissipation().unwrap(),
            );
            let d = (&a - &b).norm_max();
            let tol = 16.0 * f64::EPSILON * ra.after.abs().max(1.0)
                + 4.0 * (2.0 * ra.projection.abs()).sqrt() * d;
            assert!(ra.projection >= -tol, "projection {:e}", ra.projection);
            assert!(
                (ra.projection - rb.projection).abs() <= tol,
                "order {order}: projection {:e} (reduced) against {:e} (dense)",
                ra.projection,
                rb.projection
            );
            assert!(
                g_norm(&model, &a) <= 1e-14,
                "|g| = {:e}",
                g_norm(&model, &a)
            );
        }
        eprintln!("order {order}: reduced and dense differ by {worst:e}");
        assert!(
            worst <= 1e-12,
            "order {order}: reduced and dense differ by {worst:e}"
        );
    }
    // 300 links: k (n + m) = 2 (1200 + 300) unknowns for a dense Newton.
    let chain = "version = 1\ndim = 2\n[[chains]]\nname = \"c\"\nlinks = 300\n\
                 anchor = [0.0, 0.0]\ndirection = [1.0, -1.0]\nlength = 0.01\nmass = 0.01\n\
                 [integrator]\ndt = 1e-4\nt_end = 0.01\n";
    let (model, x0) = compile(chain);
    let err = PetrovGalerkin::<V, _>::try_new(
        System::new(model.clone(), Opaque(model.clone()), model.clone()),
        &x0,
        4,
        ProjectionOptions::default(),
    )
    .unwrap_err();
    assert!(matches!(err, SetupError::Scheme { .. }), "{err}");
    assert!(err.to_string().contains("3000 unknowns"), "{err}");
}
