//! Redundant constraints: refused by default with a located error naming one;
//! with `redundant = "drop-dependent"` an over-constrained mechanism runs — the dependent
//! constraint is dropped and reported, and every constraint, the dropped one included, holds at
//! round-off along the motion with the energy conserved to the scheme's accuracy.

use lieflow::scene::{Scene, run};
use lieflow_lab::stress::chain_scene;

fn parallel_cranks(redundant: &str) -> String {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../scenes/parallel_cranks.toml"
    ))
    .unwrap();
    text.replace(
        "redundant = \"drop-dependent\"",
        &format!("redundant = \"{redundant}\""),
    )
    .replace("t_end = 10.0", "t_end = 5.0")
}

#[test]
fn an_over_constrained_mechanism_is_refused_by_default() {
    let err = Scene::from_toml(&parallel_cranks("refuse"), "cranks.toml")
        .and_then(|s| s.compile())
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("redundant") && err.contains("cranks.toml:"),
        "{err}"
    );
    let err = Scene::from_toml(&parallel_cranks("ignore"), "cranks.toml")
        .and_then(|s| s.compile())
        .unwrap_err()
        .to_string();
    assert!(err.contains("integrator.redundant"), "{err}");
}

#[test]
fn dropping_the_dependent_constraint_runs_it_with_every_constraint_held() {
    let scene = Scene::from_toml(&parallel_cranks("drop-dependent"), "cranks.toml").unwrap();
    let mut c = scene.compile().unwrap();
    assert_eq!(
        c.assembly.dropped_constraints.len(),
        1,
        "{:?}",
        c.assembly.dropped_constraints
    );
    assert_eq!(c.assembly.constraint_rows, 5);
    let mut worst = 0.0f64;
    let s = run(c.simulation.as_mut(), &c.plan, &mut |sample| {
        // All six original constraints, the dropped one included.
        let q = &sample.x[..6];
        let d = |a: [f64; 2], b: [f64; 2], l: f64| {
            ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) - l * l).abs() / 2.0
        };
        let b = |i: usize| [q[2 * i], q[2 * i + 1]];
        let g = [
            d(b(0), [0.0, 0.0], 1.0),
            d(b(1), [1.0, 0.0], 1.0),
            d(b(2), [2.0, 0.0], 1.0),
            d(b(0), b(1), 1.0),
            d(b(1), b(2), 1.0),
            d(b(0), b(2), 2.0),
        ];
        worst = g.iter().fold(worst, |a, &v| a.max(v));
    });
    assert_eq!(s.error, None);
    // The scene's Newton tolerance is 16 ε ℓ L (ℓ = 1, L ≈ 2.2), plus rounding: 64 ε ℓ L.
    assert!(
        worst <= 64.0 * f64::EPSILON * 2.3,
        "max |g| over all six: {worst:e}"
    );
    // RATTLE's energy error: bounded, O(h²) (h = 1e-3): 1e-5 of H ≈ 31.
    let e0 = s.energy_initial.unwrap();
    assert!(
        s.max_abs_energy_error.unwrap() <= 1e-5 * e0.abs(),
        "{:?}",
        s.max_abs_energy_error
    );
}

#[test]
fn a_duplicated_rod_is_dropped_on_request() {
    let text = chain_scene(&[1.0; 3], 0.5, None, 0.01, 100)
        .replace(
            "[[effects]]",
            "[[constraints]]\ntype = \"rod\"\nbodies = [\"b0\", \"b1\"]\n[[effects]]",
        )
        .replace(
            "[integrator]",
            "[integrator]\nredundant = \"drop-dependent\"",
        );
    let mut c = Scene::from_toml(&text, "dup.toml")
        .unwrap()
        .compile()
        .unwrap();
    assert_eq!(
        c.assembly.dropped_constraints,
        ["constraints[3] rod 'b0'–'b1'"]
    );
    let s = run(c.simulation.as_mut(), &c.plan, &mut |_| {});
    assert_eq!(s.error, None);
    assert!(s.max_abs_g.unwrap() < 1e-14);
}

#[test]
fn a_dependent_constraint_that_contradicts_the_others_is_not_dropped() {
    // A second rod between b0 and b1 of another length: parallel gradient, violated.
    let text = chain_scene(&[1.0; 3], 0.5, None, 0.01, 100)
        .replace(
            "[[effects]]",
            "[[constraints]]\ntype = \"rod\"\nbodies = [\"b0\", \"b1\"]\nlength = 0.7\n[[effects]]",
        )
        .replace(
            "[integrator]",
            "[integrator]\nredundant = \"drop-dependent\"",
        );
    let err = Scene::from_toml(&text, "contradiction.toml")
        .and_then(|s| s.compile())
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("contradicts") || err.contains("off the constraints"),
        "{err}"
    );
}

