use crate::linalg::Sink;
use crate::real::Real;
use crate::vector::{Vector, ops};
use num_traits::{One, Zero};

/// The structure matrix `M(x)` of `x' = M(x) ∇H(x)`, applied to vectors.
///
/// Its skew part `J = (M − Mᵀ)/2` is the Poisson structure, its symmetric part `−R = (M + Mᵀ)/2`
/// dissipation (`R ⪰ 0`) or exchange. Implement [`apply_add`](Self::apply_add); [`apply`](Self::apply)
/// follows.
pub trait StructureMatrix<V: Vector> {
    /// `out += α M(x) v`.
    fn apply_add(&self, x: &V, v: &V, alpha: V::Real, out: &mut V);

    /// `out = M(x) v`.
    #[inline]
    fn apply(&self, x: &V, v: &V, out: &mut V) {
        ops::fill_zero(out.as_mut_slice());
        self.apply_add(x, v, V::Real::one(), out);
    }

    /// `true` if `M` does not depend on `x`.
    fn is_constant(&self) -> bool {
        false
    }

    /// `out += α (DM(x)[u]) w`, the derivative of `M` at `x` in the direction `u` applied to `w`,
    /// and `true`, if the model provides it. The default provides it only for a constant `M`
    /// (where it is zero); otherwise it returns `false` and implicit flows fall back to finite
    /// differences (see [`Hamiltonian::hessian_apply`](crate::system::Hamiltonian::hessian_apply)).
    fn derivative_apply_add(&self, x: &V, u: &V, w: &V, alpha: V::Real, out: &mut V) -> bool {
        let _ = (x, u, w, alpha, out);
        self.is_constant()
    }

    /// `true` if `M` has a dissipative symmetric part (`R ≠ 0` in `M = J − R`). Flows built on
    /// it then report [`Flow::dissipates`](crate::Flow::dissipates).
    fn is_dissipative(&self) -> bool {
        false
    }

    /// `true` if `M(x) = 0` for every `x`, known without evaluating it. [`JMinusR`] asks its
    /// `R` part: `J − R` is dissipative unless `R` says it is zero (or `J` is). The default,
    /// `false`, is the safe answer for a dissipation part that does not know.
    fn is_zero(&self) -> bool {
        false
    }

    /// Writes the entries `(row, col, value)` of `B` (rows and columns in `0..n/2`) into `sink`
    /// and returns `true` when `M(x) = [[0, I], [−I, B]]` on `x = (q, p)` for every `x`, with
    /// `B` constant (`n` the state's length): the structure of a mechanical system whose
    /// damping, dashpots and gyroscopic terms act on the momenta (`B = K − R`). With
    /// [`Hamiltonian::kinetic_inverse_mass`](crate::system::Hamiltonian::kinetic_inverse_mass)
    /// it lets implicit flows eliminate the momenta from their Newton systems. The default
    /// returns `false` (always safe); flows check a `true` at construction against
    /// [`apply`](Self::apply).
    fn momentum_block(&self, n: usize, sink: &mut dyn Sink<V::Real>) -> bool {
        let _ = (n, sink);
        false
    }

    /// Writes the entries of `C` and returns `true` when `M = [[0, 0], [0, C]]` with `C`
    /// constant: a term acting on the momenta alone, such as [`MomentumDamping`] (`C = c I`).
    /// [`JMinusR`] combines it with its `J`'s [`momentum_block`](Self::momentum_block). The
    /// default returns `false`.
    fn momentum_only(&self, n: usize, sink: &mut dyn Sink<V::Real>) -> bool {
        let _ = (n, sink);
        false
    }
}

/// A [`Sink`] that scales every value by `factor` on its way to `inner`.
struct ScaledSink<'a, T> {
    inner: &'a mut dyn Sink<T>,
    factor: T,
}

impl<T: Real> Sink<T> for ScaledSink<'_, T> {
    fn add(&mut self, row: usize, col: usize, value: T) {
        self.inner.add(row, col, self.factor * value);
    }
}

/// The canonical symplectic matrix `M = [[0, I], [−I, 0]]` on `x = (q, p)`, `q, p ∈ Rᵈ`, `n = 2d`.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Canonical;

impl<V: Vector> StructureMatrix<V> for Canonical {
    #[inline]
    fn apply_add(&self, _x: &V, v: &V, alpha: V::Real, out: &mut V) {
        let v = v.as_slice();
        let d = v.len() / 2;
        let out = out.as_mut_slice();
        let (oq, op) = out.split_at_mut(d);
        ops::axpy(oq, alpha, &v[d..]);
        ops::axpy(op, -alpha, &v[..d]);
    }
    /// `out = (p, −q)`: written directly, without zeroing first (one pass over `out` less).
    #[inline]
    fn apply(&self, _x: &V, v: &V, out: &mut V) {
        let v = v.as_slice();
        let d = v.len() / 2;
        let (oq, op) = out.as_mut_slice().split_at_mut(d);
        // Element loops: a `memcpy` call costs more than the copy for small states.
        for (o, &p) in oq.iter_mut().zip(&v[d..]) {
            *o = p;
        }
        for (o, &q) in op.iter_mut().zip(&v[..d]) {
            *o = -q;
        }
    }
    fn is_constant(&self) -> bool {
        true
    }
    /// `B = 0`.
    fn momentum_block(&self, _n: usize, _sink: &mut dyn Sink<V::Real>) -> bool {
        true
    }
}

