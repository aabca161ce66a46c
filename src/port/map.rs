//! The input map `B(x)`: how integrated inputs act on the state, and its transpose, which
//! gives the collocated output `y = B(x)ᵀ ∇H(x)`.

use crate::real::Real;
use crate::system::Hamiltonian;
use crate::vector::Vector;
use num_traits::Zero;

/// The input map `B(x)` of an open system `x' = … + B(x) u`, with `k` inputs.
///
/// Contract: `B` does not change along its own columns (`(∂B/∂x) B = 0`), so that
/// `x ← x + B(x) w` is the exact flow of `x' = B(x) u` with `w = ∫ u dt`. A constant `B` and
/// forces or torques `B(q)` acting on the momenta of a mechanical model qualify.
pub trait InputMap<V: Vector> {
    /// The number of inputs `k`.
    fn inputs(&self) -> usize;
    /// `x ← x + B(x) w`.
    fn apply(&self, x: &mut V, w: &[V::Real]);
    /// `y = B(x)ᵀ e` (`k` entries; overwrites).
    fn transpose_apply(&self, x: &V, e: &V, y: &mut [V::Real]);
    /// `out ← out + B(x) w`, with `B` at `x` and `x` unchanged: the force of the inputs at a
    /// state an implicit scheme visits (the Petrov–Galerkin residual's `B(x(e_r)) u(e_r)`).
    ///
    /// The default applies `w` to `scratch` (a copy of `x`) through [`apply`](Self::apply) and
    /// adds the difference `scratch − x`, which rounds at `ε |x|` rather than `ε |B w|`; the maps
    /// of this module override it with the product itself, and a map of one's own should too.
    fn add_product(&self, x: &V, w: &[V::Real], out: &mut V, scratch: &mut V) {
        scratch.copy_from(x);
        self.apply(scratch, w);
        for ((o, &s), &xi) in out
            .as_mut_slice()
            .iter_mut()
            .zip(scratch.as_slice())
            .zip(x.as_slice())
        {
            *o = *o + (s - xi);
        }
    }
    /// The collocated output `y = B(x)ᵀ ∇H(x)` (`grad`: scratch for `∇H`). With it, the power
    /// the inputs supply is `yᵀu`.
    fn output<H: Hamiltonian<V>>(&self, hamiltonian: &H, x: &V, grad: &mut V, y: &mut [V::Real])
    where
        Self: Sized,
    {
        hamiltonian.gradient(x, grad);
        self.transpose_apply(x, grad, y);
    }
}

impl<V: Vector, B: InputMap<V> + ?Sized> InputMap<V> for &B {
    fn inputs(&self) -> usize {
        (**self).inputs()
    }
    fn apply(&self, x: &mut V, w: &[V::Real]) {
        (**self).apply(x, w)
    }
    fn transpose_apply(&self, x: &V, e: &V, y: &mut [V::Real]) {
        (**self).transpose_apply(x, e, y)
    }
    fn add_product(&self, x: &V, w: &[V::Real], out: &mut V, scratch: &mut V) {
        (**self).add_product(x, w, out, scratch)
    }
}

/// A constant input matrix `B` (`n × k`, column-major).
#[derive(Debug, Clone, PartialEq)]
pub struct InputMatrix<T> {
    n: usize,
    columns: Vec<T>,
}

impl<T: Real> InputMatrix<T> {
    /// `B` from its `k` columns of length `n`; `None` if they differ in length or hold a
    /// non-finite entry.
    pub fn from_columns(columns: &[&[T]]) -> Option<Self> {
        let n = columns.first().map_or(0, |c| c.len());
        let ok = columns
            .iter()
            .all(|c| c.len() == n && c.iter().all(|v| v.is_finite()));
        ok.then(|| Self {
            n,
            columns: columns.iter().flat_map(|c| c.iter().copied()).collect(),
        })
    }
}