// ---------------------------------------------------------------------------------------------
// `DropDependent`: the same for a model written in Rust.

use lieflow::error::SetupError;
use lieflow::models::bricard::{self, Bricard, Joints};
use lieflow::prelude::*;
use lieflow::system::{DropDependent, check_model};
use nalgebra::SVector;

type V4 = SVector<f64, 4>;

/// Three rows on a particle in the plane (q, p): `|q|² = 1` twice (the second scaled by `k`,
/// with target `r²`) and `q_x = 0.6`.
#[derive(Debug)]
struct Rows {
    k: f64,
    r: f64,
}

impl HolonomicConstraint<V4> for Rows {
    fn dim(&self) -> usize {
        3
    }
    fn residual(&self, x: &V4, out: &mut [f64]) {
        let s = x[0] * x[0] + x[1] * x[1];
        out[0] = (s - 1.0) / 2.0;
        out[1] = self.k * (s - self.r * self.r) / 2.0;
        out[2] = x[0] - 0.6;
    }
    fn jacobian_apply(&self, x: &V4, v: &V4, out: &mut [f64]) {
        let d = x[0] * v[0] + x[1] * v[1];
        out[0] = d;
        out[1] = self.k * d;
        out[2] = v[0];
    }
    fn jacobian_transpose_apply_add(&self, x: &V4, mu: &[f64], alpha: f64, out: &mut V4) {
        let c = alpha * (mu[0] + self.k * mu[1]);
        out[0] += c * x[0] + alpha * mu[2];
        out[1] += c * x[1];
    }
}

#[test]
fn drop_dependent_keeps_the_first_of_repeated_rows_and_maps_multipliers_back() {
    let x = V4::new(0.6, 0.8, 0.1, -0.2);
    let c = DropDependent::new(Rows { k: 3.0, r: 1.0 }, &x, 1e-8).unwrap();
    assert_eq!(c.dropped(), &[1]);
    assert_eq!(c.kept(), &[0, 2]);
    assert_eq!(HolonomicConstraint::<V4>::dim(&c), 2);
    // Off the manifold the kept rows are the wrapped rows 0 and 2, and Gᵀμ puts μ on them.
    let y = V4::new(0.7, 0.9, 0.0, 0.0);
    let mut g = [0.0; 2];
    c.residual(&y, &mut g);
    assert_eq!(g, [(0.49 + 0.81 - 1.0) / 2.0, 0.7 - 0.6]);
    let mut f = V4::zeros();
    c.jacobian_transpose_apply_add(&y, &[2.0, 5.0], 1.0, &mut f);
    assert_eq!(f, V4::new(2.0 * 0.7 + 5.0, 2.0 * 0.9, 0.0, 0.0));
    assert_eq!(c.dropped_residual(&y), 3.0 * (0.49 + 0.81 - 1.0) / 2.0);
    // Minimum-norm multipliers: row 1 = 3 row 0, so (a, b) on rows 0, 2 spreads to
    // (a/10, 3a/10, b) — the same force, the least norm.
    let mut full = [0.0; 3];
    c.minimum_norm_multipliers(&y, &[2.0, 5.0], &mut full)
        .unwrap();
    let want = [0.2, 0.6, 5.0];
    for (a, b) in full.iter().zip(want) {
        assert!(
            (a - b).abs() <= 4.0 * f64::EPSILON * 5.0,
            "{full:?} vs {want:?}"
        );
    }
    // Wrong lengths and non-finite input are typed errors, not panics.
    let e = c
        .minimum_norm_multipliers(&y, &[2.0], &mut full)
        .unwrap_err();
    assert!(matches!(e, SetupError::Dimension { .. }), "{e}");
    let e = c
        .minimum_norm_multipliers(&y, &[f64::NAN, 1.0], &mut full)
        .unwrap_err();
    assert!(matches!(e, SetupError::InvalidParameter { .. }), "{e}");
    let e = c
        .minimum_norm_multipliers(&V4::new(f64::NAN, 0.0, 0.0, 0.0), &[1.0, 1.0], &mut full)
        .unwrap_err();
    assert!(
        matches!(e, SetupError::NonFiniteState { component: 0 }),
        "{e}"
    );
}

