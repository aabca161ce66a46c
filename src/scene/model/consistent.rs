//! The damper's account on the motion the constraints allow.
//!
//! Inside a projected step the free flight runs between the projection's two half-steps, on
//! momenta that cross the constraints: gravity joined to the flight turns a floor's normal
//! velocity from `+g h/2` to `−g h/2` across the step, and the projection takes it back. The
//! flight's exact damping acts on all of it, and its energy — `c g² h³/12` a step for a block at
//! rest on a floor, `(h F_n)²/(2m)` for a stiffly damped bob on a rod — was booked as dissipated
//! though the state never lost it (`H` stays constant at rest). The dynamics are right (the
//! projection makes them so, to the scheme's order); the *account* must be that of the motion
//! the constraints allow, as `../shared/docs/METHOD.md` §8 derives for joint dampers: the damping
//! acting on the constraint-consistent momentum.
//!
//! With `S = G W⁻¹ Gᵀ` at the flight's positions `q`, the consistent part of a momentum `p` (or a
//! force `F`) is `p − Gᵀ S⁻¹ G W⁻¹ p` (kinetic-metric orthogonal: what is left moves along the
//! constraints). The flight's closed-form dissipation per body — `γ w (I₁ |p|² + φ² p·F + I₃ |F|²)`
//! under a force, `½ w (1 − e^{−2γt}) |p|²` without — is evaluated with both replaced by their
//! consistent parts. A body at rest books `0`; a block sliding on a floor books exactly the
//! kinetic energy its damper takes; bodies coupled by constraints with different damping rates
//! book the consistent parts' own flights (the rate differences turn them across the
//! constraints inside the step by `O(h)`, the projection's business).
//!
//! **Cost.** A projection evaluates its inner flow once per Newton iteration, from the same
//! positions `q` and sub-step `t` with momenta that differ by the multiplier's impulse `Gᵀδλ`
//! alone — whose consistent part is zero. So the consistent parts are computed (one
//! factorization of `S`, two solves) at the first evaluation of each `(q, t)` and reused by the
//! iterations that follow; a changed state (`prepare`, a checkpoint) forgets them.

use super::SceneModel;
use super::flight::{BodyBook, DampingAccount};
use crate::real::Real;
use crate::scene::gram::MassGram;
use std::any::Any;
use std::sync::Arc;

/// The consistent account of `model`'s flight, when its damped bodies are constrained and it
/// runs in `f64` (a reference run in another scalar keeps the flight's own account).
pub(crate) fn consistent_account<T: Real>(
    model: &Arc<SceneModel<T>>,
) -> Option<Box<dyn DampingAccount>> {
    if model.m == 0 || model.damping.is_none() {
        return None;
    }
    let model = (model as &dyn Any).downcast_ref::<Arc<SceneModel<f64>>>()?;
    Some(Box::new(ConsistentAccount {
        model: model.clone(),
        gram: None,
        q: Vec::new(),
        factored: false,
        failed: false,
        kept: None,
        booked: 0.0,
        mu: Vec::new(),
        nu: Vec::new(),
        s: Vec::new(),
        p: Vec::new(),
        f: Vec::new(),
    }))
}

/// Workspace of the consistent account: the Gram matrix factored at the last positions.
struct ConsistentAccount {
    model: Arc<SceneModel<f64>>,
    gram: Option<MassGram>,
    /// The positions the Gram matrix is factored at (`factored`), and scratch.
    q: Vec<f64>,
    factored: bool,
    failed: bool,
    /// The sub-step whose consistent parts `p`, `f` are kept (for the positions `q`), and
    /// their booked dissipation.
    kept: Option<f64>,
    booked: f64,
    mu: Vec<f64>,
    /// The second right-hand side's multipliers and `S`'s diagonal (the diagonal path).
    nu: Vec<f64>,
    s: Vec<f64>,
    p: Vec<f64>,
    f: Vec<f64>,
}

impl std::fmt::Debug for ConsistentAccount {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ConsistentAccount")
            .field("factored", &self.factored)
            .finish_non_exhaustive()
    }
}

