//! The model checker: the built-in models pass it at arbitrary states; a model with a
//! wrong gradient, Hessian, `Gᵀ` (accumulated or direct), Jacobian entry or an energy-creating
//! structure fails the check that names it; the hints are reported.

use lieflow::linalg::Sink;
use lieflow::models::{
    DampedPendulum, PendulumChain, RigidBody, SphereParticles, SphericalPendulum, paper,
};
use lieflow::prelude::*;
use lieflow::system::{LiePoissonSo3, Unconstrained, check_model};
use nalgebra::{DVector, SVector};

type V4 = SVector<f64, 4>;

fn dense(n: usize, seed: f64) -> DVector<f64> {
    DVector::from_fn(n, |i, _| {
        ((i as f64 + seed) * 0.618_033_988_749_895).fract() - 0.3
    })
}

#[test]
fn the_built_in_models_pass() {
    let r = check_model(&paper::system(), &V4::new(0.6, 0.8, -0.3, 0.2));
    assert!(r.passed(), "paper:\n{r}");
    // The §2 scheme's H + μ g in closed form: on g = 0 its gradient is the energy's, and its
    // Hessian product is the derivative of that gradient.
    let modified = System::new(paper::Structure, paper::modified_energy(), paper::Circle);
    let r = check_model(&modified, &V4::new(0.6, 0.8, -0.3, 0.2));
    assert!(r.passed() && r.hints.hessian, "paper, modified:\n{r}");
    let pend = SphericalPendulum::try_new(1.5, 0.7, 9.81).unwrap();
    let x = SVector::<f64, 6>::from([0.3, -0.2, -0.6, 0.1, 0.4, -0.2]);
    let r = check_model(&pend.system(), &x);
    assert!(r.passed(), "spherical pendulum:\n{r}");
    let damped = DampedPendulum::try_new(0.4).unwrap();
    let r = check_model(&damped.system(), &V4::new(0.6, -0.8, 0.3, 0.1));
    assert!(r.passed() && r.hints.dissipative, "damped pendulum:\n{r}");
    let chain = PendulumChain::<f64>::uniform(3, 40).unwrap();
    let r = check_model(&chain.system(), &dense(chain.state_len(), 1.0));
    assert!(r.passed() && r.hints.jacobian_entries, "chain:\n{r}");
    // A planar chain with extra rods (one to the pin, one closing a loop): its direct `Gᵀ μ`
    // walks the links and then accumulates the extra rods.
    let looped = PendulumChain::<f64>::uniform(2, 12)
        .unwrap()
        .with_rod(None, 5, 0.4)
        .unwrap()
        .with_rod(Some(2), 9, 0.3)
        .unwrap();
    let r = check_model(&looped.system(), &dense(looped.state_len(), 1.0));
    assert!(r.passed(), "chain with extra rods:\n{r}");
    let shells = SphereParticles::<f64>::row(12, 3.0).unwrap();
    let r = check_model(&shells.system(), &dense(shells.state_len(), 2.0));
    assert!(r.passed(), "sphere particles:\n{r}");
    let body = RigidBody::<f64>::gni();
    let sys = System::new(LiePoissonSo3, body, Unconstrained);
    let r = check_model(&sys, &SVector::<f64, 3>::new(0.3, -0.8, 0.5));
    assert!(
        r.passed() && r.hints.structure_derivative,
        "rigid body:\n{r}"
    );
}

/// A pendulum in the paper's coordinates whose parts can each be made wrong.
#[derive(Clone, Copy, Default)]
struct Faulty {
    gradient: f64,
    hessian: f64,
    transpose: f64,
    entries: f64,
    friction: f64,
    declared: bool,
    /// `Gᵀ μ` written directly but leaving the entries it does not set as they were.
    stale: bool,
}

impl Hamiltonian<V4> for Faulty {
    fn energy(&self, x: &V4) -> f64 {
        0.5 * (x[2] * x[2] + x[3] * x[3]) + 9.81 * x[1]
    }
    fn gradient(&self, x: &V4, out: &mut V4) {
        *out = V4::new(0.0, 9.81 + self.gradient, x[2], x[3]);
    }
    fn hessian_apply(&self, _x: &V4, v: &V4, out: &mut V4) -> bool {
        *out = V4::new(self.hessian * v[0], 0.0, v[2], v[3]);
        true
    }
}

