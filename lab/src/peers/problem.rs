//! The constrained problems the peers solve: the paper's example in closed form and a scene's
//! model, each as an index-1 right-hand side (`μ(x)` from `d²g/dt² = 0`) and an index-3 field.
//!
//! For a scene, `x = (q, p)`, `M = [[0, I], [−I, K − R]]` and position constraints give
//! `(G W⁻¹ Gᵀ) μ = G W⁻¹ ((K − R) v − ∇V) + Ġ v`, `v = W⁻¹ p` (`Ġ v` is `|v_a − v_b|²` for a rod,
//! `|v|²` for a sphere, 0 for planes and pins): one solve per right-hand side with the library's
//! [`MassGram`] (a division when `G W⁻¹ Gᵀ` is diagonal, stack LU up to four rows, the pattern
//! recorded once otherwise).

use faer::Col;
use lieflow::System;
use lieflow::Vector;
use lieflow::port::InputMap;
use lieflow::scene::MassGram;
use lieflow::scene::SceneModel;
use lieflow::system::{Hamiltonian, HolonomicConstraint, StructureMatrix};
use std::cell::RefCell;
use std::sync::Arc;

/// A constrained problem as the peers see it.
pub(super) trait PeerProblem {
    fn n(&self) -> usize;
    fn m(&self) -> usize;
    /// `out = M (∇H + Gᵀλ) + B(x) u(t)` at `(t, x)` (the inputs' term with inputs only).
    fn field(&self, t: f64, x: &[f64], lambda: &[f64], out: &mut [f64]);
    /// The index-1 multiplier `μ(t, x)`.
    fn mu(&self, t: f64, x: &[f64], out: &mut [f64]);
    /// `out = M (∇H + Gᵀμ) + B u(t)`, the index-1 right-hand side (`mu` is scratch of `m`
    /// entries).
    fn index1(&self, t: f64, x: &[f64], mu: &mut [f64], out: &mut [f64]) {
        self.mu(t, x, mu);
        self.field(t, x, mu, out);
    }
    /// LU factorizations per right-hand side of the index-1 ODE (the solve for `μ`).
    fn factorizations_per_rhs(&self) -> u64 {
        0
    }
    /// `g(x)`.
    fn g(&self, x: &[f64], out: &mut [f64]);
    /// `φ(x) = G M ∇H`.
    fn phi(&self, x: &[f64], out: &mut [f64]);
    /// `H(x)`.
    fn energy(&self, x: &[f64]) -> f64;
}

/// The paper's example: `M (a₁, a₂, a₃, a₄) = (a₃, a₄, −a₁, −2a₂)`, `H = (x₃² + x₄²)/2`,
/// `g = (x₁² + x₂² − 1)/2`, `μ = (x₃² + x₄²)/(x₁² + 2x₂²)`.
pub(super) struct Paper;

impl PeerProblem for Paper {
    fn n(&self) -> usize {
        4
    }
    fn m(&self) -> usize {
        1
    }
    fn field(&self, _t: f64, x: &[f64], l: &[f64], out: &mut [f64]) {
        out[0] = x[2];
        out[1] = x[3];
        out[2] = -l[0] * x[0];
        out[3] = -2.0 * l[0] * x[1];
    }
    fn mu(&self, _t: f64, x: &[f64], out: &mut [f64]) {
        out[0] = (x[2] * x[2] + x[3] * x[3]) / (x[0] * x[0] + 2.0 * x[1] * x[1]);
    }
    fn g(&self, x: &[f64], out: &mut [f64]) {
        out[0] = 0.5 * (x[0] * x[0] + x[1] * x[1] - 1.0);
    }
    fn phi(&self, x: &[f64], out: &mut [f64]) {
        out[0] = x[0] * x[2] + x[1] * x[3];
    }
    fn energy(&self, x: &[f64]) -> f64 {
        0.5 * (x[2] * x[2] + x[3] * x[3])
    }
}

