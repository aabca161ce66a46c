//! Redundant constraints made runnable: drop the rows that depend on the others.

use super::HolonomicConstraint;
use crate::error::SetupError;
use crate::linalg::Sink;
use crate::real::Real;
use crate::vector::{Vector, ops};
use core::cell::RefCell;
use num_traits::{One, Zero};

/// A constraint with its dependent rows removed: an over-constrained mechanism (Bricard's
/// linkage, two parallel cranks, a rod listed twice) made runnable.
///
/// When the constraint gradients are linearly dependent at `x₀` (`G(x₀)` of rank `r < m`) the
/// multipliers are not unique and every multiplier system is singular; the projection refuses
/// such a model ([`SetupError::RankDeficient`]). If the dependence is structural — it persists
/// along the motion, as in a mobile over-constrained linkage whose special geometry gives it a
/// degree of freedom Grübler's count denies — the `r` independent rows define the same
/// configuration manifold near `x₀`, and the dropped rows hold along the motion without being
/// enforced (their residuals stay at the round-off level; check them with
/// [`dropped_residual`](Self::dropped_residual)).
///
/// The rows are chosen by modified Gram–Schmidt (with one reorthogonalization) on the rows of
/// `G(x₀)` in their order: row `i` is dropped when its component orthogonal to the kept rows
/// before it is below `tol · ‖Gᵢ‖` — the QR factorization `Gᵀ = QR` read greedily in the given
/// order (Golub & Van Loan, *Matrix Computations*, 4th ed., §5.2.8), not a column-pivoted,
/// rank-revealing one (§5.4.1): the rows kept are the first independent ones, so put the rows
/// that must be enforced first. A dependent row that is violated at `x₀` (by more than
/// `√ε (1 + ‖Gᵢ‖)`) contradicts the others instead of repeating them and is refused
/// ([`SetupError::InconsistentConstraint`]); a row whose gradient is not finite at `x₀` is
/// refused too ([`SetupError::InvalidParameter`] names the row).
///
/// Setup costs `O(m² n)` (dense); the wrapper then costs one `m`-entry copy per residual or
/// `G v` and one zero-filled expansion per `Gᵀ μ`, with no allocation.
#[derive(Debug)]
pub struct DropDependent<C, T> {
    inner: C,
    /// The kept rows of `inner`, in order.
    keep: Vec<usize>,
    /// The dropped rows of `inner`, in order.
    dropped: Vec<usize>,
    /// Row of `inner` → row here (`None` when dropped).
    row_of: Vec<Option<usize>>,
    /// Full-length scratch (`inner.dim()` entries).
    full: RefCell<Vec<T>>,
}

impl<C, T: Real> DropDependent<C, T> {
    /// Drops the rows of `inner` whose gradients at `x0` depend on the rows before them, with
    /// the relative tolerance `tol` (e.g. `1e-8`: well above the rounding of `G`, well below
    /// the smallest singular value of an independent, well-scaled set).
    pub fn new<V>(inner: C, x0: &V, tol: T) -> Result<Self, SetupError>
    where
        V: Vector<Real = T>,
        C: HolonomicConstraint<V>,
    {
        if !(tol > T::zero() && tol < T::one()) {
            return Err(SetupError::InvalidParameter {
                name: "tol".into(),
                value: tol.to_f64_lossy(),
                requirement: "in (0, 1)",
            });
        }
        if let Some(component) = ops::first_non_finite(x0.as_slice()) {
            return Err(SetupError::NonFiniteState { component });
        }
        let m = inner.dim();
        let mut residual = vec![T::zero(); m];
        inner.residual(x0, &mut residual);
        let mut basis: Vec<Vec<T>> = Vec::new();
        let (mut keep, mut dropped) = (Vec::new(), Vec::new());
        for (i, mut r) in gradient_rows(&inner, x0).into_iter().enumerate() {
            let norm = ops::dot(&r, &r).sqrt();
            if !norm.is_finite() {
                // Not a dependence: a gradient that cannot be evaluated here.
                return Err(SetupError::InvalidParameter {
                    name: format!("gradient of constraint row {i} at the initial state"),
                    value: norm.to_f64_lossy(),
                    requirement: "finite",
                });
            }
            for _ in 0..2 {
                for q in &basis {
                    let c = ops::dot(q, &r);
                    ops::axpy(&mut r, -c, q);
                }
            }
            let rest = ops::dot(&r, &r).sqrt();
            if rest > tol * norm {
                r.iter_mut().for_each(|v| *v = *v / rest);
                basis.push(r);
                keep.push(i);
                continue;
            }
            // Dependent: it must hold at x0 like the rows it repeats.
            let scale = T::one() + norm;
            if residual[i].abs() > T::epsilon().sqrt() * scale || residual[i].is_nan() {
                return Err(SetupError::InconsistentConstraint {
                    constraint: i,
                    residual: residual[i].to_f64_lossy(),
                });
            }
            dropped.push(i);
        }
        let mut row_of = vec![None; m];
        for (k, &i) in keep.iter().enumerate() {
            row_of[i] = Some(k);
        }
        Ok(Self {
            inner,
            keep,
            dropped,
            row_of,
            full: RefCell::new(vec![T::zero(); m]),
        })
    }

