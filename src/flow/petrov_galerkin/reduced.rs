//! The Petrov–Galerkin step of a model of mechanical form ([`MechanicalForm`]): the position
//! rows eliminated, Newton on the momentum increments and the multipliers, first by the Schur
//! iteration of `k` stages (no force Jacobian), then by sparse Newton on its pattern
//! ([`Reduced`]).
//!
//! For `H = ½ pᵀW⁻¹p + V(q)`, `M = [[0, I], [−I, B]]` and `g = g(q)`, the position rows of
//! (a) are linear: `Y^q_i = (1/β_i) Σ_r b_r ℓ_i(e_r) h W⁻¹ p(e_r) = h W⁻¹ (p_n + Σ_j Â_ij Y^p_j)`
//! (the quadrature is exact: `ℓ_i A_j` has degree `2k − 1`). What is left are the `k n_q`
//! momentum rows and the `k m` constraint rows in `(Y^p, L)`,
//!
//! ```text
//! F^p_i = Y^p_i + (1/β_i) Σ_r b_r ℓ_i(e_r) (h ∇V(q_r) + G(q_r)ᵀ L(e_r) − h F(q_r) u(t_r)) − B Y^q_i
//! F^c_i = (1/β_i) Σ_r b_r ℓ_i(e_r) G(q_r) h q'(e_r) + g(q_n)
//! ```
//!
//! (the full residual of [`Problem`], read at these rows; `F u` the inputs' forces, when the
//! system is open), whose Newton matrix is
//! `[[I − h Â ⊗ B W⁻¹ + O(h² ∇²V), C], [G, 0]]`: `C` the multipliers' columns
//! `(1/β_i) Σ_r b_r ℓ_i(e_r) ℓ_j(e_r) G(q_r)ᵀ`, `G` the constraint rows through the eliminated
//! `Y^q`. Without the force Jacobian and the constraints' curvature this is the
//! [`SchurIteration`](crate::flow::schur) of `k` stages with `D_d = I_k − h w_d b_d Â`: for a
//! shell of particles a `k × k` block per constraint, for a chain a band. Its contraction is
//! of the size of `h² ‖Â‖² ‖W⁻¹∇²V‖ + h |q'| ‖∇²g‖`.
//!
//! Layout: momentum `d` of stage `i` at `d k + i`, multiplier `a` of stage `i` at
//! `k n_q + a k + i`; the full problem's stage-major `u` is formed from it at every residual.

use super::blocks::ConstraintBlocks;
use super::problem::Problem;
use crate::error::StepError;
use crate::flow::schur::ReducedBlocks;
use crate::linalg::Sink;
use crate::nonlinear::NonlinearProblem;
use crate::real::Real;
use crate::system::{Hamiltonian, HolonomicConstraint, Model};
use crate::vector::{Vector, ops};
use num_traits::{Float as _, One};

/// The reduced step problem over the full one.
pub(super) struct Stages<'a, 'b, V: Vector, Sys> {
    pub(super) full: &'b mut Problem<'a, V, Sys>,
    /// `diag W⁻¹`.
    pub(super) w: &'b [V::Real],
    /// The full problem's unknowns (stage-major): `Y^q` for the rows, the step's end.
    pub(super) u: &'b mut [V::Real],
    /// The entries of `B`.
    pub(super) momentum_block: &'b [(usize, usize, V::Real)],
    /// The constraint blocks from Jacobian entries, for a constraint that lists them.
    pub(super) blocks: Option<&'b mut ConstraintBlocks<V::Real>>,
    /// Whether the blocks keep their last fill ([`ReducedBlocks::keep_matrix`]).
    pub(super) keep: bool,
}

impl<V: Vector, Sys: Model<V>> Stages<'_, '_, V, Sys> {
    /// `(n_q, m, k)`.
    fn dims(&self) -> (usize, usize, usize) {
        (self.w.len(), self.full.g0.len(), self.full.tables.k)
    }

    /// The reduced `z` from the full `u` (its momentum increments and multipliers).
    pub(super) fn compress(&self, z: &mut [V::Real]) {
        let (nq, m, k) = self.dims();
        gather(self.u, z, nq, m, k);
    }

    /// The constraint blocks at the last residual's points, filled if they are stale; `None`
    /// when the constraint does not list its entries (the products go through the model).
    fn blocks(&mut self) -> Option<&mut ConstraintBlocks<V::Real>> {
        let blocks = self.blocks.as_deref_mut()?;
        if self.keep {
            // Those of the kept Schur complement's points.
            return blocks.filled().then_some(blocks);
        }
        let full = &mut *self.full;
        let (h, system) = (full.h, full.system);
        // `grad` is the residual's scratch, free between residuals.
        blocks
            .refresh(system.constraint(), &full.w.xs, h, self.w, &mut full.w.grad)
            .then_some(blocks)
    }

