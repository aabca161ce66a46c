//! The nonlinear system of one Petrov–Galerkin step: the increments `Y_j = h x'(c_j)` and the
//! scaled multipliers `L_j = h λ(c_j)` at the `k` Gauss points.

use super::Tables;
use crate::error::StepError;
use crate::flow::forcing::Forcing;
use crate::nonlinear::NonlinearProblem;
use crate::real::Real;
use crate::system::{Hamiltonian, HolonomicConstraint, Model, StructureMatrix};
use crate::vector::{Vector, ops};
use num_traits::{Float as _, One as _, Zero};

/// Scratch of the step (states of length `n`, multipliers of length `m`).
#[derive(Debug, Clone)]
pub(super) struct Scratch<V: Vector> {
    /// `∇H(x(e_r))`, then `h ∇H + G(x_r)ᵀ L(e_r)`.
    pub(super) grad: V,
    /// `h x'(e_r) = Σ_j ℓ_j(e_r) Y_j`.
    pub(super) dr: V,
    /// `M acc_i`.
    pub(super) f: V,
    /// `acc_i = (1/β_i) Σ_r b_r ℓ_i(e_r) (h ∇H(x_r) + G(x_r)ᵀ L(e_r))`, one per Gauss point.
    pub(super) acc: Vec<V>,
    /// The `∇H` part of `acc_i`, `h z(c_i)`: what the damping acts on.
    pub(super) accz: Vec<V>,
    /// The inputs' part of the increments, `(1/β_i) Σ_r b_r ℓ_i(e_r) h B(x_r) u(t_r)`, one per
    /// Gauss point; empty without inputs.
    pub(super) accu: Vec<V>,
    /// `L(e_r)` and `G(x_r) h x'(e_r)`.
    pub(super) lr: Vec<V::Real>,
    pub(super) cr: Vec<V::Real>,
    /// `x(e_r)` of the last residual, one per quadrature point.
    pub(super) xs: Vec<V>,
}

impl<V: Vector> Scratch<V> {
    /// Room for the inputs' part of `k` stages.
    pub(super) fn forced(&mut self, k: usize) {
        self.accu = vec![self.dr.zeros_like(); k];
    }

    pub(super) fn new(x0: &V, k: usize, s: usize, m: usize) -> Self {
        Self {
            grad: x0.zeros_like(),
            dr: x0.zeros_like(),
            f: x0.zeros_like(),
            acc: vec![x0.zeros_like(); k],
            accz: vec![x0.zeros_like(); k],
            accu: Vec::new(),
            lr: vec![V::Real::zero(); m],
            cr: vec![V::Real::zero(); m],
            xs: vec![x0.zeros_like(); s],
        }
    }
}

/// `F(Y, L)`: for each Gauss point `c_i` (test function `ℓ_i`),
///
/// ```text
/// (a)  Y_i − M acc_i − accu_i = 0,
///      acc_i = (1/β_i) Σ_r b_r ℓ_i(e_r) (h ∇H(x_r) + G(x_r)ᵀ L(e_r))
/// (c)  (1/β_i) Σ_r b_r ℓ_i(e_r) G(x_r) (Σ_j ℓ_j(e_r) Y_j) + g(x_n) = 0
/// ```
///
/// with `x_r = x_n + Σ_j A_rj Y_j` and `accu_i` the inputs' part (`flow/forcing.rs`; none without).
/// The `z`-equation (b) is eliminated: `h z(c_i)` is the `∇H` part of `acc_i` (the L²-projection of `h ∇H(x(t))` onto `P_{k−1}`, whose mass matrix
/// is `diag(β)` in the Lagrange basis at the Gauss points). The `g(x_n)` in (c) — zero on the
/// manifold — makes `Σ_i β_i (c)_i = g(x_{n+1}) = 0` instead of `g(x_{n+1}) = g(x_n)`, so the
/// rounding of each step's solve does not accumulate into a drift of `g`; it adds
/// `g(x_n)·Σβ_iλ_i h`, a rounding-level work, to the energy identity.
pub(super) struct Problem<'a, V: Vector, Sys> {
    pub(super) h: V::Real,
    pub(super) x: &'a V,
    pub(super) tables: &'a Tables<V::Real>,
    pub(super) w: &'a mut Scratch<V>,
    pub(super) system: &'a Sys,
    /// `g(x_n)`.
    pub(super) g0: &'a [V::Real],
    /// The rounding noise of the last residual's state rows.
    pub(super) noise: V::Real,
    /// The step's rounding floor of the state rows from the positions' rounding
    /// ([`PetrovGalerkin::rounding_floor`](super::PetrovGalerkin)).
    pub(super) floor: V::Real,
    /// The inputs, their values at this step's quadrature points evaluated.
    pub(super) forcing: Option<&'a mut Forcing<V>>,
}