    /// The rows of the wrapped constraint that were dropped, in order.
    pub fn dropped(&self) -> &[usize] {
        &self.dropped
    }

    /// The rows kept: row `k` of this constraint is row `kept()[k]` of the wrapped one.
    pub fn kept(&self) -> &[usize] {
        &self.keep
    }

    /// The wrapped constraint.
    pub fn inner(&self) -> &C {
        &self.inner
    }

    /// The minimum-norm multipliers of all the wrapped rows at `x`, from the multipliers `kept`
    /// of the kept rows (e.g. [`Flow::multipliers`](crate::flow::Flow::multipliers)): the same
    /// force `Gᵀλ`, distributed over the redundant rows instead of loaded onto the kept ones —
    /// what a joint-reaction report wants (the motion does not depend on it).
    ///
    /// `λ_full` (zeros at the dropped rows) is projected onto the complement of the null space
    /// of `Gᵀ` at `x`: each dropped row `d` gives the null vector `n_d = e_d − Σ_k c_k e_k` with
    /// `c` from the normal equations `G_K G_Kᵀ c = G_K g_d` of the kept rows `K`, and
    /// `λ = λ_full − N (NᵀN)⁻¹ Nᵀ λ_full` (Golub & Van Loan §5.5 on minimum-norm solutions).
    /// Dense, `O(m² n)` with allocation: for reporting, not for every step. Fails with a typed
    /// error, never silently: [`SetupError::Dimension`] for slices of the wrong length,
    /// [`SetupError::NonFiniteState`] or [`SetupError::InvalidParameter`] for a non-finite `x`
    /// or multiplier, [`SetupError::RankDeficient`] when the kept rows are themselves dependent
    /// at `x`, and [`SetupError::NotDependent`] when a dropped row is no longer a combination
    /// of the kept ones (relative residual above `√ε`: `x` is off the mechanism's motion, where
    /// no redistribution keeps the force).
    pub fn minimum_norm_multipliers<V>(
        &self,
        x: &V,
        kept: &[T],
        out: &mut [T],
    ) -> Result<(), SetupError>
    where
        V: Vector<Real = T>,
        C: HolonomicConstraint<V>,
    {
        let m = self.keep.len() + self.dropped.len();
        if kept.len() != self.keep.len() || out.len() != m {
            return Err(SetupError::Dimension {
                what: format!(
                    "minimum_norm_multipliers: {} kept multipliers and {} outputs for {} kept of {} rows",
                    kept.len(),
                    out.len(),
                    self.keep.len(),
                    m
                ),
            });
        }
        if let Some(component) = ops::first_non_finite(x.as_slice()) {
            return Err(SetupError::NonFiniteState { component });
        }
        if let Some(k) = ops::first_non_finite(kept) {
            return Err(SetupError::InvalidParameter {
                name: format!("multiplier {k}"),
                value: kept[k].to_f64_lossy(),
                requirement: "finite",
            });
        }
        let rows = gradient_rows(&self.inner, x);
        // Cholesky of G_K G_Kᵀ (lower, row-major).
        let k = self.keep.len();
        let mut l = vec![T::zero(); k * k];
        let mut largest = T::zero();
        for i in 0..k {
            for j in 0..=i {
                let mut v = ops::dot(&rows[self.keep[i]], &rows[self.keep[j]]);
                for p in 0..j {
                    v = v - l[i * k + p] * l[j * k + p];
                }
                if i == j {
                    largest = largest.max(v.abs());
                    if v.is_nan() || v <= T::epsilon() * T::lit(64.0) * largest {
                        let ratio = if largest > T::zero() {
                            (v / largest).to_f64_lossy()
                        } else {
                            0.0
                        };
                        return Err(SetupError::RankDeficient {
                            constraint: self.keep[i],
                            ratio,
                        });
                    }
                    l[i * k + i] = v.sqrt();
                } else {
                    l[i * k + j] = v / l[j * k + j];
                }
            }
        }
        // Null vectors n_d, one per dropped row, each checked: G_Kᵀ c must reproduce g_d.
        let mut null: Vec<Vec<T>> = Vec::with_capacity(self.dropped.len());
        for &d in &self.dropped {
            null.push({
                let mut c: Vec<T> = self
                    .keep
                    .iter()
                    .map(|&r| ops::dot(&rows[r], &rows[d]))
                    .collect();
                for i in 0..k {
                    let s = (0..i).fold(c[i], |s, p| s - l[i * k + p] * c[p]);
                    c[i] = s / l[i * k + i];
                }
                for i in (0..k).rev() {
                    let s = (i + 1..k).fold(c[i], |s, p| s - l[p * k + i] * c[p]);
                    c[i] = s / l[i * k + i];
                }
                let mut rest = rows[d].clone();
                for (&r, &ci) in self.keep.iter().zip(&c) {
                    ops::axpy(&mut rest, -ci, &rows[r]);
                }
                let scale = ops::dot(&rows[d], &rows[d]).sqrt();
                let relative = ops::dot(&rest, &rest).sqrt() / scale.max(T::min_positive_value());
                if relative.is_nan() || relative > T::epsilon().sqrt() {
                    return Err(SetupError::NotDependent {
                        constraint: d,
                        residual: relative.to_f64_lossy(),
                    });
                }
                let mut n = vec![T::zero(); m];
                n[d] = T::one();
                for (&r, &ci) in self.keep.iter().zip(&c) {
                    n[r] = -ci;
                }
                n
            });
        }
        // λ_full, then its projection: orthonormalize the null vectors (Gram–Schmidt) and
        // subtract their components.
        out.fill(T::zero());
        for (&r, &v) in self.keep.iter().zip(kept) {
            out[r] = v;
        }
        let mut basis: Vec<Vec<T>> = Vec::new();
        for mut n in null {
            for _ in 0..2 {
                for q in &basis {
                    let c = ops::dot(q, &n);
                    ops::axpy(&mut n, -c, q);
                }
            }
            let norm = ops::dot(&n, &n).sqrt();
            n.iter_mut().for_each(|v| *v = *v / norm);
            basis.push(n);
        }
        for q in &basis {
            let c = ops::dot(q, out);
            ops::axpy(out, -c, q);
        }
        Ok(())
    }