    /// The full `u` from the reduced `z`: `Y^p`, `Y^q = h W⁻¹ (p_n + Â Y^p)`, `L`.
    pub(super) fn expand(&mut self, z: &[V::Real]) {
        match self.full.tables.k {
            1 => self.expand_k::<1>(z),
            2 => self.expand_k::<2>(z),
            3 => self.expand_k::<3>(z),
            _ => self.expand_k::<4>(z),
        }
    }

    /// [`expand`](Self::expand) with `k = K` known to the compiler.
    fn expand_k<const K: usize>(&mut self, z: &[V::Real]) {
        let (nq, m, _) = self.dims();
        let n = 2 * nq;
        let h = self.full.h;
        let p0 = &self.full.x.as_slice()[nq..];
        let t = self.full.tables;
        let zq = &z[..K * nq];
        for i in 0..K {
            let row: [V::Real; K] = core::array::from_fn(|j| t.ahat[i * K + j]);
            let (yq, yp) = self.u[i * n..(i + 1) * n].split_at_mut(nq);
            for ((((q, p), zd), &w), &p0) in yq
                .iter_mut()
                .zip(yp)
                .zip(zq.chunks_exact(K))
                .zip(self.w)
                .zip(p0)
            {
                *p = zd[i];
                *q = h * (w * (p0 + ops::dot(&row, zd)));
            }
        }
        let (ls, zl) = (&mut self.u[K * n..], &z[K * nq..]);
        for (a, za) in zl.chunks_exact(K).take(m).enumerate() {
            for i in 0..K {
                ls[i * m + a] = za[i];
            }
        }
    }

    /// The reduced residual ([`NonlinearProblem::residual`]) with `k = K` known to the
    /// compiler: the stage sums unrolled, the rows of a position (`K` stages) updated together.
    fn rows<const K: usize>(
        &mut self,
        z: &[V::Real],
        out: &mut [V::Real],
    ) -> Result<(), StepError> {
        self.expand_k::<K>(z);
        if let Some(blocks) = self.blocks.as_deref_mut()
            && !self.keep
        {
            blocks.stale();
        }
        let (nq, _, _) = self.dims();
        let n = 2 * nq;
        let full = &mut *self.full;
        let (h, t, sys) = (full.h, full.tables, full.system);
        let x0 = full.x.as_slice();
        let sw = &mut *full.w;
        let ys = &self.u[..K * n];
        ops::fill_zero(out);
        let (out_p, out_c) = out.split_at_mut(K * nq);
        // The momenta of `h x'` are not read (`G` acts on positions).
        ops::fill_zero(&mut sw.dr.as_mut_slice()[nq..]);
        let st: [&[V::Real]; K] = core::array::from_fn(|j| &ys[j * n..j * n + n]);
        let x0 = &x0[..n];
        for r in 0..t.s {
            let row: [V::Real; K] = core::array::from_fn(|j| t.ell[r * K + j]);
            let arow: [V::Real; K] = core::array::from_fn(|j| t.a[r * K + j]);
            let wgt: [V::Real; K] = core::array::from_fn(|i| t.test[r * K + i]);
            // x_r = x_n + Σ_j A_rj Y_j and h x'_q(e_r) = Σ_j ℓ_j(e_r) Y^q_j: one pass over the
            // components, the stages summed in order (the sums of a pass per stage).
            let xr = &mut sw.xs[r].as_mut_slice()[..n];
            for e in 0..n {
                let mut acc = x0[e];
                for j in 0..K {
                    acc = acc + arow[j] * st[j][e];
                }
                xr[e] = acc;
            }
            let dr = &mut sw.dr.as_mut_slice()[..nq];
            for (e, o) in dr.iter_mut().enumerate() {
                let mut acc = row[0] * st[0][e];
                for j in 1..K {
                    acc = acc + row[j] * st[j][e];
                }
                *o = acc;
            }
            for (o, za) in sw.lr.iter_mut().zip(z[K * nq..].chunks_exact(K)) {
                *o = ops::dot(&row, za);
            }
            let xr = &sw.xs[r];
            sys.hamiltonian().gradient(xr, &mut sw.grad);
            for gi in &mut sw.grad.as_mut_slice()[..nq] {
                *gi = *gi * h;
            }
            // The inputs' forces `h (B u)_p(x_r)` join the momentum rows with the force's sign
            // (`F^p = Y^p − (M acc)_p − accu_p`, and these rows hold `acc_q`).
            if let Some(forcing) = full.forcing.as_deref_mut() {
                let force = &forcing.force_at(r, xr).as_slice()[nq..n];
                for (gi, &f) in sw.grad.as_mut_slice()[..nq].iter_mut().zip(force) {
                    *gi = *gi - f;
                }
            }
            // `G_q(x_r)ᵀ L` adds nothing to the momenta: the rows read stay the positions'.
            sys.constraint()
                .jacobian_transpose_apply_add(xr, &sw.lr, V::Real::one(), &mut sw.grad);
            spread::<_, K>(out_p, &wgt, &sw.grad.as_slice()[..nq]);
            sys.constraint().jacobian_apply(xr, &sw.dr, &mut sw.cr);
            spread::<_, K>(out_c, &wgt, &sw.cr);
        }
        // `acc − B Y^q = −(M acc)_p`, then `F^p = Y^p + acc − B Y^q`.
        for &(row, col, v) in self.momentum_block {
            for i in 0..K {
                out_p[row * K + i] = out_p[row * K + i] - v * ys[i * n + col];
            }
        }
        // The noise scale of the full residual's rows: the largest `|Y|` and `|M acc|` of a
        // stage, the position rows (`|Y^q| = |acc_p|`) included. A select, not `max`: a NaN
        // in either makes a non-finite row, which is reported below.
        let (ya, fa) = (ops::norm_inf(&z[..K * nq]), ops::norm_inf(out_p));
        let mut scale = if ya > fa { ya } else { fa };
        for (o, &y) in out_p.iter_mut().zip(z) {
            *o = *o + y;
        }
        for stage in ys.chunks_exact(n) {
            // A NaN is kept (and reported below).
            let yq = ops::norm_inf(&stage[..nq]);
            scale = if (yq > scale) | yq.is_nan() {
                yq
            } else {
                scale
            };
        }
        for (oa, &g) in out_c.chunks_exact_mut(K).zip(full.g0) {
            oa.iter_mut().for_each(|o| *o = *o + g);
        }
        full.set_noise(scale);
        if let Some(i) = ops::first_non_finite(out) {
            return Err(StepError::NonFinite { component: i });
        }
        if !scale.is_finite() {
            // A position increment that reached no row: reported at its momentum row.
            let at = ys.iter().position(|v| !v.is_finite()).unwrap_or(0);
            return Err(StepError::NonFinite {
                component: (at % n) * K + at / n,
            });
        }
        Ok(())
    }
}