impl HolonomicConstraint<V4> for Faulty {
    fn dim(&self) -> usize {
        1
    }
    fn residual(&self, x: &V4, out: &mut [f64]) {
        out[0] = 0.5 * (x[0] * x[0] + x[1] * x[1] - 1.0);
    }
    fn jacobian_apply(&self, x: &V4, v: &V4, out: &mut [f64]) {
        out[0] = x[0] * v[0] + x[1] * v[1];
    }
    fn jacobian_transpose_apply_add(&self, x: &V4, mu: &[f64], alpha: f64, out: &mut V4) {
        out[0] += alpha * mu[0] * (x[0] + self.transpose);
        out[1] += alpha * mu[0] * x[1];
    }
    fn jacobian_transpose_apply(&self, x: &V4, mu: &[f64], out: &mut V4) {
        out[0] = mu[0] * (x[0] + self.transpose);
        out[1] = mu[0] * x[1];
        if !self.stale {
            out[2] = 0.0;
            out[3] = 0.0;
        }
    }
    fn jacobian_entries(&self, x: &V4, sink: &mut dyn Sink<f64>) -> bool {
        sink.add(0, 0, x[0]);
        sink.add(0, 1, x[1] + self.entries);
        true
    }
}

impl StructureMatrix<V4> for Faulty {
    fn apply_add(&self, _x: &V4, v: &V4, alpha: f64, out: &mut V4) {
        // Canonical J, plus `friction` on the momenta: negative friction creates energy.
        out[0] += alpha * v[2];
        out[1] += alpha * v[3];
        out[2] += alpha * (-v[0] - self.friction * v[2]);
        out[3] += alpha * (-v[1] - self.friction * v[3]);
    }
    fn is_constant(&self) -> bool {
        true
    }
    fn is_dissipative(&self) -> bool {
        self.declared
    }
}

fn failures(f: Faulty) -> Vec<&'static str> {
    let sys = System::new(f, f, f);
    let r = check_model(&sys, &V4::new(0.6, -0.8, 0.3, 0.1));
    r.failures().map(|c| c.what).collect()
}

#[test]
fn each_wrong_part_is_named() {
    assert_eq!(failures(Faulty::default()), Vec::<&str>::new());
    assert_eq!(
        failures(Faulty {
            gradient: 1e-3,
            ..Default::default()
        }),
        ["gradient vs energy differences"]
    );
    assert_eq!(
        failures(Faulty {
            hessian: 0.5,
            ..Default::default()
        }),
        ["Hessian product vs gradient differences"]
    );
    assert_eq!(
        failures(Faulty {
            transpose: 0.1,
            ..Default::default()
        }),
        ["<G v, mu> vs <v, G^T mu>"]
    );
    assert_eq!(
        failures(Faulty {
            entries: 0.1,
            ..Default::default()
        }),
        ["Jacobian entries vs G v"]
    );
    // Friction the structure does not declare: compositions would run it backwards.
    assert_eq!(
        failures(Faulty {
            friction: 0.2,
            ..Default::default()
        }),
        ["is_dissipative() where v^T M v < 0"]
    );
    // Declared dissipative, negative friction creates energy.
    assert_eq!(
        failures(Faulty {
            friction: -0.2,
            declared: true,
            ..Default::default()
        }),
        ["v^T M v <= 0 (no energy created)"]
    );
    // A direct Gᵀ μ that forgets to clear what it does not set.
    assert_eq!(
        failures(Faulty {
            stale: true,
            ..Default::default()
        }),
        ["M v, G^T mu written directly vs accumulated"]
    );
}

#[test]
fn the_hints_and_what_they_enable_are_reported() {
    let r = check_model(&paper::system(), &V4::new(0.6, 0.8, -0.3, 0.2));
    assert!(!r.hints.jacobian_entries);
    assert!(r.notes.iter().any(|n| n.contains("indefinite")), "{r}");
    assert!(
        r.notes.iter().any(|n| n.contains("no Jacobian entries")),
        "{r}"
    );
    let f = Faulty::default();
    let r = check_model(&System::new(f, f, f), &V4::new(0.6, -0.8, 0.3, 0.1));
    assert!(r.hints.hessian && r.hints.jacobian_entries && r.hints.constant_structure);
    let text = r.to_string();
    assert!(
        text.contains("ok   gradient vs energy differences"),
        "{text}"
    );
}
