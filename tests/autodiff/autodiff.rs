//! Automatic derivatives (feature `autodiff`): the built-in models written once as
//! elements give the same gradients, Hessian products, `G v`, `Gᵀ μ` and Jacobian entries as
//! their hand-written derivatives (to 1e-13 relative), pass `check_model`, and run the same
//! trajectories.

use crate::ad_models;

use ad_models::{ad_chain, ad_paper, ad_paper_whole, chain_rattle_pair};
use lieflow::autodiff::{AdConstraint, AdHamiltonian, DualNum, Element};
use lieflow::linalg::Triplets;
use lieflow::models::{PendulumChain, RigidBody, SphereParticles, SphericalPendulum, paper};
use lieflow::prelude::*;
use lieflow::system::{LiePoissonSo3, Unconstrained, check_model};
use nalgebra::{DVector, SVector};

type V4 = SVector<f64, 4>;
type D = DVector<f64>;

fn dense(n: usize, seed: f64) -> D {
    D::from_fn(n, |i, _| {
        ((i as f64 + seed) * 0.618_033_988_749_895).fract() - 0.3
    })
}

/// `|a − b|∞ ≤ 1e-13 (1 + |b|∞)`.
fn close(a: &[f64], b: &[f64], what: &str) {
    let scale = 1.0 + b.iter().fold(0.0f64, |s, v| s.max(v.abs()));
    let err = a
        .iter()
        .zip(b)
        .fold(0.0f64, |s, (x, y)| s.max((x - y).abs()));
    assert!(err <= 1e-13 * scale, "{what}: {err:e} (scale {scale:e})");
}

/// Compares every derivative of `(h_ad, c_ad)` with `(h, c)` at `x` along `v`.
fn same_derivatives<V: Vector<Real = f64>>(
    h_ad: &impl Hamiltonian<V>,
    h: &impl Hamiltonian<V>,
    c_ad: &impl HolonomicConstraint<V>,
    c: &impl HolonomicConstraint<V>,
    x: &V,
    v: &V,
    what: &str,
) {
    assert!((h_ad.energy(x) - h.energy(x)).abs() <= 1e-13 * (1.0 + h.energy(x).abs()));
    let (mut a, mut b) = (x.zeros_like(), x.zeros_like());
    h_ad.gradient(x, &mut a);
    h.gradient(x, &mut b);
    close(a.as_slice(), b.as_slice(), &format!("{what}: gradient"));
    if h.hessian_apply(x, v, &mut b) {
        assert!(h_ad.hessian_apply(x, v, &mut a));
        close(
            a.as_slice(),
            b.as_slice(),
            &format!("{what}: Hessian product"),
        );
    }
    let m = c.dim();
    assert_eq!(c_ad.dim(), m);
    if m == 0 {
        return;
    }
    let (mut ga, mut gb) = (vec![0.0; m], vec![0.0; m]);
    c_ad.residual(x, &mut ga);
    c.residual(x, &mut gb);
    close(&ga, &gb, &format!("{what}: g"));
    c_ad.jacobian_apply(x, v, &mut ga);
    c.jacobian_apply(x, v, &mut gb);
    close(&ga, &gb, &format!("{what}: G v"));
    let mu: Vec<f64> = (0..m).map(|i| (i as f64 * 0.37).sin()).collect();
    let (mut ta, mut tb) = (x.zeros_like(), x.zeros_like());
    c_ad.jacobian_transpose_apply_add(x, &mu, 0.7, &mut ta);
    c.jacobian_transpose_apply_add(x, &mu, 0.7, &mut tb);
    close(ta.as_slice(), tb.as_slice(), &format!("{what}: G^T mu"));
    let (mut ea, mut eb) = (Triplets::default(), Triplets::default());
    if c.jacobian_entries(x, &mut eb) {
        assert!(c_ad.jacobian_entries(x, &mut ea), "{what}: no entries");
        // Same matrix (positions may be listed in another order): compare G applied to v.
        let apply = |t: &Triplets<f64>| {
            let mut o = vec![0.0; m];
            for &(r, col, val) in &t.entries {
                o[r] += val * v.as_slice()[col];
            }
            o
        };
        close(&apply(&ea), &apply(&eb), &format!("{what}: entries"));
    }
}