/// Workspace of a scene's peer problem.
struct SceneWork {
    x: Col<f64>,
    t1: Col<f64>,
    t2: Col<f64>,
    rhs: Vec<f64>,
    grad: Vec<f64>,
    /// Velocities `W⁻¹ p`.
    vel: Vec<f64>,
    full: Col<f64>,
    mu: Vec<f64>,
    gram: MassGram,
    /// `u(t)` and scratch of the inputs' product.
    u: Vec<f64>,
    scratch: Col<f64>,
}

/// A scene as a peer problem (see the module docs).
pub(super) struct ScenePeer {
    model: Arc<SceneModel>,
    /// `model` as a system, for the hidden constraint.
    system: System<Arc<SceneModel>, Arc<SceneModel>, Arc<SceneModel>>,
    work: RefCell<SceneWork>,
}

impl ScenePeer {
    pub(super) fn new(model: Arc<SceneModel>, x0: &[f64]) -> Result<Self, String> {
        let m = model.constraint_rows();
        let n = model.state_len();
        let gram = MassGram::new(&model, &x0[..n / 2]).map_err(|e| e.to_string())?;
        let zeros = Col::<f64>::zeros(n);
        Ok(Self {
            work: RefCell::new(SceneWork {
                x: zeros.clone(),
                t1: zeros.clone(),
                t2: zeros,
                rhs: vec![0.0; m],
                grad: vec![0.0; n / 2],
                vel: vec![0.0; n / 2],
                full: Col::<f64>::zeros(n),
                mu: vec![0.0; m],
                gram,
                u: vec![0.0; model.inputs().map_or(0, |i| i.names().len())],
                scratch: Col::<f64>::zeros(n),
            }),
            system: System::new(model.clone(), model.clone(), model.clone()),
            model,
        })
    }
}

impl ScenePeer {
    /// `out += B(x) u(t)` with `x` in `w.x` (nothing without inputs).
    fn inputs_add(&self, w: &mut SceneWork, t: f64, out: &mut Col<f64>) {
        let Some(inputs) = self.model.inputs() else {
            return;
        };
        for (u, s) in w.u.iter_mut().zip(inputs.signals()) {
            *u = s.value(t);
        }
        inputs.map().add_product(&w.x, &w.u, out, &mut w.scratch);
    }

    /// `w.grad ← w.grad − F(q) u(t)`: the inputs' forces join `−∇V` in `μ`'s right-hand side
    /// (`x` in `w.x`).
    fn forces_into_gradient(&self, w: &mut SceneWork, t: f64) {
        if self.model.inputs().is_none() {
            return;
        }
        let nq = self.model.state_len() / 2;
        let mut force = std::mem::replace(&mut w.t2, Col::<f64>::zeros(0));
        force.as_mut_slice().fill(0.0);
        self.inputs_add(w, t, &mut force);
        for (g, &f) in w.grad.iter_mut().zip(&force.as_slice()[nq..]) {
            *g -= f;
        }
        w.t2 = force;
    }

    /// `μ(x)` with `∇V(q) − F(q) u(t)` already in `w.grad`.
    fn mu_from(&self, w: &mut SceneWork, x: &[f64], out: &mut [f64]) {
        let model = &self.model;
        let (n, d) = (model.state_len(), model.space_dim());
        let nq = n / 2;
        // b = G W⁻¹ ((K − R) v − ∇V) + Ġ v: t1 = (0, v) so that M t1 = (v, (K − R) v).
        w.t1.as_mut_slice()[..nq].fill(0.0);
        for i in 0..nq {
            w.t1[nq + i] = model.inv_masses()[i / d] * x[nq + i];
        }
        model.apply(&w.x, &w.t1, &mut w.t2);
        // f = (K − R) v − ∇V, then W⁻¹ f into the q-half of t1 (G acts on positions).
        for i in 0..nq {
            w.t1[i] = model.inv_masses()[i / d] * (w.t2[nq + i] - w.grad[i]);
        }
        w.t1.as_mut_slice()[nq..].fill(0.0);
        HolonomicConstraint::<Col<f64>>::jacobian_apply(model, &w.x, &w.t1, &mut w.rhs);
        for i in 0..nq {
            w.vel[i] = model.inv_masses()[i / d] * x[nq + i];
        }
        model.velocity_curvature_add(&w.vel, &mut w.rhs);
        let ok = w.gram.factor(model, &x[..nq]).is_ok() && w.gram.solve(&mut w.rhs).is_ok();
        if ok {
            out.copy_from_slice(&w.rhs);
        } else {
            out.fill(f64::NAN);
        }
    }
}

