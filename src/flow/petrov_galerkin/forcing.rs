//! The inputs of an open system in the Petrov–Galerkin step: `x' = M (z + Gᵀλ) + B(x) u(t)`.
//!
//! Tested against `v ∈ P_{k−1}`, row (a) gains `∫ ⟨B(x) u(t), v⟩`, by the same `s`-point rule as
//! the other integrals: `acc_i` gains `(1/β_i) Σ_r b_r ℓ_i(e_r) h B(x_r) u(t_n + e_r h)`, added
//! to the step's increments as it stands (not through `M`). With `v = z` the energy identity
//! becomes
//!
//! ```text
//! H(x_{n+1}) − H(x_n) = −h ∫ zᵀRz + S_n,      S_n = h Σ_r b_r z(e_r)ᵀ B(x_r) u(t_r)
//! ```
//!
//! `S_n` the supplied work `∫ yᵀu dt` (`y = Bᵀ∇H`, `z` the L²-projection of `∇H`) by the
//! quadrature, exact to the Newton tolerance as the dissipation is. For a mechanical form with
//! forces on the momenta, `z_p = q'` and `S_n = Σ_r b_r (h q'(e_r))ᵀ (B u)_p(x_r)`: velocity
//! times force. The order `2k` is kept for smooth `u` (the rule has `s ≥ k` points).

use super::Tables;
use crate::error::SetupError;
use crate::port::{InputMap, Signal};
use crate::system::{HolonomicConstraint, Model};
use crate::vector::{Vector, ops};
use num_traits::{Float as _, One, Zero};

/// The input map and signals of a forced Petrov–Galerkin step, with the step's input values.
pub(super) struct Forcing<V: Vector> {
    map: Box<dyn InputMap<V>>,
    signals: Vec<Signal<V::Real>>,
    /// `h u(t_n + e_r h)`, `inputs` entries per quadrature point.
    hu: Vec<V::Real>,
    scratch: V,
    /// `h B(x_r) u(t_r)` of the last [`force_at`](Self::force_at).
    force: V,
}

impl<V: Vector> Forcing<V> {
    /// The inputs `map` driven by `signals`, checked at `x0` for a scheme of `system` (`nq`:
    /// the positions of its mechanical form, when it has one).
    ///
    /// # Errors
    /// [`SetupError::Dimension`] when the signals and the map's inputs differ in number;
    /// [`SetupError::Scheme`] for an input that moves a position of the mechanical form or
    /// what the constraints read (`G(x0) B(x0) ≠ 0`).
    pub(super) fn try_new<Sys: Model<V>>(
        map: Box<dyn InputMap<V>>,
        signals: Vec<Signal<V::Real>>,
        system: &Sys,
        x0: &V,
        nq: Option<usize>,
    ) -> Result<Self, SetupError> {
        if signals.len() != map.inputs() {
            return Err(SetupError::Dimension {
                what: format!(
                    "{} signals for an input map with {} inputs",
                    signals.len(),
                    map.inputs()
                ),
            });
        }
        let mut forcing = Self {
            map,
            signals,
            hu: Vec::new(),
            scratch: x0.zeros_like(),
            force: x0.zeros_like(),
        };
        let mut g = vec![V::Real::zero(); system.constraint().dim()];
        let why = if let Some(nq) = nq
            && let Some(j) =
                forcing.find_column(x0, |b| b.as_slice()[..nq].iter().any(|v| !v.is_zero()))
        {
            Some((
                j,
                "moves a position: the mechanical form's positions are eliminated, so inputs must be forces (B(x) acting on the momenta)",
            ))
        } else {
            forcing
                .find_column(x0, |b| {
                    system.constraint().jacobian_apply(x0, b, &mut g);
                    g.iter().any(|v| !v.is_zero())
                })
                .map(|j| {
                    (
                        j,
                        "moves what the constraints read (G(x0) B(x0) ≠ 0): the energy identity needs the constraint forces to do no work, so inputs must act where the constraints do not",
                    )
                })
        };
        match why {
            Some((j, what)) => Err(SetupError::Scheme {
                what: format!("input {j} of the Petrov–Galerkin scheme {what}"),
            }),
            None => Ok(forcing),
        }
    }