#[test]
fn the_papers_example() {
    let (h, c) = ad_paper();
    papers_example(h, c, "paper");
}

/// The same, each function one element reading the whole state (the loads and stores at fixed
/// positions of `AdHamiltonian::whole`).
#[test]
fn the_papers_example_on_the_whole_state() {
    let (h, c) = ad_paper_whole();
    papers_example(h, c, "paper, whole state");
}

fn papers_example<H, C>(h: H, c: C, what: &str)
where
    H: Hamiltonian<V4> + Clone,
    C: HolonomicConstraint<V4> + Clone,
{
    let x = V4::new(0.6, 0.8, -0.3, 0.2);
    let v = V4::new(0.3, -0.1, 0.7, 0.5);
    same_derivatives(&h, &paper::Energy, &c, &paper::Circle, &x, &v, what);
    let sys = System::new(paper::Structure, h.clone(), c.clone());
    assert!(check_model(&sys, &x).passed());
    // Trajectories: the same projected drift on the AD and the hand-written model.
    let x0: V4 = paper::initial_state();
    let mut ad = paper::drift()
        .projected(sys, &x0, ProjectionOptions::default())
        .unwrap();
    let mut hand = paper::drift()
        .projected(paper::system(), &x0, ProjectionOptions::default())
        .unwrap();
    let (mut xa, mut xh) = (x0, x0);
    for _ in 0..1000 {
        ad.step(0.1, &mut xa).unwrap();
        hand.step(0.1, &mut xh).unwrap();
    }
    assert!((xa - xh).amax() < 1e-12, "{:e}", (xa - xh).amax());
}

/// The spherical pendulum, m = 1.5, L = 0.7, g = 9.81: `H = |p|²/2m + m g z`.
#[derive(Clone, Copy)]
struct Pendulum {
    m: f64,
    g: f64,
    l: f64,
}
impl Element<6> for Pendulum {
    fn eval<T: DualNum<Primitive = f64> + Copy>(&self, x: [T; 6]) -> T {
        (x[3] * x[3] + x[4] * x[4] + x[5] * x[5]) / (2.0 * self.m) + x[2] * (self.m * self.g)
    }
}
#[derive(Clone, Copy)]
struct Sphere(f64);
impl Element<3> for Sphere {
    fn eval<T: DualNum<Primitive = f64> + Copy>(&self, x: [T; 3]) -> T {
        (x[0] * x[0] + x[1] * x[1] + x[2] * x[2] - self.0 * self.0) * 0.5
    }
}

#[test]
fn the_spherical_pendulum() {
    let p = Pendulum {
        m: 1.5,
        g: 9.81,
        l: 0.7,
    };
    let model = SphericalPendulum::try_new(p.m, p.l, p.g).unwrap();
    let h = AdHamiltonian::whole(p);
    let c = AdConstraint::new(vec![(Sphere(p.l), [0, 1, 2])]);
    let x = SVector::<f64, 6>::from([0.3, -0.2, -0.6, 0.1, 0.4, -0.2]);
    let v = SVector::<f64, 6>::from([0.5, 0.1, -0.3, 0.2, -0.7, 0.4]);
    let s = model.system();
    same_derivatives(
        &h,
        &s.hamiltonian,
        &c,
        &s.constraint,
        &x,
        &v,
        "spherical pendulum",
    );
}

