//! A model from `H(x)` and `g(x)` alone (feature `autodiff`): forward-mode automatic derivatives
//! on [num-dual](https://docs.rs/num-dual) dual numbers, element by element.
//!
//! Write each energy term and each constraint row once, generically over the scalar, as an
//! [`Element`] of `K` arguments (the [`element!`](crate::element) macro writes the trait impl
//! from a closure-like expression), and list which state coordinates each instance reads:
//!
//! - [`AdHamiltonian`] implements [`Hamiltonian`]: `H = Σₑ fₑ(x[iₑ])`; the gradient of each
//!   element by a vector dual number `DualSVec64<K>` (one pass per element), `∇²H v` by
//!   forward-over-forward duals (`DualSVec<Dual64, K>`, one pass), scattered into the state.
//! - [`AdConstraint`] implements [`HolonomicConstraint`], one row per element:
//!   `G v` by a directional dual (`Dual64` seeded with `v`), `Gᵀμ` and the Jacobian entries
//!   from the element's gradient. Entries are given when there are more rows than the
//!   projection's small path takes ([`SMALL_MAX`](crate::nonlinear::SMALL_MAX)), so large
//!   models get the sparse multiplier systems and small ones the stack path.
//!
//! Every element reads `K` coordinates, so the cost is `O(K²)` per element and `O(N)` for a
//! model of `N` elements — a chain of 10⁵ links differentiates 10⁵ small elements, never a
//! whole-state gradient (which would be `O(n²)`). For a small model one element can read the
//! whole state ([`AdHamiltonian::whole`]).
//!
//! ```
//! use lieflow::autodiff::{AdConstraint, AdHamiltonian};
//! use lieflow::prelude::*;
//! type V = nalgebra::SVector<f64, 4>;
//!
//! // A planar pendulum in Cartesian coordinates, x = (q₁, q₂, p₁, p₂).
//! lieflow::element!(Energy, 4, |x| (x[2] * x[2] + x[3] * x[3]) * 0.5 + x[1] * 9.81);
//! lieflow::element!(Rod, 2, |q| (q[0] * q[0] + q[1] * q[1] - 1.0) * 0.5);
//!
//! fn main() -> Result<(), Box<dyn std::error::Error>> {
//!     let energy = AdHamiltonian::whole(Energy);
//!     let system = System::new(Canonical, energy.clone(), AdConstraint::new(vec![(Rod, [0, 1])]));
//!     let mut x = V::new(1.0, 0.0, 0.0, 0.0);
//!     let mut flow = ImplicitMidpoint::<V, _, _>::try_new(Canonical, energy, &x, Default::default())?
//!         .projected(system, &x, ProjectionOptions::default())?;
//!     integrate(&mut flow, &mut x, 0.0, 0.01, 1000, &mut ())?;
//!     assert!((x[0] * x[0] + x[1] * x[1] - 1.0).abs() < 1e-14);
//!     Ok(())
//! }
//! ```
//!
//! Reference: Griewank & Walther, *Evaluating Derivatives* (SIAM, 2008), ch. 3 (forward mode)
//! and §5.4 (forward-over-forward second derivatives); num-dual: Rehner & Bauer, *Application
//! of generalized (hyper-) dual numbers in equation of state modeling*, Front. Chem. Eng. 3
//! (2021).

use crate::linalg::Sink;
use crate::nonlinear::SMALL_MAX;
use crate::system::{Hamiltonian, HolonomicConstraint};
use crate::vector::Vector;
use nalgebra::{Const, U1};
pub use num_dual::DualNum;
use num_dual::{Derivative, Dual64, DualSVec, DualSVec64, HyperDual64};

/// One term of an energy or one constraint row, a function of `K` state coordinates written
/// once, generically over the scalar: `f64` for values, dual numbers for derivatives. Use the
/// operators with `D` on the left (`x[0] * 0.5`, not `0.5 * x[0]`), `D::from(c)` for a constant
/// on its own, and the [`DualNum`] methods (`sin`, `cos`, `sqrt`, `powi`, …).
pub trait Element<const K: usize> {
    /// `f(x)`.
    fn eval<D: DualNum<Primitive = f64> + Copy>(&self, x: [D; K]) -> D;
}

