//! The mass-weighted Gram matrix of the constraints, `A = G(q) W⁻¹ G(q)ᵀ`, assembled on a
//! pattern recorded once and factored by [`AutoLu`] — or, when no two constraints share a body
//! (particles each on its own sphere), inverted as the diagonal it is: the matrix of the initial
//! projection (`project_initial`) and of the peers' index-1 multipliers.

use super::model::SceneModel;
use crate::error::LinearSolveError;
use crate::linalg::{AutoLu, LinearSolver, Sink, SolverChoice, Structure, check_pivots};
use std::collections::HashMap;

/// `A = G W⁻¹ Gᵀ`, `W` the masses: two rows couple where their gradients touch the same body.
pub struct MassGram {
    /// The gradient walk's `(row, body)` in order ([`SceneModel::for_each_gradient`]).
    walk: Vec<(usize, usize)>,
    /// `(walk index e₁, walk index e₂, key index)`: `A[key] += c(e₁) · c(e₂) / m_body`.
    products: Vec<(usize, usize, usize)>,
    /// The pattern of `A`, in assembly order.
    keys: Vec<(usize, usize)>,
    coefs: Vec<[f64; 3]>,
    vals: Vec<f64>,
    lu: AutoLu<f64>,
    /// `A`'s diagonal by row, when `A` is diagonal (then `lu` is not used).
    diagonal: Option<Vec<f64>>,
}

impl MassGram {
    /// Records the pattern at positions `q` (it does not depend on them) and sets up the solver.
    pub fn new(model: &SceneModel, q: &[f64]) -> Result<Self, LinearSolveError> {
        let mut walk = Vec::new();
        model.for_each_gradient(q, |row, body, _| walk.push((row, body)));
        let mut by_body: HashMap<usize, Vec<usize>> = HashMap::new();
        for (e, &(_, b)) in walk.iter().enumerate() {
            by_body.entry(b).or_default().push(e);
        }
        let mut bodies: Vec<_> = by_body.into_iter().collect();
        bodies.sort_unstable();
        let mut key_index: HashMap<(usize, usize), usize> = HashMap::new();
        let (mut keys, mut products) = (Vec::new(), Vec::new());
        for (_, es) in &bodies {
            for &e1 in es {
                for &e2 in es {
                    let key = (walk[e1].0, walk[e2].0);
                    let k = *key_index.entry(key).or_insert_with(|| {
                        keys.push(key);
                        keys.len() - 1
                    });
                    products.push((e1, e2, k));
                }
            }
        }
        let lu = AutoLu::with_structure(model.m, Structure::of_pattern(&keys), SolverChoice::Auto)?;
        let diagonal = (model.m > 0 && keys.len() == model.m && keys.iter().all(|&(i, j)| i == j))
            .then(|| vec![0.0; model.m]);
        Ok(Self {
            diagonal,
            coefs: vec![[0.0; 3]; walk.len()],
            vals: vec![0.0; keys.len()],
            walk,
            products,
            keys,
            lu,
        })
    }

    /// Assembles and factors `A` at positions `q` (no allocation).
    pub fn factor(&mut self, model: &SceneModel, q: &[f64]) -> Result<(), LinearSolveError> {
        self.factor_weighted(model, q, &model.inv_masses)
    }