impl<V: Vector> InputMap<V> for InputMatrix<V::Real> {
    fn inputs(&self) -> usize {
        self.columns.len().checked_div(self.n).unwrap_or(0)
    }
    fn apply(&self, x: &mut V, w: &[V::Real]) {
        let x = x.as_mut_slice();
        for (col, &wj) in self.columns.chunks_exact(self.n).zip(w) {
            for (xi, &b) in x.iter_mut().zip(col) {
                *xi = *xi + b * wj;
            }
        }
    }
    fn transpose_apply(&self, _x: &V, e: &V, y: &mut [V::Real]) {
        for (col, yj) in self.columns.chunks_exact(self.n).zip(y.iter_mut()) {
            *yj = col
                .iter()
                .zip(e.as_slice())
                .fold(V::Real::zero(), |s, (&b, &ei)| s + b * ei);
        }
    }
    /// `B` is constant: applied to `out` directly.
    fn add_product(&self, _x: &V, w: &[V::Real], out: &mut V, _scratch: &mut V) {
        <Self as InputMap<V>>::apply(self, out, w);
    }
}

/// Each input drives one component of the state with a gain: `B = Σ_j gain_j e_{c_j} e_jᵀ`
/// (a force along one momentum, a voltage into one port). Constant, so exact.
#[derive(Debug, Clone, PartialEq)]
pub struct ComponentInputs<T> {
    components: Vec<usize>,
    gains: Vec<T>,
}

impl<T: Real> ComponentInputs<T> {
    /// Inputs on `components` (state indices) with unit gains.
    pub fn new(components: &[usize]) -> Self {
        Self {
            components: components.to_vec(),
            gains: vec![T::one(); components.len()],
        }
    }
    /// Inputs on `(component, gain)` pairs.
    pub fn with_gains(pairs: &[(usize, T)]) -> Self {
        Self {
            components: pairs.iter().map(|p| p.0).collect(),
            gains: pairs.iter().map(|p| p.1).collect(),
        }
    }
}

impl<V: Vector> InputMap<V> for ComponentInputs<V::Real> {
    fn inputs(&self) -> usize {
        self.components.len()
    }
    #[inline]
    fn apply(&self, x: &mut V, w: &[V::Real]) {
        let x = x.as_mut_slice();
        for ((&c, &g), &wj) in self.components.iter().zip(&self.gains).zip(w) {
            x[c] = x[c] + g * wj;
        }
    }
    fn transpose_apply(&self, _x: &V, e: &V, y: &mut [V::Real]) {
        let e = e.as_slice();
        for ((&c, &g), yj) in self.components.iter().zip(&self.gains).zip(y.iter_mut()) {
            *yj = g * e[c];
        }
    }
    /// `B` is constant: applied to `out` directly.
    fn add_product(&self, _x: &V, w: &[V::Real], out: &mut V, _scratch: &mut V) {
        <Self as InputMap<V>>::apply(self, out, w);
    }
}

/// An input map from two closures: `apply(x, w)` for `x ← x + B(x) w` and
/// `transpose(x, e, y)` for `y = B(x)ᵀ e` (for a state-dependent `B(q)`: a torque about a
/// moving pivot, a force along a rod).
#[derive(Clone)]
pub struct FnInputMap<A, Y> {
    inputs: usize,
    apply: A,
    transpose: Y,
}

impl<A, Y> FnInputMap<A, Y> {
    /// `k` inputs acting through `apply`, read back through `transpose`.
    pub fn new(inputs: usize, apply: A, transpose: Y) -> Self {
        Self {
            inputs,
            apply,
            transpose,
        }
    }
}

impl<A, Y> core::fmt::Debug for FnInputMap<A, Y> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("FnInputMap")
            .field("inputs", &self.inputs)
            .finish_non_exhaustive()
    }
}

impl<V, A, Y> InputMap<V> for FnInputMap<A, Y>
where
    V: Vector,
    A: Fn(&mut V, &[V::Real]),
    Y: Fn(&V, &V, &mut [V::Real]),
{
    fn inputs(&self) -> usize {
        self.inputs
    }
    fn apply(&self, x: &mut V, w: &[V::Real]) {
        (self.apply)(x, w)
    }
    fn transpose_apply(&self, x: &V, e: &V, y: &mut [V::Real]) {
        (self.transpose)(x, e, y)
    }
}