impl<V: Vector, Sys: Model<V>> NonlinearProblem<V::Real> for Stages<'_, '_, V, Sys> {
    type Error = StepError;

    fn dim(&self) -> usize {
        let (nq, m, k) = self.dims();
        k * (nq + m)
    }

    fn noise_floor(&self) -> V::Real {
        self.full.noise
    }

    fn noisy_rows(&self) -> usize {
        let (nq, _, k) = self.dims();
        k * nq
    }

    /// The momentum and constraint rows directly, in the reduced layout: per quadrature
    /// point `x_r` (its momenta too, for the gradient), `h x'_q(e_r)`, `L(e_r)`, then
    /// `h ∇_q H(x_r) + G_q(x_r)ᵀ L(e_r)` spread over the stages' momentum rows and
    /// `G(x_r) h x'(e_r)` over their constraint rows, and `F^p_i = Y^p_i + acc_i − B Y^q_i`.
    /// The position rows, satisfied by `Y^q` exactly, are not formed. The same numbers as the
    /// full [`Problem`]'s residual read at these rows, to rounding (`acc_p = Y^q`).
    fn residual(&mut self, z: &[V::Real], out: &mut [V::Real]) -> Result<(), StepError> {
        match self.full.tables.k {
            1 => self.rows::<1>(z, out),
            2 => self.rows::<2>(z, out),
            3 => self.rows::<3>(z, out),
            _ => self.rows::<4>(z, out),
        }
    }
}