    /// `max |gᵢ(x)|` over the dropped rows: how well the motion keeps the constraints it was
    /// not forced to keep.
    pub fn dropped_residual<V>(&self, x: &V) -> T
    where
        V: Vector<Real = T>,
        C: HolonomicConstraint<V>,
    {
        let mut full = self.full.borrow_mut();
        self.inner.residual(x, &mut full);
        self.dropped
            .iter()
            .fold(T::zero(), |a, &i| a.max(full[i].abs()))
    }
}

/// The rows of `G(x)`, each as `Gᵀ eᵢ` (dense; setup and reporting only).
fn gradient_rows<V: Vector, C: HolonomicConstraint<V>>(c: &C, x: &V) -> Vec<Vec<V::Real>> {
    let mut unit = vec![V::Real::zero(); c.dim()];
    (0..c.dim())
        .map(|i| {
            let mut row = x.zeros_like();
            unit[i] = V::Real::one();
            c.jacobian_transpose_apply(x, &unit, &mut row);
            unit[i] = V::Real::zero();
            row.as_slice().to_vec()
        })
        .collect()
}

impl<V, C> HolonomicConstraint<V> for DropDependent<C, V::Real>
where
    V: Vector,
    C: HolonomicConstraint<V>,
{
    fn dim(&self) -> usize {
        self.keep.len()
    }
    fn residual(&self, x: &V, out: &mut [V::Real]) {
        let mut full = self.full.borrow_mut();
        self.inner.residual(x, &mut full);
        for (o, &i) in out.iter_mut().zip(&self.keep) {
            *o = full[i];
        }
    }
    fn jacobian_apply(&self, x: &V, v: &V, out: &mut [V::Real]) {
        let mut full = self.full.borrow_mut();
        self.inner.jacobian_apply(x, v, &mut full);
        for (o, &i) in out.iter_mut().zip(&self.keep) {
            *o = full[i];
        }
    }
    fn jacobian_transpose_apply_add(&self, x: &V, mu: &[V::Real], alpha: V::Real, out: &mut V) {
        let mut full = self.full.borrow_mut();
        full.fill(V::Real::zero());
        for (&m, &i) in mu.iter().zip(&self.keep) {
            full[i] = m;
        }
        self.inner
            .jacobian_transpose_apply_add(x, &full, alpha, out);
    }
    fn jacobian_entries(&self, x: &V, sink: &mut dyn Sink<V::Real>) -> bool {
        // Renumber the kept rows; drop the entries of the dropped ones.
        struct Renumber<'a, T> {
            row_of: &'a [Option<usize>],
            sink: &'a mut dyn Sink<T>,
        }
        impl<T> Sink<T> for Renumber<'_, T> {
            fn add(&mut self, row: usize, col: usize, value: T) {
                if let Some(Some(r)) = self.row_of.get(row) {
                    self.sink.add(*r, col, value);
                }
            }
        }
        self.inner.jacobian_entries(
            x,
            &mut Renumber {
                row_of: &self.row_of,
                sink,
            },
        )
    }
}