/// A constant dense `n × n` structure matrix, stored row-major (allocated once).
#[derive(Debug, Clone, PartialEq)]
pub struct Constant<T> {
    n: usize,
    rows: Vec<T>,
    /// The symmetric part is non-zero and negative semi-definite (`M = J − R`, `R ⪰ 0`, `R ≠ 0`).
    dissipative: bool,
}

/// `true` if the symmetric `n × n` matrix `a` (row-major) is positive semi-definite, to a
/// tolerance `n ε max|a|`: Gaussian elimination with diagonal pivoting; a pivot below the
/// tolerance must leave a numerically zero remainder (Higham, *Accuracy and Stability of
/// Numerical Algorithms*, §10.3).
fn semidefinite<T: Real>(n: usize, mut a: Vec<T>) -> bool {
    let scale = a.iter().fold(T::zero(), |s, v| s.max(v.abs()));
    let tol = T::lit(n.max(1) as f64) * T::epsilon() * scale;
    for k in 0..n {
        let (p, d) = (k..n)
            .map(|i| (i, a[i * n + i]))
            .fold((k, T::neg_infinity()), |b, c| if c.1 > b.1 { c } else { b });
        if d < -tol {
            return false;
        }
        if d <= tol {
            return (k..n).all(|i| (k..n).all(|j| a[i * n + j].abs() <= tol));
        }
        if p != k {
            for j in 0..n {
                a.swap(k * n + j, p * n + j);
            }
            for i in 0..n {
                a.swap(i * n + k, i * n + p);
            }
        }
        for i in k + 1..n {
            let f = a[i * n + k] / d;
            for j in k + 1..n {
                a[i * n + j] = a[i * n + j] - f * a[k * n + j];
            }
        }
    }
    true
}

impl<T: Real> Constant<T> {
    /// Builds `M` from its rows. Panics if the rows are not all of length `rows.len()`.
    #[track_caller]
    pub fn from_rows<R: AsRef<[T]>>(rows: &[R]) -> Self {
        let n = rows.len();
        let mut data = Vec::with_capacity(n * n);
        for (i, r) in rows.iter().enumerate() {
            let r = r.as_ref();
            assert_eq!(
                r.len(),
                n,
                "row {i} of the structure matrix has {} entries, expected {n}",
                r.len()
            );
            data.extend_from_slice(r);
        }
        // −(M + Mᵀ)/2 = R must be positive semi-definite and non-zero for M to dissipate.
        let r: Vec<T> = (0..n * n)
            .map(|k| {
                let (i, j) = (k / n, k % n);
                -(data[i * n + j] + data[j * n + i]) * T::lit(0.5)
            })
            .collect();
        let dissipative = r.iter().any(|&v| v != T::zero()) && semidefinite(n, r);
        Self {
            n,
            rows: data,
            dissipative,
        }
    }

    /// The entry `M_ij`.
    pub fn get(&self, i: usize, j: usize) -> T {
        self.rows[i * self.n + j]
    }

    /// The dimension `n`.
    pub fn dim(&self) -> usize {
        self.n
    }
}

impl<V: Vector> StructureMatrix<V> for Constant<V::Real> {
    #[inline]
    fn apply_add(&self, _x: &V, v: &V, alpha: V::Real, out: &mut V) {
        let v = v.as_slice();
        for (oi, row) in out
            .as_mut_slice()
            .iter_mut()
            .zip(self.rows.chunks_exact(self.n))
        {
            let mut s = V::Real::zero();
            for (&a, &b) in row.iter().zip(v) {
                s = s + a * b;
            }
            *oi = *oi + alpha * s;
        }
    }
    fn is_constant(&self) -> bool {
        true
    }
    /// `true` if the symmetric part `(M + Mᵀ)/2 = −R` is non-zero with `R ⪰ 0` (decided once,
    /// at construction). An indefinite symmetric part (the paper's example) is not dissipation:
    /// `H` is then not a Lyapunov function, and compositions may take backward sub-steps.
    fn is_dissipative(&self) -> bool {
        self.dissipative
    }
    fn is_zero(&self) -> bool {
        self.rows.iter().all(|&a| a == V::Real::zero())
    }
}

/// The port-Hamiltonian structure `M(x) = J(x) − R(x)`: `J` skew (interconnection),
/// `R ⪰ 0` symmetric (dissipation). Both parts are themselves structure matrices.
#[derive(Debug, Clone, PartialEq)]
pub struct JMinusR<J, R> {
    /// The skew-symmetric interconnection part.
    pub j: J,
    /// The symmetric positive semi-definite dissipation part.
    pub r: R,
}

impl<J, R> JMinusR<J, R> {
    /// `M = J − R`.
    pub fn new(j: J, r: R) -> Self {
        Self { j, r }
    }
}

