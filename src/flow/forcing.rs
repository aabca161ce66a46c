//! The inputs of an open system in an implicit step, `x' = M (∇H + Gᵀλ) + B(x) u(t)`: the
//! input map and signals, the step's input values at the scheme's nodes, and the checks that
//! the inputs act where the scheme can take them.
//!
//! Petrov–Galerkin integrates `B u` against its test functions at its quadrature nodes; the
//! projected midpoint rule and the discrete gradient take it at the step's midpoint
//! (`t_n + h/2`, one node). Each books the supplied work of its own energy identity.

use crate::error::{SetupError, StepError};
use crate::port::{InputMap, Signal};
use crate::real::Real as _;
use crate::system::{HolonomicConstraint, Model};
use crate::vector::{Vector, ops};
use num_traits::{Float as _, One, Zero};

/// The input map and signals of a forced implicit step, with the step's input values.
pub(crate) struct Forcing<V: Vector> {
    map: Box<dyn InputMap<V>>,
    signals: Vec<Signal<V::Real>>,
    /// `s u(t_n + e_r h)` (`s` the scale of [`begin`](Self::begin)), `inputs` entries per node.
    hu: Vec<V::Real>,
    scratch: V,
    /// `s B(x_r) u(t_r)` of the last [`force_at`](Self::force_at).
    force: V,
}

impl<V: Vector> Forcing<V> {
    /// The inputs `map` driven by `signals`, checked at `x0` for the scheme named `scheme` of
    /// `system` (`nq`: the positions of its mechanical form, when it has one).
    ///
    /// # Errors
    /// [`SetupError::Dimension`] when the signals and the map's inputs differ in number;
    /// [`SetupError::Scheme`] for an input that moves a position of the mechanical form or
    /// what the constraints read (`G(x0) B(x0) ≠ 0`).
    pub(crate) fn try_new<Sys: Model<V>>(
        scheme: &str,
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
                what: format!("input {j} of the {scheme} {what}"),
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

    /// Evaluates `s u(t + e_r h)` at the nodes `e_r` of the step `[t, t + h]` (`s = scale`:
    /// `h` where the scheme adds `h B u` to an increment, `1` where it adds `B u` to a field).
    /// `Err` names the first input whose value is not finite ([`StepError::NonFiniteInput`]).
    pub(crate) fn begin(
        &mut self,
        t: V::Real,
        h: V::Real,
        nodes: &[V::Real],
        scale: V::Real,
    ) -> Result<(), StepError> {
        let k = self.signals.len();
        self.hu.resize(k * nodes.len(), V::Real::zero());
        for (r, &e) in nodes.iter().enumerate() {
            let tr = t + e * h;
            for (j, s) in self.signals.iter().enumerate() {
                let u = s.value(tr);
                if !u.is_finite() {
                    return Err(StepError::NonFiniteInput {
                        input: j,
                        t: tr.to_f64_lossy(),
                        value: u.to_f64_lossy(),
                    });
                }
                self.hu[r * k + j] = scale * u;
            }
        }
        Ok(())
    }

    /// `s B(x_r) u(t_r)` at node `r`, state `xr`.
    pub(crate) fn force_at(&mut self, r: usize, xr: &V) -> &V {
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

    /// `s B(x_r) u(t_r)` of the last [`force_at`](Self::force_at).
    pub(crate) fn last_force(&self) -> &V {
        &self.force
    }
}