/// Defines a unit struct `$name` implementing [`Element<$k>`](crate::autodiff::Element) from
/// an expression in `x: [D; $k]`, with optional attributes and doc comments first:
/// `lieflow::element!(Energy, 4, |x| (x[2] * x[2] + x[3] * x[3]) * 0.5 + x[1] * 9.81);`
#[macro_export]
macro_rules! element {
    ($(#[$meta:meta])* $vis:vis $name:ident, $k:literal, |$x:ident| $body:expr) => {
        $(#[$meta])*
        #[derive(Debug, Clone, Copy, Default, PartialEq)]
        $vis struct $name;
        impl $crate::autodiff::Element<$k> for $name {
            #[inline]
            fn eval<D: $crate::autodiff::DualNum<Primitive = f64> + Copy>(&self, $x: [D; $k]) -> D {
                $body
            }
        }
    };
}

/// Up to this many arguments a gradient takes `K` passes of a scalar dual number (three flops
/// per product) instead of one pass of a vector dual (whose optional derivative part costs
/// more than the arithmetic for small `K`).
const SCALAR_PASSES_MAX: usize = 8;

/// The value and gradient of `e` at the coordinates `idx` of `x`.
#[inline(always)]
fn gradient<E: Element<K>, const K: usize>(e: &E, x: &[f64; K]) -> (f64, [f64; K]) {
    if K <= SCALAR_PASSES_MAX {
        let mut g = [0.0; K];
        let mut value = 0.0;
        for (j, gj) in g.iter_mut().enumerate() {
            let xs: [Dual64; K] =
                core::array::from_fn(|i| Dual64::new(x[i], if i == j { 1.0 } else { 0.0 }));
            let r = e.eval(xs);
            *gj = r.eps;
            value = r.re;
        }
        return (value, g);
    }
    let xs: [DualSVec64<K>; K] =
        core::array::from_fn(|j| DualSVec64::<K>::from_re(x[j]).derivative(j));
    let r = e.eval(xs);
    let g = r.eps.unwrap_generic(Const::<K>, U1);
    (r.re, core::array::from_fn(|j| g[j]))
}

/// The directional derivative `∇f · v`.
#[inline(always)]
fn directional<E: Element<K>, const K: usize>(e: &E, x: &[f64; K], v: &[f64; K]) -> f64 {
    let xs: [Dual64; K] = core::array::from_fn(|j| Dual64::new(x[j], v[j]));
    e.eval(xs).eps
}

/// `∇²f · v[idx]` by forward over forward: the inner dual carries the direction `v`, the outer
/// vector dual the gradient; the gradient's `v`-derivative is the Hessian product.
#[inline(always)]
fn hessian_product<E: Element<K>, const K: usize>(e: &E, x: &[f64; K], v: &[f64; K]) -> [f64; K] {
    if K <= SCALAR_PASSES_MAX {
        // K passes of a hyper-dual number: ε₁ carries v, ε₂ the unit vector e_j, and the
        // ε₁ε₂ part is (∇²f v)_j.
        return core::array::from_fn(|j| {
            let xs: [HyperDual64; K] = core::array::from_fn(|i| {
                HyperDual64::new(x[i], v[i], if i == j { 1.0 } else { 0.0 }, 0.0)
            });
            e.eval(xs).eps1eps2
        });
    }
    let xs: [DualSVec<Dual64, K>; K] = core::array::from_fn(|j| {
        DualSVec::<Dual64, K>::new(
            Dual64::new(x[j], v[j]),
            Derivative::derivative_generic(Const::<K>, U1, j),
        )
    });
    let g = e.eval(xs).eps.unwrap_generic(Const::<K>, U1);
    core::array::from_fn(|j| g[j].eps)
}

/// Elements and the coordinates each reads.
#[derive(Debug, Clone, PartialEq)]
struct Elements<E, const K: usize> {
    items: Vec<(E, [usize; K])>,
    /// One element reading `x[0..K]` in order: loads and stores at fixed positions, which the
    /// compiler keeps in registers for a small stack state (gathers and scatters through
    /// run-time indices go through memory, and a scalar store read back by a vector load
    /// stalls).
    whole: bool,
}

impl<E, const K: usize> Elements<E, K> {
    fn new(items: Vec<(E, [usize; K])>) -> Self {
        let whole = items.len() == 1 && items[0].1.iter().enumerate().all(|(j, &i)| i == j);
        Self { items, whole }
    }
    /// `x[idx]`.
    #[inline(always)]
    fn load(&self, x: &[f64], idx: &[usize; K]) -> [f64; K] {
        if self.whole {
            core::array::from_fn(|j| x[j])
        } else {
            core::array::from_fn(|j| x[idx[j]])
        }
    }
    /// `out[idx] += a · v`.
    #[inline(always)]
    fn add(&self, out: &mut [f64], idx: &[usize; K], a: f64, v: &[f64; K]) {
        if self.whole {
            for j in 0..K {
                out[j] += a * v[j];
            }
        } else {
            for j in 0..K {
                out[idx[j]] += a * v[j];
            }
        }
    }
    fn check(&self, n: usize) {
        debug_assert!(
            self.items.iter().all(|(_, idx)| idx.iter().all(|&i| i < n)),
            "an element reads a coordinate outside the state of length {n}"
        );
    }
}

/// `H(x) = Σₑ fₑ(x[iₑ])` with automatic derivatives (see the [module docs](self)).
#[derive(Debug, Clone, PartialEq)]
pub struct AdHamiltonian<E, const K: usize> {
    elements: Elements<E, K>,
    quadratic: bool,
    /// For a quadratic `H`: each element's constant Hessian (`K × K`, by rows) and its
    /// gradient at 0, so that `∇f(x) = A x + b` and `∇²f v = A v` cost `K²` flops.
    affine: Vec<([[f64; K]; K], [f64; K])>,
}

impl<E: Element<K>, const K: usize> AdHamiltonian<E, K> {
    /// `H = Σ f(x[i])` over the given elements and the coordinates each reads.
    pub fn new(items: Vec<(E, [usize; K])>) -> Self {
        Self {
            elements: Elements::new(items),
            quadratic: false,
            affine: Vec::new(),
        }
    }
    /// One element reading the whole state `x[0..K]` (a small model).
    pub fn whole(e: E) -> Self {
        Self::new(vec![(e, core::array::from_fn(|j| j))])
    }
    /// Declares `H` quadratic: each element's Hessian is computed once (at `x = 0`) and its
    /// gradient is `A x + b` from then on, and with a constant `M` the projection's `λ_{k+1}`
    /// system is one linear solve. Declare it only when it is true: a non-quadratic element
    /// would get the wrong derivatives ([`check_model`](crate::system::check_model) finds it).
    pub fn quadratic(mut self) -> Self {
        self.quadratic = true;
        let zeros = [0.0; K];
        let at =
            |j: usize| -> [f64; K] { core::array::from_fn(|i| if i == j { 1.0 } else { 0.0 }) };
        self.affine = self
            .elements
            .items
            .iter()
            .map(|(e, _)| {
                // Column j is ∇²f e_j; a[i][j] is row i.
                let cols: [[f64; K]; K] =
                    core::array::from_fn(|j| hessian_product(e, &zeros, &at(j)));
                let a: [[f64; K]; K] =
                    core::array::from_fn(|i| core::array::from_fn(|j| cols[j][i]));
                (a, gradient(e, &zeros).1)
            })
            .collect();
        self
    }
}

impl<V, E, const K: usize> Hamiltonian<V> for AdHamiltonian<E, K>
where
    V: Vector<Real = f64>,
    E: Element<K>,
{
    #[inline(always)]
    fn energy(&self, x: &V) -> f64 {
        let x = x.as_slice();
        let el = &self.elements;
        el.check(x.len());
        el.items
            .iter()
            .map(|(e, idx)| e.eval::<f64>(el.load(x, idx)))
            .sum()
    }
    #[inline(always)]
    fn gradient(&self, x: &V, out: &mut V) {
        let (x, out) = (x.as_slice(), out.as_mut_slice());
        let el = &self.elements;
        out.fill(0.0);
        if self.quadratic {
            for ((_, idx), (a, b)) in el.items.iter().zip(&self.affine) {
                let xs = el.load(x, idx);
                let g: [f64; K] =
                    core::array::from_fn(|i| (0..K).fold(b[i], |s, j| s + a[i][j] * xs[j]));
                el.add(out, idx, 1.0, &g);
            }
            return;
        }
        for (e, idx) in &el.items {
            let (_, g) = gradient(e, &el.load(x, idx));
            el.add(out, idx, 1.0, &g);
        }
    }
    #[inline(always)]
    fn hessian_apply(&self, x: &V, v: &V, out: &mut V) -> bool {
        let (x, v, out) = (x.as_slice(), v.as_slice(), out.as_mut_slice());
        let el = &self.elements;
        out.fill(0.0);
        if self.quadratic {
            for ((_, idx), (a, _)) in el.items.iter().zip(&self.affine) {
                let vs = el.load(v, idx);
                let hv: [f64; K] =
                    core::array::from_fn(|i| (0..K).fold(0.0, |s, j| s + a[i][j] * vs[j]));
                el.add(out, idx, 1.0, &hv);
            }
            return true;
        }
        for (e, idx) in &el.items {
            let hv = hessian_product(e, &el.load(x, idx), &el.load(v, idx));
            el.add(out, idx, 1.0, &hv);
        }
        true
    }
    fn is_quadratic(&self) -> bool {
        self.quadratic
    }
}

/// Constraints `g_r(x) = f_r(x[i_r]) = 0`, one row per element, with automatic derivatives
/// (see the [module docs](self)).
#[derive(Debug, Clone, PartialEq)]
pub struct AdConstraint<E, const K: usize> {
    elements: Elements<E, K>,
    entries: bool,
}

impl<E: Element<K>, const K: usize> AdConstraint<E, K> {
    /// One row per element. Jacobian entries are provided when there are more rows than
    /// [`SMALL_MAX`] (see [`with_entries`](Self::with_entries)).
    pub fn new(items: Vec<(E, [usize; K])>) -> Self {
        let entries = items.len() > SMALL_MAX;
        Self {
            elements: Elements::new(items),
            entries,
        }
    }
    /// One row reading the whole state `x[0..K]`.
    pub fn whole(e: E) -> Self {
        Self::new(vec![(e, core::array::from_fn(|j| j))])
    }
    /// Provide (or not) [`HolonomicConstraint::jacobian_entries`]: with them the projection
    /// takes the sparse path and checks at construction that no row is redundant; without them
    /// `G` is dense and up to [`SMALL_MAX`] rows take the stack path.
    pub fn with_entries(mut self, entries: bool) -> Self {
        self.entries = entries;
        self
    }
}

impl<V, E, const K: usize> HolonomicConstraint<V> for AdConstraint<E, K>
where
    V: Vector<Real = f64>,
    E: Element<K>,
{
    fn dim(&self) -> usize {
        self.elements.items.len()
    }
    #[inline(always)]
    fn residual(&self, x: &V, out: &mut [f64]) {
        let x = x.as_slice();
        let el = &self.elements;
        el.check(x.len());
        for ((e, idx), o) in el.items.iter().zip(out) {
            *o = e.eval::<f64>(el.load(x, idx));
        }
    }
    #[inline(always)]
    fn jacobian_apply(&self, x: &V, v: &V, out: &mut [f64]) {
        let (x, v) = (x.as_slice(), v.as_slice());
        let el = &self.elements;
        for ((e, idx), o) in el.items.iter().zip(out) {
            *o = directional(e, &el.load(x, idx), &el.load(v, idx));
        }
    }
    #[inline(always)]
    fn jacobian_transpose_apply_add(&self, x: &V, mu: &[f64], alpha: f64, out: &mut V) {
        let (x, out) = (x.as_slice(), out.as_mut_slice());
        let el = &self.elements;
        for ((e, idx), &m) in el.items.iter().zip(mu) {
            if m == 0.0 {
                continue;
            }
            let (_, g) = gradient(e, &el.load(x, idx));
            el.add(out, idx, alpha * m, &g);
        }
    }
    fn jacobian_entries(&self, x: &V, sink: &mut dyn Sink<f64>) -> bool {
        if !self.entries {
            return false;
        }
        let x = x.as_slice();
        let el = &self.elements;
        for (r, (e, idx)) in el.items.iter().enumerate() {
            let (_, g) = gradient(e, &el.load(x, idx));
            for j in 0..K {
                sink.add(r, idx[j], g[j]);
            }
        }
        true
    }
}