impl<V: Vector, J: StructureMatrix<V>, R: StructureMatrix<V>> StructureMatrix<V> for JMinusR<J, R> {
    #[inline]
    fn apply_add(&self, x: &V, v: &V, alpha: V::Real, out: &mut V) {
        self.j.apply_add(x, v, alpha, out);
        self.r.apply_add(x, v, -alpha, out);
    }
    fn is_constant(&self) -> bool {
        self.j.is_constant() && self.r.is_constant()
    }
    fn derivative_apply_add(&self, x: &V, u: &V, w: &V, alpha: V::Real, out: &mut V) -> bool {
        self.j.derivative_apply_add(x, u, w, alpha, out)
            && self.r.derivative_apply_add(x, u, w, -alpha, out)
    }
    /// Dissipative unless the `R` part is known to be zero (a `MomentumDamping` with `c = 0`,
    /// an all-zero [`Constant`]), or `J` itself is dissipative.
    fn is_dissipative(&self) -> bool {
        self.j.is_dissipative() || !self.r.is_zero()
    }
    fn is_zero(&self) -> bool {
        self.j.is_zero() && self.r.is_zero()
    }
    /// `J`'s block minus `R`'s, when `J` is of the form `[[0, I], [−I, B]]` and `R` acts on the
    /// momenta alone.
    fn momentum_block(&self, n: usize, sink: &mut dyn Sink<V::Real>) -> bool {
        let mut pattern = crate::linalg::Triplets::default();
        if !self.j.momentum_block(n, &mut pattern) {
            return false;
        }
        let mut negated = ScaledSink {
            inner: &mut pattern,
            factor: -V::Real::one(),
        };
        if !self.r.momentum_only(n, &mut negated) {
            return false;
        }
        for (r, c, v) in pattern.entries {
            sink.add(r, c, v);
        }
        true
    }
}

/// Linear damping of the momenta, `R = c · diag(0, I)` on `x = (q, p)`, `q, p ∈ Rᵈ`, `n = 2d`,
/// `c ≥ 0`: the dissipative part of `JMinusR::new(Canonical, MomentumDamping::new(c))`, i.e.
/// `p' = −∇_q H − c ∇_p H` (viscous friction on every particle).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct MomentumDamping<T> {
    /// The damping coefficient `c ≥ 0`.
    pub c: T,
}

impl<T: Real> MomentumDamping<T> {
    /// `R = c · diag(0, I)`; [`SetupError::InvalidParameter`](crate::error::SetupError::InvalidParameter) unless `c` is finite and `c ≥ 0`
    /// (so that `R ⪰ 0`).
    pub fn new(c: T) -> Result<Self, crate::error::SetupError> {
        if c.is_finite() && c >= T::zero() {
            Ok(Self { c })
        } else {
            Err(crate::error::SetupError::InvalidParameter {
                name: "damping coefficient".into(),
                value: c.to_f64_lossy(),
                requirement: "finite and non-negative",
            })
        }
    }
}

impl<T: Real, V: Vector<Real = T>> StructureMatrix<V> for MomentumDamping<T> {
    #[inline]
    fn apply_add(&self, _x: &V, v: &V, alpha: T, out: &mut V) {
        let v = v.as_slice();
        let d = v.len() / 2;
        ops::axpy(&mut out.as_mut_slice()[d..], alpha * self.c, &v[d..]);
    }
    fn is_constant(&self) -> bool {
        true
    }
    fn is_dissipative(&self) -> bool {
        self.c > T::zero()
    }
    fn is_zero(&self) -> bool {
        self.c == T::zero()
    }
    /// `C = c I`.
    fn momentum_only(&self, n: usize, sink: &mut dyn Sink<T>) -> bool {
        for i in 0..n / 2 {
            sink.add(i, i, self.c);
        }
        true
    }
}

/// The Lie–Poisson structure of `so(3)*`: `M(y) = ŷ`, `ŷ v = y × v`
/// (`ŷ = [[0, −y₃, y₂], [y₃, 0, −y₁], [−y₂, y₁, 0]]`), state-dependent and skew. `|y|²` is a
/// Casimir. With `H = ½ Σ yᵢ²/Iᵢ` it is the free rigid body (GNI §IV.1, §VII.5).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct LiePoissonSo3;

impl<V: Vector> StructureMatrix<V> for LiePoissonSo3 {
    #[inline]
    fn apply_add(&self, x: &V, v: &V, alpha: V::Real, out: &mut V) {
        let (y, v) = (x.as_slice(), v.as_slice());
        let o = out.as_mut_slice();
        o[0] = o[0] + alpha * (y[1] * v[2] - y[2] * v[1]);
        o[1] = o[1] + alpha * (y[2] * v[0] - y[0] * v[2]);
        o[2] = o[2] + alpha * (y[0] * v[1] - y[1] * v[0]);
    }
    /// `M(y)` is linear in `y`: `DM(y)[u] w = u × w`.
    fn derivative_apply_add(&self, _x: &V, u: &V, w: &V, alpha: V::Real, out: &mut V) -> bool {
        self.apply_add(u, w, alpha, out);
        true
    }
}