impl ConsistentAccount {
    /// `p`, `f` made consistent at `q` (`p ← p − Gᵀ S⁻¹ G W⁻¹ p`); `None` when `S` cannot be
    /// factored there.
    fn make_consistent(&mut self, q: &[f64]) -> Option<()> {
        let model = &*self.model;
        let (d, m) = (model.dim, model.m);
        if !self.factored || self.q.as_slice() != q {
            if self.gram.is_none() {
                match MassGram::new(model, q) {
                    Ok(g) => self.gram = Some(g),
                    Err(_) => {
                        self.failed = true;
                        return None;
                    }
                }
                self.mu = vec![0.0; m];
                self.nu = vec![0.0; m];
                self.s = vec![0.0; m];
            }
            let gram = self.gram.as_mut()?;
            // A diagonal `S` (no two constraints share a body: a pendulum, particles each on
            // its sphere, a block on a floor) is summed with the products below instead.
            self.factored = gram.is_diagonal() || gram.factor(model, q).is_ok();
            self.q.clear();
            self.q.extend_from_slice(q);
            if !self.factored {
                return None;
            }
        }
        let gram = self.gram.as_mut()?;
        if gram.is_diagonal() {
            // μ_r = (G_r W⁻¹ v)/S_rr, S_rr = Σ_b |g_rb|²/m_b, for both vectors in one pass,
            // then v −= Gᵀμ in another.
            let w = &model.inv_masses;
            let (mu, nu, sr) = (&mut self.mu, &mut self.nu, &mut self.s);
            mu.iter_mut()
                .chain(nu.iter_mut())
                .chain(sr.iter_mut())
                .for_each(|x| *x = 0.0);
            let (pv, fv) = (&self.p, &self.f);
            model.for_each_gradient(q, |r, b, g| {
                let (mut gp, mut gf, mut gg) = (0.0, 0.0, 0.0);
                for k in 0..d {
                    gp += g[k] * pv[b * d + k];
                    gf += g[k] * fv[b * d + k];
                    gg += g[k] * g[k];
                }
                mu[r] += w[b] * gp;
                nu[r] += w[b] * gf;
                sr[r] += w[b] * gg;
            });
            for r in 0..m {
                mu[r] /= sr[r];
                nu[r] /= sr[r];
            }
            model.gradient_transpose_add(q, mu, -1.0, &mut self.p);
            model.gradient_transpose_add(q, nu, -1.0, &mut self.f);
            return Some(());
        }
        for v in [&mut self.p, &mut self.f] {
            self.mu.iter_mut().for_each(|x| *x = 0.0);
            model.for_each_row_dot(q, v, Some(&model.inv_masses), |r, g| self.mu[r] += g);
            gram.solve(&mut self.mu).ok()?;
            model.gradient_transpose_add(q, &self.mu, -1.0, v);
        }
        Some(())
    }
}

impl DampingAccount for ConsistentAccount {
    fn kept_for(&self, t: f64, q: &[f64]) -> Option<f64> {
        (self.kept == Some(t) && self.q.as_slice() == q).then_some(self.booked)
    }

    fn removed(
        &mut self,
        t: f64,
        q: &[f64],
        p: &[f64],
        force: &dyn Fn(usize) -> [f64; 3],
        book: &BodyBook<'_>,
    ) -> Option<f64> {
        if self.failed {
            return None;
        }
        self.kept = None;
        let d = self.model.dim;
        let bodies = self.model.masses.len();
        self.p.clear();
        self.p.extend_from_slice(p);
        self.f.clear();
        self.f
            .extend((0..bodies).flat_map(|b| force(b).into_iter().take(d)));
        self.make_consistent(q)?;
        let booked = (0..bodies).fold(0.0, |acc, b| {
            acc + book(b, &self.p[b * d..b * d + d], &self.f[b * d..b * d + d])
        });
        self.booked = booked.max(0.0);
        self.kept = Some(t);
        Some(self.booked)
    }

    fn forget(&mut self) {
        self.kept = None;
    }
}