    /// The first input whose column `B(x) e_j` satisfies `pred`.
    fn find_column(&mut self, x: &V, mut pred: impl FnMut(&V) -> bool) -> Option<usize> {
        let k = self.signals.len();
        let mut w = vec![V::Real::zero(); k];
        (0..k).find(|&j| {
            w.iter_mut().for_each(|v| *v = V::Real::zero());
            w[j] = V::Real::one();
            ops::fill_zero(self.force.as_mut_slice());
            self.map
                .add_product(x, &w, &mut self.force, &mut self.scratch);
            pred(&self.force)
        })
    }

    /// Evaluates `h u(t + e_r h)` at the rule's nodes for the step `[t, t + h]`. `Err` names
    /// the first input whose value is not finite: `(input, time, value)`.
    pub(super) fn begin(
        &mut self,
        t: V::Real,
        h: V::Real,
        nodes: &[V::Real],
    ) -> Result<(), (usize, V::Real, V::Real)> {
        let k = self.signals.len();
        self.hu.resize(k * nodes.len(), V::Real::zero());
        for (r, &e) in nodes.iter().enumerate() {
            let tr = t + e * h;
            for (j, s) in self.signals.iter().enumerate() {
                let u = s.value(tr);
                if !u.is_finite() {
                    return Err((j, tr, u));
                }
                self.hu[r * k + j] = h * u;
            }
        }
        Ok(())
    }

    /// `h B(x_r) u(t_r)` at quadrature point `r`, state `xr`.
    pub(super) fn force_at(&mut self, r: usize, xr: &V) -> &V {
        let k = self.signals.len();
        ops::fill_zero(self.force.as_mut_slice());
        self.map.add_product(
            xr,
            &self.hu[r * k..(r + 1) * k],
            &mut self.force,
            &mut self.scratch,
        );
        &self.force
    }
}

impl<V: Vector> Forcing<V> {
    /// `S_n = Σ_i β_i accz_iᵀ accu_i / h` from the last residual's parts (evaluated at the
    /// solution: the dense solve's last residual is its solution's): `h Σ_r b_r z(e_r)ᵀ
    /// B(x_r) u(t_r)`, since `z(e_r) = Σ_i ℓ_i(e_r) z(c_i)` and `accu_i` is the test sum.
    pub(super) fn supplied(
        &self,
        tables: &Tables<V::Real>,
        accz: &[V],
        accu: &[V],
        h: V::Real,
    ) -> V::Real {
        let mut s = V::Real::zero();
        for ((z, f), &beta) in accz.iter().zip(accu).zip(&tables.beta) {
            s = s + beta * ops::dot(z.as_slice(), f.as_slice());
        }
        s / h
    }

    /// `S_n` of a mechanical form from the unknowns `u` (stage-major `Y_j`, the step's start
    /// `x`): `z_p = q'`, so `S_n = Σ_r b_r (h q'(e_r))ᵀ (B u)_p(x_r)`, velocity times force at
    /// each quadrature point (`x_r` formed again in `xr`: the solve may stop without a
    /// residual at its solution).
    pub(super) fn supplied_mechanical(
        &mut self,
        tables: &Tables<V::Real>,
        x: &V,
        u: &[V::Real],
        nq: usize,
        h: V::Real,
        xr: &mut V,
    ) -> V::Real {
        let (k, n) = (tables.k, x.len());
        let mut s = V::Real::zero();
        for r in 0..tables.s {
            xr.copy_from(x);
            for j in 0..k {
                ops::axpy(
                    xr.as_mut_slice(),
                    tables.a[r * k + j],
                    &u[j * n..(j + 1) * n],
                );
            }
            let force = self.force_at(r, xr);
            let f = &force.as_slice()[nq..n];
            let mut power = V::Real::zero();
            for (d, &fd) in f.iter().enumerate() {
                let dq = (0..k).fold(V::Real::zero(), |acc, j| {
                    acc + tables.ell[r * k + j] * u[j * n + d]
                });
                power = power + dq * fd;
            }
            s = s + tables.b[r] * power;
        }
        s / h
    }
}