#[test]
fn the_rigid_body() {
    #[derive(Clone, Copy)]
    struct Free([f64; 3]);
    impl Element<3> for Free {
        fn eval<T: DualNum<Primitive = f64> + Copy>(&self, y: [T; 3]) -> T {
            (y[0] * y[0] / self.0[0] + y[1] * y[1] / self.0[1] + y[2] * y[2] / self.0[2]) * 0.5
        }
    }
    let body = RigidBody::<f64>::gni();
    let h = AdHamiltonian::whole(Free(body.inertia));
    let y = SVector::<f64, 3>::new(0.3, -0.8, 0.5);
    let v = SVector::<f64, 3>::new(-0.2, 0.4, 0.9);
    same_derivatives(
        &h,
        &body,
        &Unconstrained,
        &Unconstrained,
        &y,
        &v,
        "rigid body",
    );
    assert!(check_model(&System::new(LiePoissonSo3, h, Unconstrained), &y).passed());
}

#[test]
fn the_pendulum_chain_per_element() {
    let links = 40;
    let chain = PendulumChain::<f64>::uniform(2, links).unwrap();
    let (h, c) = ad_chain(links);
    let x = dense(chain.state_len(), 1.0);
    let v = dense(chain.state_len(), 5.0);
    let s = chain.system();
    same_derivatives(&h, &s.hamiltonian, &c, &s.constraint, &x, &v, "chain");
    assert!(check_model(&System::new(Canonical, h.clone(), c.clone()), &x).passed());
    // Trajectories: RATTLE on both, from the same state at rest.
    let x0: D = chain.at_rest(|i| 0.3 + 0.01 * i as f64);
    let (mut ad, mut hand) = chain_rattle_pair(&chain, links, &x0);
    let (mut xa, mut xh) = (x0.clone(), x0);
    for _ in 0..200 {
        ad.step(1e-3, &mut xa).unwrap();
        hand.step(1e-3, &mut xh).unwrap();
    }
    let d = (&xa - &xh).amax();
    assert!(d < 1e-12, "trajectories differ by {d:e}");
}

#[test]
fn sphere_particles_with_springs() {
    #[derive(Clone, Copy)]
    enum Term {
        Kinetic { m: f64, gravity: f64 },
        Spring(f64),
    }
    impl Element<6> for Term {
        fn eval<T: DualNum<Primitive = f64> + Copy>(&self, x: [T; 6]) -> T {
            match *self {
                // x = (q_z, p_x, p_y, p_z, unused, unused)
                Term::Kinetic { m, gravity } => {
                    (x[1] * x[1] + x[2] * x[2] + x[3] * x[3]) / (2.0 * m) + x[0] * (m * gravity)
                }
                // x = (q_i, q_{i+1})
                Term::Spring(k) => {
                    let d = [x[3] - x[0], x[4] - x[1], x[5] - x[2]];
                    (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) * (0.5 * k)
                }
            }
        }
    }
    let n = 12;
    let model = SphereParticles::<f64>::row(n, 3.0).unwrap();
    let s = model.system();
    // `row`: unit masses, gravity 1.
    let (gravity, k) = (1.0, 3.0);
    let nq = 3 * n;
    let mut terms: Vec<(Term, [usize; 6])> = (0..n)
        .map(|i| {
            let q = 3 * i + 2;
            let p = nq + 3 * i;
            (
                Term::Kinetic { m: 1.0, gravity },
                [q, p, p + 1, p + 2, q, q],
            )
        })
        .collect();
    terms.extend((0..n - 1).map(|i| {
        (
            Term::Spring(k),
            [3 * i, 3 * i + 1, 3 * i + 2, 3 * i + 3, 3 * i + 4, 3 * i + 5],
        )
    }));
    let h = AdHamiltonian::new(terms);
    let x = dense(model.state_len(), 3.0);
    let v = dense(model.state_len(), 8.0);
    // The constraints: the built-in's own, so the energy is what is compared here.
    same_derivatives(
        &h,
        &s.hamiltonian,
        &s.constraint,
        &s.constraint,
        &x,
        &v,
        "sphere particles",
    );
}
