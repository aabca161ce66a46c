//! The mechanical form of a model, read from its declarations and checked against its
//! evaluations: what lets implicit flows eliminate the momenta from their Newton systems.

use super::{Hamiltonian, HolonomicConstraint, Model, StructureMatrix};
use crate::error::SetupError;
use crate::linalg::Triplets;
use crate::real::Real;
use crate::vector::{Vector, ops};

/// A model of mechanical form on `x = (q, p)`, `q, p ∈ R^{n_q}`:
///
/// ```text
/// H(q, p) = ½ Σᵢ wᵢ pᵢ² + V(q),     M = [[0, I], [−I, B]] (B constant),     g = g(q),
/// ```
///
/// so `q' = W⁻¹ p`, `p' = −∇V(q) + B W⁻¹ p − G_qᵀ λ` with `W⁻¹ = diag(w)`. The momenta then
/// enter an implicit step linearly: the implicit midpoint rule's `p̄ = W δq / h` (from
/// `δq = h W⁻¹ p̄`) eliminates them, and its Newton system shrinks from `n + m` to `n_q + m`
/// unknowns with the matrix (rows scaled by `(h/2) W⁻¹`)
///
/// ```text
/// [ I − (h/2) W⁻¹ B + (h²/4) W⁻¹ ∇²V(q̄)    (h²/2) W⁻¹ G_qᵀ ]
/// [ G_q(q + δq)                              0              ]
/// ```
///
/// whose sparsity is that of `B`, `∇²V` and `G_q` (for a chain under gravity: diagonal plus the
/// constraint rows, factored in linear time). Read by [`MechanicalForm::of`] from
/// [`Hamiltonian::kinetic_inverse_mass`], [`StructureMatrix::momentum_block`],
/// [`Hamiltonian::hessian_pattern`] and [`HolonomicConstraint::jacobian_entries`].
#[derive(Debug, Clone, PartialEq)]
pub struct MechanicalForm<T> {
    /// `n_q = n/2`.
    pub positions: usize,
    /// `w = diag W⁻¹` (`n_q` entries).
    pub inverse_mass: Vec<T>,
    /// The entries of `B` (`n_q × n_q`; duplicates are summed).
    pub momentum_block: Vec<(usize, usize, T)>,
    /// The positions `(i, j)`, `i, j < n_q`, where `∇²V` can be non-zero; `None`: dense.
    pub hessian_pattern: Option<Vec<(usize, usize)>>,
    /// The positions `(constraint, i)` where `G_q` can be non-zero; `None`: dense.
    pub constraint_pattern: Option<Vec<(usize, usize)>>,
}

impl<T: Real> MechanicalForm<T> {
    /// The mechanical form of `system` with Hamiltonian `inner` (the system's own, or the one
    /// an inner flow integrates), `Ok(None)` when the model does not declare one (or `n` is
    /// odd). A declaration is checked at `x0` against the model's evaluations — `M` applied
    /// to a probe vector, the momentum part of `∇H` and of `∇²H`, `G` applied to a momentum
    /// direction — and a contradiction beyond rounding is a [`SetupError::Declaration`].
    pub fn of<V, Sys, K>(system: &Sys, inner: &K, x0: &V) -> Result<Option<Self>, SetupError>
    where
        V: Vector<Real = T>,
        Sys: Model<V>,
        K: Hamiltonian<V>,
    {
        let n = x0.len();
        if n == 0 || !n.is_multiple_of(2) {
            return Ok(None);
        }
        let nq = n / 2;
        let mut w = vec![T::zero(); nq];
        if !inner.kinetic_inverse_mass(&mut w) {
            return Ok(None);
        }
        let mut block = Triplets::default();
        if !system.structure().momentum_block(n, &mut block) {
            return Ok(None);
        }
        if let Some(&(r, c, _)) = block.entries.iter().find(|e| e.0 >= nq || e.1 >= nq) {
            return Err(declaration(format!(
                "momentum block entry ({r}, {c}) outside {nq} x {nq}"
            )));
        }
        let form = Self {
            positions: nq,
            inverse_mass: w,
            momentum_block: block.entries,
            hessian_pattern: hessian_pattern(inner, n),
            constraint_pattern: constraint_pattern(system.constraint(), x0, nq)?,
        };
        form.check(system, inner, x0)?;
        Ok(Some(form))
    }