impl PeerProblem for ScenePeer {
    fn n(&self) -> usize {
        self.model.state_len()
    }
    fn m(&self) -> usize {
        self.model.constraint_rows()
    }
    fn field(&self, t: f64, x: &[f64], lambda: &[f64], out: &mut [f64]) {
        let mut w = self.work.borrow_mut();
        let w = &mut *w;
        w.x.as_mut_slice().copy_from_slice(x);
        self.model.gradient(&w.x, &mut w.t1);
        self.model
            .jacobian_transpose_apply_add(&w.x, lambda, 1.0, &mut w.t1);
        self.model.apply(&w.x, &w.t1, &mut w.t2);
        let mut field = std::mem::replace(&mut w.t2, Col::<f64>::zeros(0));
        self.inputs_add(w, t, &mut field);
        out.copy_from_slice(field.as_slice());
        w.t2 = field;
    }
    fn mu(&self, t: f64, x: &[f64], out: &mut [f64]) {
        let mut w = self.work.borrow_mut();
        let w = &mut *w;
        w.x.as_mut_slice().copy_from_slice(x);
        w.grad.fill(0.0);
        let nq = self.model.state_len() / 2;
        self.model
            .potential_gradient_add(&x[..nq], 1.0, &mut w.grad);
        self.forces_into_gradient(w, t);
        self.mu_from(w, x, out);
    }
    fn index1(&self, t: f64, x: &[f64], _mu: &mut [f64], out: &mut [f64]) {
        // ∇H once: its q-half is ∇V for μ's right-hand side, all of it for the field.
        let mut w = self.work.borrow_mut();
        let w = &mut *w;
        let nq = self.model.state_len() / 2;
        w.x.as_mut_slice().copy_from_slice(x);
        self.model.gradient(&w.x, &mut w.full);
        w.grad.copy_from_slice(&w.full.as_slice()[..nq]);
        self.forces_into_gradient(w, t);
        let mut mu = std::mem::take(&mut w.mu);
        self.mu_from(w, x, &mut mu);
        self.model
            .jacobian_transpose_apply_add(&w.x, &mu, 1.0, &mut w.full);
        w.mu = mu;
        self.model.apply(&w.x, &w.full, &mut w.t2);
        let mut field = std::mem::replace(&mut w.t2, Col::<f64>::zeros(0));
        self.inputs_add(w, t, &mut field);
        out.copy_from_slice(field.as_slice());
        w.t2 = field;
    }
    fn factorizations_per_rhs(&self) -> u64 {
        // A diagonal G W⁻¹ Gᵀ is divided, not factored.
        u64::from(!self.work.borrow().gram.is_diagonal())
    }
    fn g(&self, x: &[f64], out: &mut [f64]) {
        let mut w = self.work.borrow_mut();
        w.x.as_mut_slice().copy_from_slice(x);
        HolonomicConstraint::<Col<f64>>::residual(&self.model, &w.x, out);
    }
    fn phi(&self, x: &[f64], out: &mut [f64]) {
        let mut w = self.work.borrow_mut();
        let w = &mut *w;
        w.x.as_mut_slice().copy_from_slice(x);
        self.system
            .hidden_constraint(&w.x, &mut w.t1, &mut w.t2, out);
    }
    fn energy(&self, x: &[f64]) -> f64 {
        let mut w = self.work.borrow_mut();
        w.x.as_mut_slice().copy_from_slice(x);
        self.model.energy(&w.x)
    }
}