    /// Assembles and factors `G W⁻¹ Gᵀ` with the inverse masses `inv_masses` in place of the
    /// model's: with unit masses it is `G Gᵀ`, whose rank is the constraints' own — singular
    /// only when they are redundant, whatever the masses.
    pub fn factor_weighted(
        &mut self,
        model: &SceneModel,
        q: &[f64],
        inv_masses: &[f64],
    ) -> Result<(), LinearSolveError> {
        let d = model.dim;
        let mut e = 0;
        let coefs = &mut self.coefs;
        model.for_each_gradient(q, |_, _, c| {
            coefs[e] = c;
            e += 1;
        });
        self.vals.fill(0.0);
        for &(e1, e2, k) in &self.products {
            let (c1, c2) = (self.coefs[e1], self.coefs[e2]);
            let dot = (0..d).fold(0.0, |s, i| s + c1[i] * c2[i]);
            self.vals[k] += dot * inv_masses[self.walk[e1].1];
        }
        if let Some(diag) = &mut self.diagonal {
            for (&(i, _), &v) in self.keys.iter().zip(&self.vals) {
                if !v.is_finite() {
                    return Err(LinearSolveError::NonFinite { row: i, col: i });
                }
                diag[i] = v;
            }
            return check_pivots(diag.len(), |i| diag[i]);
        }
        self.lu.clear();
        for (k, &(i, j)) in self.keys.iter().enumerate() {
            self.lu.add(i, j, self.vals[k]);
        }
        self.lu.factor()
    }

    /// An estimate of `κ₂(A) = λ_max / λ_min` at positions `q` (`A` is symmetric positive
    /// semi-definite): power iteration on `A` for `λ_max` and on `A⁻¹` (the factorization) for
    /// `λ_min`, each from the same deterministic start, to a relative change of 1e-3 or 100
    /// iterations — an estimate from below of each extreme eigenvalue, good to a few digits
    /// unless two eigenvalues cluster (Golub & Van Loan, Matrix Computations, §7.3, §8.2).
    /// `∞` when `A` is singular to working precision.
    pub fn condition_estimate(&mut self, model: &SceneModel, q: &[f64]) -> f64 {
        if self.factor(model, q).is_err() {
            return f64::INFINITY;
        }
        let m = model.m;
        let start: Vec<f64> = (0..m).map(|i| 1.0 + (i as f64 * 0.618).fract()).collect();
        let normalize = |v: &mut [f64]| {
            let n = v.iter().map(|a| a * a).sum::<f64>().sqrt();
            v.iter_mut().for_each(|a| *a /= n);
            n
        };
        let power = |apply: &mut dyn FnMut(&[f64], &mut [f64]) -> bool| -> Option<f64> {
            let mut v = start.clone();
            normalize(&mut v);
            let mut w = vec![0.0; m];
            let mut est = 0.0;
            for _ in 0..100 {
                if !apply(&v, &mut w) {
                    return None;
                }
                let next = normalize(&mut w);
                if !next.is_finite() {
                    return None;
                }
                std::mem::swap(&mut v, &mut w);
                let done = (next - est).abs() <= 1e-3 * next;
                est = next;
                if done {
                    break;
                }
            }
            Some(est)
        };
        let (keys, vals) = (&self.keys, &self.vals);
        let max = power(&mut |v, w| {
            w.fill(0.0);
            for (&(i, j), &a) in keys.iter().zip(vals) {
                w[i] += a * v[j];
            }
            true
        });
        let (lu, diagonal) = (&mut self.lu, &self.diagonal);
        let inv_min = power(&mut |v, w| {
            w.copy_from_slice(v);
            match diagonal {
                Some(diag) => {
                    w.iter_mut().zip(diag).for_each(|(r, d)| *r /= d);
                    true
                }
                None => lu.solve_in_place(w).is_ok(),
            }
        });
        match (max, inv_min) {
            (Some(max), Some(inv)) => max * inv,
            _ => f64::INFINITY,
        }
    }

    /// `A` is diagonal (no two constraints share a body): factoring is a check and solving a
    /// division.
    pub fn is_diagonal(&self) -> bool {
        self.diagonal.is_some()
    }

    /// `rhs ← A⁻¹ rhs` with the last factorization.
    pub fn solve(&mut self, rhs: &mut [f64]) -> Result<(), LinearSolveError> {
        if let Some(diag) = &self.diagonal {
            rhs.iter_mut().zip(diag).for_each(|(r, d)| *r /= d);
            return Ok(());
        }
        self.lu.solve_in_place(rhs)
    }
}
