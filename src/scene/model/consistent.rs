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
//! force `F`) is `p_c = p − Gᵀ S⁻¹ G W⁻¹ p` (kinetic-metric orthogonal: what is left moves along
//! the constraints), the inconsistent part `p_i = p − p_c` the projection's impulse. The flight's
//! closed-form dissipation per body — `Q(p, F) = γ w (I₁ |p|² + φ² p·F + I₃ |F|²)` under a
//! force, `½ w (1 − e^{−2γt}) |p|²` without, a quadratic form — splits as `Q(p_c) + 2B(p_c, p_i)
//! + Q(p_i)`; the account books `Q(p, F) − Q(p_i, F_i)`, clamped at zero. A body at rest books
//! `0` (its momentum and force are all impulse and normal force); a block sliding on a floor
//! books exactly the kinetic energy its damper takes (its `p_c` and `F_i` are orthogonal); in
//! motion the account is the flight's own to the scheme's order. `Q(p_c)` alone, tried first,
//! is first order when bodies of different damping rates share a constraint (the constraint
//! changes the consistent motion's decay; the cross term carries the step's symmetric
//! cancellation): on a double pendulum of masses 1 and 3 under `c = 0.5` its budget error fell
//! 0.175, 0.057, 0.021 for `h` = 0.01, 0.005, 0.0025, against 0.120, 0.030, 0.0074 now.
//! The dashpots take the same account (`dashpot.rs`, [`ConsistentMomentum`]).
//!
//! **Cost.** A projection evaluates its inner flow once per Newton iteration, from the same
//! positions `q` and sub-step `t` with momenta that differ by the multiplier's impulse `Gᵀδλ`
//! alone — whose consistent part is zero. So the consistent parts are computed (one
//! factorization of `S`, two solves) at the first evaluation of each `(q, t)` and reused by the
//! iterations that follow; a changed state (`prepare`, a checkpoint) forgets them. When no two
//! constraints share a body (`S` diagonal: a pendulum, particles each on its sphere, a block on
//! a floor) the account is summed in closed form without forming `p_c` (each body's
//! inconsistent part is `g_rb μ_r`; `removed_diagonal`): on ten damped particles on a sphere
//! extrapolated to order 12 the account was 31% of the run's instructions and is 17% with it
//! (`valgrind --tool=callgrind lieflow run` of `scenes/shell_damped.toml` at `order = 12`,
//! `dt = 1`, `t_end = 600`: 307.0M → 255.6M).

use super::SceneModel;
use super::dashpot::ConsistentMomentum;
use super::flight::{BodyBooks, DampingAccount, body3, dot3};
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
    Some(Box::new(ConsistentAccount::new(model.clone())))
}

/// The consistent momentum for `model`'s dashpots, when they join constrained bodies and it
/// runs in `f64` (see [`ConsistentMomentum`]).
pub(crate) fn consistent_momentum<T: Real>(
    model: &Arc<SceneModel<T>>,
) -> Option<Box<dyn ConsistentMomentum>> {
    model.dashpots.as_ref()?;
    consistent_projector(model)
}

/// The constraint-consistent part of a momentum or a force direction of `model`
/// (`p − Gᵀ S⁻¹ G W⁻¹ p`), when it is constrained and runs in `f64`: the hinge dampers act
/// along it.
pub(crate) fn consistent_projector<T: Real>(
    model: &Arc<SceneModel<T>>,
) -> Option<Box<dyn ConsistentMomentum>> {
    if model.m == 0 {
        return None;
    }
    let model = (model as &dyn Any).downcast_ref::<Arc<SceneModel<f64>>>()?;
    Some(Box::new(ConsistentAccount::new(model.clone())))
}