    /// Checks the declaration at `x0` (see [`of`](Self::of)).
    fn check<V, Sys, K>(&self, system: &Sys, inner: &K, x0: &V) -> Result<(), SetupError>
    where
        V: Vector<Real = T>,
        Sys: Model<V>,
        K: Hamiltonian<V>,
    {
        let nq = self.positions;
        let x = x0.as_slice();
        // A probe with distinct, irregular entries of order one.
        let mut v = x0.zeros_like();
        for (i, e) in v.as_mut_slice().iter_mut().enumerate() {
            *e = T::lit(1.0 + ((i * 7919) % 97) as f64 / 97.0);
        }
        let mut out = x0.zeros_like();
        let mut expected = vec![T::zero(); 2 * nq];
        let tol = |scale: T| T::lit(64.0) * T::epsilon() * (T::one() + scale);
        // M v = (v_p, −v_q + B v_p).
        system.structure().apply(x0, &v, &mut out);
        let (vq, vp) = v.as_slice().split_at(nq);
        expected[..nq].copy_from_slice(vp);
        for (e, &q) in expected[nq..].iter_mut().zip(vq) {
            *e = -q;
        }
        for &(r, c, b) in &self.momentum_block {
            expected[nq + r] = expected[nq + r] + b * vp[c];
        }
        let scale = ops::norm_inf(&expected);
        if let Some(i) = first_mismatch(out.as_slice(), &expected, tol(scale)) {
            return Err(declaration(format!(
                "M v = (v_p, -v_q + B v_p) fails at component {i}"
            )));
        }
        // ∇H(x0)_p = W⁻¹ p.
        inner.gradient(x0, &mut out);
        for (e, (&wi, &p)) in expected[nq..]
            .iter_mut()
            .zip(self.inverse_mass.iter().zip(&x[nq..]))
        {
            *e = wi * p;
        }
        let scale = ops::norm_inf(&expected[nq..]);
        if let Some(i) = first_mismatch(&out.as_slice()[nq..], &expected[nq..], tol(scale)) {
            return Err(declaration(format!(
                "the momentum part of grad H is not W^-1 p at component {}",
                nq + i
            )));
        }
        // ∇²H (0, v_p) = (0, W⁻¹ v_p), when the Hessian is given.
        v.as_mut_slice()[..nq]
            .iter_mut()
            .for_each(|e| *e = T::zero());
        if inner.hessian_apply(x0, &v, &mut out) {
            expected[..nq].iter_mut().for_each(|e| *e = T::zero());
            for (e, (&wi, &p)) in expected[nq..]
                .iter_mut()
                .zip(self.inverse_mass.iter().zip(&v.as_slice()[nq..]))
            {
                *e = wi * p;
            }
            let scale = ops::norm_inf(&expected);
            if let Some(i) = first_mismatch(out.as_slice(), &expected, tol(scale)) {
                return Err(declaration(format!(
                    "the Hessian of H on momenta is not diag(W^-1) at component {i}"
                )));
            }
        }
        // G (0, v_p) = 0: the constraints depend on positions only.
        let m = system.constraint().dim();
        let mut gv = vec![T::zero(); m];
        system.constraint().jacobian_apply(x0, &v, &mut gv);
        if let Some(i) = gv.iter().position(|e| *e != T::zero()) {
            return Err(declaration(format!(
                "constraint {i} depends on the momenta (G (0, v_p) = {})",
                gv[i].to_f64_lossy()
            )));
        }
        Ok(())
    }
}

fn declaration(what: String) -> SetupError {
    SetupError::Declaration {
        what: format!("mechanical form: {what}"),
    }
}

/// The first index where `a` and `b` differ by more than `tol` (or either is not finite).
fn first_mismatch<T: Real>(a: &[T], b: &[T], tol: T) -> Option<usize> {
    a.iter()
        .zip(b)
        .position(|(&x, &y)| (x - y).abs().is_nan() || (x - y).abs() > tol)
}

/// `∇²V`'s pattern: the position block of the declared Hessian pattern.
fn hessian_pattern<V: Vector, K: Hamiltonian<V>>(
    inner: &K,
    n: usize,
) -> Option<Vec<(usize, usize)>> {
    let nq = n / 2;
    let mut all = Vec::new();
    if !inner.hessian_pattern(n, &mut all) {
        return None;
    }
    all.retain(|&(r, c)| r < nq && c < nq);
    all.sort_unstable();
    all.dedup();
    Some(all)
}

/// `G_q`'s pattern from the constraint's entries at `x0`; an entry on a momentum column is a
/// [`SetupError::Declaration`].
fn constraint_pattern<V: Vector, C: HolonomicConstraint<V>>(
    constraint: &C,
    x0: &V,
    nq: usize,
) -> Result<Option<Vec<(usize, usize)>>, SetupError> {
    let mut entries = Triplets::default();
    if !constraint.jacobian_entries(x0, &mut entries) {
        return Ok(None);
    }
    if let Some(&(r, c, _)) = entries.entries.iter().find(|e| e.1 >= nq) {
        return Err(declaration(format!(
            "constraint {r} has a Jacobian entry on momentum {c}"
        )));
    }
    let mut pattern: Vec<_> = entries.entries.iter().map(|&(r, c, _)| (r, c)).collect();
    pattern.sort_unstable();
    pattern.dedup();
    Ok(Some(pattern))
}