impl<V: Vector, Sys: Model<V>> ReducedBlocks<V::Real> for Stages<'_, '_, V, Sys> {
    /// `out_(d,i) += (1/β_i) Σ_r b_r ℓ_i(e_r) [G(q_r)ᵀ Σ_j ℓ_j(e_r) v_(·,j)]_d`.
    fn multiplier_columns_add(&mut self, v: &[V::Real], out: &mut [V::Real]) {
        if let Some(blocks) = self.blocks() {
            blocks.columns_add(v, out);
            return;
        }
        let (nq, m, k) = self.dims();
        let t = self.full.tables;
        let sw = &mut *self.full.w;
        for r in 0..t.s {
            let row = &t.ell[r * k..(r + 1) * k];
            for a in 0..m {
                sw.lr[a] = ops::dot(row, &v[a * k..(a + 1) * k]);
            }
            ops::fill_zero(sw.grad.as_mut_slice());
            self.full.system.constraint().jacobian_transpose_apply_add(
                &sw.xs[r],
                &sw.lr,
                V::Real::one(),
                &mut sw.grad,
            );
            let wgt = &t.test[r * k..(r + 1) * k];
            let gq = &sw.grad.as_slice()[..nq];
            for (od, &g) in out.chunks_exact_mut(k).zip(gq) {
                for (o, &c) in od.iter_mut().zip(wgt) {
                    *o = *o + c * g;
                }
            }
        }
    }

    /// `out_(a,i) = (1/β_i) Σ_r b_r ℓ_i(e_r) [G(q_r) (h W⁻¹ Σ_l (ℓ(e_r)ᵀÂ)_l v_(·,l), 0)]_a`.
    fn constraint_rows(&mut self, v: &[V::Real], out: &mut [V::Real]) {
        if let Some(blocks) = self.blocks() {
            blocks.rows_apply(v, out);
            return;
        }
        let (nq, m, k) = self.dims();
        let h = self.full.h;
        let t = self.full.tables;
        let sw = &mut *self.full.w;
        ops::fill_zero(out);
        for r in 0..t.s {
            let la = &t.ell_ahat[r * k..(r + 1) * k];
            let (dq, dp) = sw.dr.as_mut_slice().split_at_mut(nq);
            for ((o, vd), &w) in dq.iter_mut().zip(v.chunks_exact(k)).zip(self.w) {
                *o = h * (w * ops::dot(la, vd));
            }
            ops::fill_zero(dp);
            self.full
                .system
                .constraint()
                .jacobian_apply(&sw.xs[r], &sw.dr, &mut sw.cr);
            let wgt = &t.test[r * k..(r + 1) * k];
            for (oa, &g) in out[..m * k].chunks_exact_mut(k).zip(&sw.cr) {
                for (o, &c) in oa.iter_mut().zip(wgt) {
                    *o = *o + c * g;
                }
            }
        }
    }

    /// The blocks keep the points of their last fill while `keep` (the residual's points
    /// move on); they are filled again at the next residual's points otherwise.
    fn keep_matrix(&mut self, keep: bool) {
        self.keep = keep;
        if let Some(blocks) = self.blocks.as_deref_mut()
            && !keep
        {
            blocks.stale();
        }
    }

    /// `S = Σ_d G_(b,d) D_d⁻¹ C_(a,d)` from the blocks of the Jacobian entries.
    fn schur_complement_add(&mut self, inv_d: &[V::Real], sink: &mut dyn Sink<V::Real>) -> bool {
        match self.blocks() {
            Some(blocks) => {
                blocks.schur_add(inv_d, sink);
                true
            }
            None => false,
        }
    }
}

/// `out_(e,i) += w_i v_e` for the `K` stages of each `e` (rows `e K + i`).
#[inline(always)]
fn spread<T: Real, const K: usize>(out: &mut [T], w: &[T; K], v: &[T]) {
    for (oe, &ve) in out.chunks_exact_mut(K).zip(v) {
        for (o, &wi) in oe.iter_mut().zip(w) {
            *o = *o + wi * ve;
        }
    }
}

// The kernels above have a case for each stage count up to four.
const _: () = assert!(super::MAX_STAGES <= 4);

/// The momentum and multiplier parts of a stage-major vector of the full problem (stage `i`'s
/// `(q, p)` at `i n`, its multipliers at `k n + i m`) in the reduced layout (momentum `d` of
/// stage `i` at `d k + i`, multiplier `a` at `k n_q + a k + i`).
fn gather<T: Copy>(full: &[T], out: &mut [T], nq: usize, m: usize, k: usize) {
    let n = 2 * nq;
    for i in 0..k {
        let yp = &full[i * n + nq..(i + 1) * n];
        for (d, &v) in yp.iter().enumerate() {
            out[d * k + i] = v;
        }
    }
    let (ls, ol) = (&full[k * n..], &mut out[k * nq..]);
    for a in 0..m {
        for i in 0..k {
            ol[a * k + i] = ls[i * m + a];
        }
    }
}

#[cfg(all(test, feature = "scene"))]
#[path = "reduced_tests.rs"]
mod tests;