/// The diagonal case's multipliers of `p` and `f` at `q`: `μ_r = G_r W⁻¹ p / S_rr`, `ν_r`
/// likewise for `f`, `S_rr = Σ_b w_b |g_rb|²` (in `scratch`: `μ`, `ν`, `S`'s diagonal), the
/// gradients' `(row, body, g_rb)` left in `walk`.
fn diagonal_multipliers<'a>(
    model: &SceneModel<f64>,
    q: &[f64],
    p: &[f64],
    f: &[f64],
    scratch: [&'a mut Vec<f64>; 3],
    walk: &mut Vec<(usize, usize, [f64; 3])>,
) -> (&'a [f64], &'a [f64]) {
    let (d, w) = (model.dim, &model.inv_masses);
    let [mu, nu, sr] = scratch;
    mu.iter_mut()
        .chain(nu.iter_mut())
        .chain(sr.iter_mut())
        .for_each(|x| *x = 0.0);
    walk.clear();
    model.for_each_gradient(q, |r, b, g| {
        let (pb, fb) = (body3(p, b, d), body3(f, b, d));
        mu[r] += w[b] * dot3(g, pb);
        nu[r] += w[b] * dot3(g, fb);
        sr[r] += w[b] * dot3(g, g);
        walk.push((r, b, g));
    });
    for r in 0..model.m {
        mu[r] /= sr[r];
        nu[r] /= sr[r];
    }
    (mu, nu)
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
    /// The multipliers of `p`, of `f` (the diagonal path) and `S`'s diagonal (the diagonal
    /// path).
    mu: Vec<f64>,
    nu: Vec<f64>,
    s: Vec<f64>,
    /// The gradients' `(row, body, g_rb)` of the diagonal path.
    walk: Vec<(usize, usize, [f64; 3])>,
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
    fn new(model: Arc<SceneModel<f64>>) -> Self {
        Self {
            model,
            gram: None,
            q: Vec::new(),
            factored: false,
            failed: false,
            kept: None,
            booked: 0.0,
            mu: Vec::new(),
            nu: Vec::new(),
            s: Vec::new(),
            walk: Vec::new(),
            p: Vec::new(),
            f: Vec::new(),
        }
    }

    /// Whether `S` has a diagonal pattern (no two constraints share a body), its structure
    /// built at the first call (from `q`); `None` when it cannot be built.
    fn is_diagonal(&mut self, q: &[f64]) -> Option<bool> {
        if self.gram.is_none() {
            let model = &*self.model;
            match MassGram::new(model, q) {
                Ok(g) => self.gram = Some(g),
                Err(_) => {
                    self.failed = true;
                    return None;
                }
            }
            self.mu = vec![0.0; model.m];
            self.nu = vec![0.0; model.m];
            self.s = vec![0.0; model.m];
        }
        Some(self.gram.as_ref()?.is_diagonal())
    }

    /// The account of a diagonal `S` in closed form, nothing written but the multipliers:
    /// each body is in at most one row `r`, so its inconsistent parts are `g_rb μ_r` and
    /// `g_rb ν_r` (`μ_r = G_r W⁻¹ p / S_rr`, `ν_r` likewise for the force), and the booking is
    /// `Σ_b Q_b(p_b, F_b) − Σ_(r,b) Q_b(g_rb μ_r, g_rb ν_r)`, clamped at zero: the same as
    /// [`make_consistent`](Self::make_consistent) and the body loop of `removed`, without
    /// forming `p_c`, `F_c` (one walk over the gradients, kept, and one over the bodies).
    fn removed_diagonal(&mut self, q: &[f64], p: &[f64], books: &BodyBooks) -> f64 {
        let model = &*self.model;
        let d = model.dim;
        let forces = &books.forces;
        let walk = &mut self.walk;
        let (mu, nu) = diagonal_multipliers(
            model,
            q,
            p,
            forces,
            [&mut self.mu, &mut self.nu, &mut self.s],
            walk,
        );
        // Q_b at the parts themselves (not |g|² times the form at μ, ν): a body whose
        // momentum and force are all along g books exactly zero.
        let mut inconsistent = 0.0;
        for &(r, b, g) in walk.iter() {
            let (m, n) = (mu[r], nu[r]);
            inconsistent += books.forms[b].eval(
                [g[0] * m, g[1] * m, g[2] * m],
                [g[0] * n, g[1] * n, g[2] * n],
            );
        }
        let own: f64 = books
            .forms
            .iter()
            .enumerate()
            .map(|(b, form)| form.eval(body3(p, b, d), body3(forces, b, d)))
            .sum();
        (own - inconsistent).max(0.0)
    }

    /// `p`, `f` made consistent at `q` (`p ← p − Gᵀ S⁻¹ G W⁻¹ p`); `None` when `S` cannot be
    /// factored there.
    fn make_consistent(&mut self, q: &[f64], with_force: bool) -> Option<()> {
        if !self.factored || self.q.as_slice() != q {
            self.is_diagonal(q)?;
        }
        let model = &*self.model;
        if !self.factored || self.q.as_slice() != q {
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
            // μ_r = (G_r W⁻¹ v)/S_rr for both vectors in one pass, then v −= Gᵀμ in another.
            let (mu, nu) = diagonal_multipliers(
                model,
                q,
                &self.p,
                &self.f,
                [&mut self.mu, &mut self.nu, &mut self.s],
                &mut self.walk,
            );
            model.gradient_transpose_add(q, mu, -1.0, &mut self.p);
            model.gradient_transpose_add(q, nu, -1.0, &mut self.f);
            return Some(());
        }
        let vectors = if with_force {
            [Some(&mut self.p), Some(&mut self.f)]
        } else {
            [Some(&mut self.p), None]
        };
        for v in vectors.into_iter().flatten() {
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

    fn removed(&mut self, t: f64, q: &[f64], p: &[f64], books: &BodyBooks) -> Option<f64> {
        if self.failed {
            return None;
        }
        self.kept = None;
        if self.is_diagonal(q)? {
            self.booked = self.removed_diagonal(q, p, books);
            self.q.clear();
            self.q.extend_from_slice(q);
            self.kept = Some(t);
            return Some(self.booked);
        }
        self.booked = self.removed_general(q, p, books)?;
        self.kept = Some(t);
        Some(self.booked)
    }

    fn forget(&mut self) {
        self.kept = None;
    }
}

impl ConsistentAccount {
    /// The account through the consistent parts `p_c`, `F_c` themselves (any `S`).
    fn removed_general(&mut self, q: &[f64], p: &[f64], books: &BodyBooks) -> Option<f64> {
        let d = self.model.dim;
        self.p.clear();
        self.p.extend_from_slice(p);
        self.f.clear();
        self.f.extend_from_slice(&books.forces);
        self.make_consistent(q, true)?;
        // The flight's own closed form less that of the inconsistent parts `p − p_c`,
        // `F − F_c` (see the module docs): zero at rest, the flight's own account to the
        // scheme's order in motion, never negative.
        let mut booked = 0.0;
        let (mut pi, mut fi) = ([0.0; 3], [0.0; 3]);
        for (b, form) in books.forms.iter().enumerate() {
            let range = b * d..b * d + d;
            let (pb, fb) = (&p[range.clone()], &books.forces[range]);
            for k in 0..d {
                pi[k] = pb[k] - self.p[b * d + k];
                fi[k] = fb[k] - self.f[b * d + k];
            }
            booked += form.eval(body3(pb, 0, d), body3(fb, 0, d))
                - form.eval(body3(&pi, 0, d), body3(&fi, 0, d));
        }
        Some(booked.max(0.0))
    }
}

impl ConsistentMomentum for ConsistentAccount {
    fn consistent(&mut self, q: &[f64], p: &[f64], out: &mut Vec<f64>) -> bool {
        if self.failed {
            return false;
        }
        self.p.clear();
        self.p.extend_from_slice(p);
        self.f.clear();
        self.f.resize(p.len(), 0.0);
        if self.make_consistent(q, false).is_none() {
            return false;
        }
        out.clear();
        out.extend_from_slice(&self.p);
        true
    }
}

#[cfg(test)]
#[path = "consistent_tests.rs"]
mod tests;