#[test]
fn drop_dependent_refuses_a_contradicting_row_and_a_bad_tolerance() {
    let x = V4::new(0.6, 0.8, 0.0, 0.0);
    // The same gradient direction but another circle: not redundant, inconsistent.
    let e = DropDependent::new(Rows { k: 1.0, r: 1.1 }, &x, 1e-8).unwrap_err();
    assert!(
        matches!(e, SetupError::InconsistentConstraint { constraint: 1, .. }),
        "{e}"
    );
    for tol in [0.0, 1.0, f64::NAN] {
        let e = DropDependent::new(Rows { k: 1.0, r: 1.0 }, &x, tol).unwrap_err();
        assert!(matches!(e, SetupError::InvalidParameter { .. }), "{e}");
    }
}

#[test]
fn bricard_has_rank_23_and_its_model_checks_out() {
    let x0: faer::Col<f64> = Bricard::initial_state();
    // Without dropping: with the case named (no bracket analysis) and no Jacobian entries (no
    // Gram check) the flow is built; its multiplier system is singular to working precision —
    // the 24th row depends on the others.
    let full = System::new(Canonical, Bricard, Joints);
    let mut unreduced = Bricard::kick()
        .strang(Bricard::drift())
        .projected(
            full,
            &x0,
            ProjectionOptions::default().with_case(Case::Degenerate),
        )
        .unwrap();
    // Whether rounding leaves the 24th pivot just below the singularity threshold (a typed
    // error) or just above it (Newton on the consistent, redundant system converges, to the
    // motion of the reduced system) depends on the order of the solves' roundings.
    let mut x = x0.clone();
    match unreduced.step(1e-3, &mut x) {
        Err(e) => {
            let e = e.to_string();
            assert!(e.contains("singular") && e.contains("pivot 23"), "{e}");
            assert_eq!(x, x0, "a failed step leaves the state as it was");
        }
        Ok(()) => {
            let mut reduced = Bricard::rattle(&x0).unwrap();
            let mut y = x0.clone();
            reduced.step(1e-3, &mut y).unwrap();
            let diff = (&x - &y).norm_max();
            assert!(
                diff <= 1e-12,
                "the redundant step moved differently by {diff:e}"
            );
        }
    }
    let c = Bricard::constraint().unwrap();
    assert_eq!(c.dropped().len(), 1, "rank 23 of {}", bricard::ROWS);
    // Derivatives of the model (natural coordinates) against differences, at a moved state.
    let system = Bricard::system().unwrap();
    let mut x = x0.clone();
    for (i, v) in x.as_mut_slice().iter_mut().enumerate() {
        *v += 0.01 * ((i * 7 % 11) as f64 - 5.0) / 5.0;
    }
    let report = check_model(&system, &x);
    assert!(report.passed(), "{report}");
    // The minimum-norm multipliers carry the same force as the kept ones, with less norm, at a
    // state on the mechanism's motion (off it, all 24 rows are independent).
    // Off the motion (the moved state above) the dropped row is independent: no
    // redistribution keeps the force, and the call says so.
    let kept: Vec<f64> = (0..23).map(|i| ((i * 5 % 7) as f64 - 3.0) / 3.0).collect();
    let mut full = vec![0.0; bricard::ROWS];
    let e = c
        .minimum_norm_multipliers(&x, &kept, &mut full)
        .unwrap_err();
    assert!(
        matches!(e, SetupError::NotDependent { constraint: 23, .. }),
        "{e}"
    );
    let mut flow = Bricard::rattle(&x0).unwrap();
    let mut x = x0.clone();
    for _ in 0..300 {
        flow.step(1e-3, &mut x).unwrap();
    }
    c.minimum_norm_multipliers(&x, &kept, &mut full).unwrap();
    let (mut f_kept, mut f_full) = (faer::Col::<f64>::zeros(48), faer::Col::<f64>::zeros(48));
    c.jacobian_transpose_apply_add(&x, &kept, 1.0, &mut f_kept);
    Joints.jacobian_transpose_apply_add(&x, &full, 1.0, &mut f_full);
    let diff = (0..48)
        .map(|i| (f_kept[i] - f_full[i]).abs())
        .fold(0.0, f64::max);
    let norm = |v: &[f64]| v.iter().map(|a| a * a).sum::<f64>().sqrt();
    // Round-off of G (entries ~1) times |λ| ~ 1, through the normal equations (κ(G_K)² ~ 40).
    assert!(diff <= 1e-12, "force changed by {diff:e}");
    assert!(
        norm(&full) < norm(&kept),
        "{} vs {}",
        norm(&full),
        norm(&kept)
    );
}