impl<V: Vector, Sys: Model<V>> Problem<'_, V, Sys> {
    /// The rounding noise of rows whose terms are at most `scale`: each sums `s` quadrature
    /// terms of about that size, `4 s ε scale`, and never below the step's measured floor.
    pub(super) fn set_noise(&mut self, scale: V::Real) {
        self.noise =
            (V::Real::lit(4.0 * self.tables.s as f64) * V::Real::epsilon() * scale).max(self.floor);
    }

    /// Fills `w.acc` and `w.accz` (and the constraint rows into `out_c`) from `u`.
    pub(super) fn accumulate(&mut self, u: &[V::Real], mut out_c: Option<&mut [V::Real]>) {
        let t = self.tables;
        let (k, s) = (t.k, t.s);
        let n = self.x.len();
        let m = self.w.lr.len();
        let (ys, ls) = u.split_at(k * n);
        for acc in self.w.acc.iter_mut().chain(&mut self.w.accz) {
            ops::fill_zero(acc.as_mut_slice());
        }
        for acc in &mut self.w.accu {
            ops::fill_zero(acc.as_mut_slice());
        }
        if let Some(c) = out_c.as_deref_mut() {
            c.iter_mut().for_each(|v| *v = V::Real::zero());
        }
        let sys = self.system;
        for r in 0..s {
            let row = &t.ell[r * k..(r + 1) * k];
            let arow = &t.a[r * k..(r + 1) * k];
            // x_r (kept for the Schur products) and h x'(e_r) in one pass, L(e_r).
            let xr = self.w.xs[r].as_mut_slice();
            let dr = self.w.dr.as_mut_slice();
            for (d, (xo, dout)) in xr.iter_mut().zip(dr.iter_mut()).enumerate() {
                let (mut xv, mut dv) = (self.x.as_slice()[d], V::Real::zero());
                for j in 0..k {
                    let y = ys[j * n + d];
                    xv = xv + arow[j] * y;
                    dv = dv + row[j] * y;
                }
                *xo = xv;
                *dout = dv;
            }
            self.w.lr.iter_mut().for_each(|v| *v = V::Real::zero());
            for j in 0..k {
                ops::axpy(&mut self.w.lr, row[j], &ls[j * m..(j + 1) * m]);
            }
            let xr = &self.w.xs[r];
            if let Some(forcing) = self.forcing.as_deref_mut() {
                let force = forcing.force_at(r, xr);
                for (i, acc) in self.w.accu.iter_mut().enumerate() {
                    ops::axpy(acc.as_mut_slice(), t.test[r * k + i], force.as_slice());
                }
            }
            sys.hamiltonian().gradient(xr, &mut self.w.grad);
            for gi in self.w.grad.as_mut_slice() {
                *gi = *gi * self.h;
            }
            // `accz` keeps the `∇H` part apart (the damping reads it); `acc` collects `Gᵀ L`.
            for (i, acc) in self.w.accz.iter_mut().enumerate() {
                let wgt = t.test[r * k + i];
                ops::axpy(acc.as_mut_slice(), wgt, self.w.grad.as_slice());
            }
            if m > 0 {
                ops::fill_zero(self.w.grad.as_mut_slice());
                sys.constraint().jacobian_transpose_apply_add(
                    xr,
                    &self.w.lr,
                    V::Real::one(),
                    &mut self.w.grad,
                );
                for (i, acc) in self.w.acc.iter_mut().enumerate() {
                    let wgt = t.test[r * k + i];
                    ops::axpy(acc.as_mut_slice(), wgt, self.w.grad.as_slice());
                }
                if let Some(c) = out_c.as_deref_mut() {
                    sys.constraint()
                        .jacobian_apply(xr, &self.w.dr, &mut self.w.cr);
                    for i in 0..k {
                        let wgt = t.test[r * k + i];
                        ops::axpy(&mut c[i * m..(i + 1) * m], wgt, &self.w.cr);
                    }
                }
            }
        }
        // acc_i = accz_i + the multipliers' part (collected in acc during the loop).
        for (acc, z) in self.w.acc.iter_mut().zip(&self.w.accz) {
            ops::axpy(acc.as_mut_slice(), V::Real::one(), z.as_slice());
        }
    }
}

impl<V: Vector, Sys: Model<V>> NonlinearProblem<V::Real> for Problem<'_, V, Sys> {
    type Error = StepError;

    fn dim(&self) -> usize {
        self.tables.k * (self.x.len() + self.w.lr.len())
    }

    fn noise_floor(&self) -> V::Real {
        self.noise
    }

    fn noisy_rows(&self) -> usize {
        self.tables.k * self.x.len()
    }

    fn residual(&mut self, u: &[V::Real], out: &mut [V::Real]) -> Result<(), StepError> {
        let k = self.tables.k;
        let n = self.x.len();
        let (out_a, out_c) = out.split_at_mut(k * n);
        self.accumulate(u, Some(&mut *out_c));
        let m = self.g0.len();
        for i in 0..k {
            ops::axpy(&mut out_c[i * m..(i + 1) * m], V::Real::one(), self.g0);
        }
        let mut scale = V::Real::zero();
        for i in 0..k {
            self.system
                .structure()
                .apply(self.x, &self.w.acc[i], &mut self.w.f);
            if let Some(accu) = self.w.accu.get(i) {
                ops::axpy(self.w.f.as_mut_slice(), V::Real::one(), accu.as_slice());
            }
            let yi = &u[i * n..(i + 1) * n];
            for ((o, &y), &f) in out_a[i * n..(i + 1) * n]
                .iter_mut()
                .zip(yi)
                .zip(self.w.f.as_slice())
            {
                *o = y - f;
                // Selects, not `max`: no NaN handling in the loop (a non-finite row is
                // reported below).
                let (ya, fa) = (y.abs(), f.abs());
                scale = if ya > scale { ya } else { scale };
                scale = if fa > scale { fa } else { scale };
            }
        }
        self.set_noise(scale);
        if let Some(i) = ops::first_non_finite(out) {
            return Err(StepError::NonFinite { component: i });
        }
        Ok(())
    }
}
