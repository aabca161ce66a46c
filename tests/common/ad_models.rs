//! The built-in models written once as autodiff elements, shared by tests/autodiff/autodiff.rs and
//! benches/autodiff.rs (included with `#[path]`).

use lieflow::autodiff::{AdConstraint, AdHamiltonian, DualNum, Element};
use lieflow::models::PendulumChain;
use lieflow::prelude::*;

lieflow::element!(
    /// The paper's `H = (x₃² + x₄²)/2`, reading `(x₃, x₄)`.
    pub PaperEnergy, 2, |p| (p[0] * p[0] + p[1] * p[1]) * 0.5);
lieflow::element!(
    /// The paper's `g = (x₁² + x₂² − 1)/2`, reading `(x₁, x₂)`.
    pub UnitCircle, 2, |q| (q[0] * q[0] + q[1] * q[1] - 1.0) * 0.5);

/// The paper's example with automatic derivatives: each element reads only the coordinates it
/// depends on (two of four).
pub fn ad_paper() -> (AdHamiltonian<PaperEnergy, 2>, AdConstraint<UnitCircle, 2>) {
    (
        AdHamiltonian::new(vec![(PaperEnergy, [2, 3])]).quadratic(),
        AdConstraint::new(vec![(UnitCircle, [0, 1])]),
    )
}

/// A planar chain per element: each body's energy reads `(q_y, p_x, p_y)`; each link reads the
/// two bodies it joins (the pin reads body 0 twice and uses the first copy).
#[derive(Clone, Copy)]
pub struct Body {
    pub m: f64,
    pub gravity: f64,
}
impl Element<3> for Body {
    fn eval<T: DualNum<Primitive = f64> + Copy>(&self, x: [T; 3]) -> T {
        (x[1] * x[1] + x[2] * x[2]) / (2.0 * self.m) + x[0] * (self.m * self.gravity)
    }
}
#[derive(Clone, Copy)]
pub enum Link {
    Pin(f64),
    Rod(f64),
}
impl Element<4> for Link {
    fn eval<T: DualNum<Primitive = f64> + Copy>(&self, x: [T; 4]) -> T {
        match *self {
            Link::Pin(l) => (x[0] * x[0] + x[1] * x[1] - l * l) * 0.5,
            Link::Rod(l) => {
                let (dx, dy) = (x[2] - x[0], x[3] - x[1]);
                (dx * dx + dy * dy - l * l) * 0.5
            }
        }
    }
}

pub fn ad_chain(links: usize) -> (AdHamiltonian<Body, 3>, AdConstraint<Link, 4>) {
    let nq = 2 * links;
    let h = AdHamiltonian::new(
        (0..links)
            .map(|i| {
                (
                    Body {
                        m: 1.0,
                        gravity: 1.0,
                    },
                    [2 * i + 1, nq + 2 * i, nq + 2 * i + 1],
                )
            })
            .collect(),
    )
    .quadratic();
    let l = 1.0 / links as f64;
    let mut rows = vec![(Link::Pin(l), [0, 1, 0, 1])];
    rows.extend((1..links).map(|i| (Link::Rod(l), [2 * i - 2, 2 * i - 1, 2 * i, 2 * i + 1])));
    (h, AdConstraint::new(rows))
}

/// RATTLE (projected kick–drift–kick) on the chain with its autodiff model and with its
/// hand-written one, from the same state: `(autodiff, hand)`.
#[allow(dead_code)]
pub fn chain_rattle_pair<V: Vector<Real = f64> + 'static>(
    chain: &PendulumChain<f64>,
    links: usize,
    x0: &V,
) -> (impl Flow<V> + use<V>, impl Flow<V> + use<V>) {
    let opts = chain.projection_options();
    let (h, con) = ad_chain(links);
    let ad = chain
        .kick()
        .strang(chain.drift())
        .projected(System::new(Canonical, h, con), x0, opts)
        .unwrap();
    let hand = chain
        .kick()
        .strang(chain.drift())
        .projected(chain.system(), x0, opts)
        .unwrap();
    (ad, hand)
}

lieflow::element!(
    /// The paper's `H`, written on the whole state `x = (x₁, x₂, x₃, x₄)`.
    pub PaperEnergyWhole, 4, |x| (x[2] * x[2] + x[3] * x[3]) * 0.5);
lieflow::element!(
    /// The paper's `g`, written on the whole state.
    pub UnitCircleWhole, 4, |x| (x[0] * x[0] + x[1] * x[1] - 1.0) * 0.5);

/// The paper's example with one element per function, each reading the whole state (how a
/// small model is usually written, as in the README).
pub fn ad_paper_whole() -> (
    AdHamiltonian<PaperEnergyWhole, 4>,
    AdConstraint<UnitCircleWhole, 4>,
) {
    (
        AdHamiltonian::whole(PaperEnergyWhole).quadratic(),
        AdConstraint::whole(UnitCircleWhole),
    )
}
