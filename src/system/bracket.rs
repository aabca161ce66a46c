//! The pseudo-Poisson bracket of Zhang & Deng (2004, §1) and what it tells about a constraint.
//!
//! For vector-valued `φ: Rⁿ → Rˡ`, `ψ: Rⁿ → Rᵏ`,
//!
//! ```text
//! ⟨φ, ψ⟩ = (∂φ/∂x) M (∂ψ/∂x)ᵀ        (l × k; antisymmetric only if M is)
//! ```
//!
//! With `g` the constraint and `H` the Hamiltonian:
//! - `⟨g, g⟩ = G M Gᵀ` invertible — the **non-degenerate** case; the modified Hamiltonian
//!   `H_N1 = H + μᵀg` with `μ = −⟨g,g⟩⁻¹⟨g,H⟩` keeps `g = 0` weakly invariant.
//! - `⟨g, g⟩ = 0` — the **degenerate** case (every mechanical model): `φ = ⟨g, H⟩ = G M ∇H = 0`
//!   is a hidden constraint and `μ = −⟨φ,g⟩⁻¹⟨φ,H⟩` needs `⟨φ, g⟩` invertible.
//! - neither — redundant constraints or a Casimir of `M`: reported as
//!   [`SetupError::SingularMultiplierMatrix`], never divided by.
//!
//! These are analysis tools (they allocate); the integrators evaluate what they need in place.

use super::Model;
use super::{HolonomicConstraint, StructureMatrix};
use crate::error::SetupError;
use crate::real::Real;
use crate::vector::{Vector, ops};
use num_traits::{Float as _, One, Zero};

/// Which of the paper's two cases a constraint falls in at a given state.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Case {
    /// `⟨g, g⟩ = 0`, `⟨φ, g⟩` invertible: hidden constraint `φ = ⟨g, H⟩ = 0` (mechanics).
    Degenerate,
    /// `⟨g, g⟩` invertible: no hidden constraint (e.g. overdamped, gradient-like dynamics).
    NonDegenerate,
}

/// The bracket `⟨φ, ψ⟩ = Dφ M Dψᵀ` at `x` as an `l × k` column-major matrix.
///
/// `dphi(x, u, out)` writes `Dφ(x) u` (`l` entries); `dpsi_t(x, μ, out)` writes `Dψ(x)ᵀ μ`
/// (overwriting `out`). Column `j` is `Dφ M Dψᵀ e_j`.
pub fn bracket<V, Ms>(
    structure: &Ms,
    x: &V,
    l: usize,
    mut dphi: impl FnMut(&V, &V, &mut [V::Real]),
    k: usize,
    mut dpsi_t: impl FnMut(&V, &[V::Real], &mut V),
) -> Vec<V::Real>
where
    V: Vector,
    Ms: StructureMatrix<V>,
{
    let mut out = vec![V::Real::zero(); l * k];
    let mut e = vec![V::Real::zero(); k];
    let mut w = x.zeros_like();
    let mut u = x.zeros_like();
    for j in 0..k {
        e.iter_mut().for_each(|v| *v = V::Real::zero());
        e[j] = V::Real::one();
        dpsi_t(x, &e, &mut w);
        structure.apply(x, &w, &mut u);
        dphi(x, &u, &mut out[j * l..(j + 1) * l]);
    }
    out
}

/// Bracket computations for one model ([`Model`], e.g. a [`System`](super::System)): `⟨g,g⟩`,
/// `⟨g,H⟩ = φ`, `⟨φ,g⟩`, `⟨φ,H⟩`, the case, and
/// the modified-Hamiltonian multiplier `μ`.
///
/// Brackets with `g` on the right and `g` or `H` on the left are exact. Those with the hidden
/// constraint `φ` on the left need `∂φ/∂x`, which involves `∇²H`, `∂G/∂x` and `∂M/∂x`; they are
/// computed by central differences of `φ` along `M Gᵀ e_j` and `M ∇H` (step `ε^{1/3}` scaled),
/// accurate to about `ε^{2/3}` relative.
#[derive(Debug)]
pub struct Brackets<'a, Sys> {
    sys: &'a Sys,
}

/// `out = G(x)ᵀ μ`: the right factor of every bracket with `g`.
fn transpose_of<V, C>(c: &C) -> impl Fn(&V, &[V::Real], &mut V) + '_
where
    V: Vector,
    C: HolonomicConstraint<V>,
{
    move |x, mu, out| {
        c.jacobian_transpose_apply(x, mu, out);
    }
}

impl<'a, Sys> Brackets<'a, Sys> {
    /// Bracket computations for `sys`.
    pub fn new(sys: &'a Sys) -> Self {
        Self { sys }
    }

    /// `⟨g, g⟩ = G M Gᵀ` (m × m, column-major).
    pub fn g_g<V>(&self, x: &V) -> Vec<V::Real>
    where
        V: Vector,
        Sys: Model<V>,
    {
        let c = self.sys.constraint();
        let m = c.dim();
        bracket(
            self.sys.structure(),
            x,
            m,
            |x, u, out| c.jacobian_apply(x, u, out),
            m,
            transpose_of(c),
        )
    }

    /// `⟨g, H⟩ = G M ∇H`, which is the hidden constraint `φ(x)` (m entries).
    pub fn g_h<V>(&self, x: &V) -> Vec<V::Real>
    where
        V: Vector,
        Sys: Model<V>,
    {
        let mut out = vec![V::Real::zero(); self.sys.constraint().dim()];
        let (mut t1, mut t2) = (x.zeros_like(), x.zeros_like());
        self.sys.hidden_constraint(x, &mut t1, &mut t2, &mut out);
        out
    }

    /// `(∂φ/∂x) u` by central differences.
    fn dphi<V>(&self, x: &V, u: &V, out: &mut [V::Real])
    where
        V: Vector,
        Sys: Model<V>,
    {
        let un = ops::norm_inf(u.as_slice());
        if un == V::Real::zero() {
            ops::fill_zero(out);
            return;
        }
        let s = V::Real::epsilon().cbrt() * (V::Real::one() + ops::norm_inf(x.as_slice())) / un;
        let (mut xp, mut t1, mut t2) = (x.zeros_like(), x.zeros_like(), x.zeros_like());
        let m = out.len();
        let mut fm = vec![V::Real::zero(); m];
        ops::add_scaled(xp.as_mut_slice(), x.as_slice(), s, u.as_slice());
        self.sys.hidden_constraint(&xp, &mut t1, &mut t2, out);
        ops::add_scaled(xp.as_mut_slice(), x.as_slice(), -s, u.as_slice());
        self.sys.hidden_constraint(&xp, &mut t1, &mut t2, &mut fm);
        let two_s = s + s;
        for (o, f) in out.iter_mut().zip(&fm) {
            *o = (*o - *f) / two_s;
        }
    }

    /// `⟨φ, g⟩ = (∂φ/∂x) M Gᵀ` (m × m, column-major), by central differences.
    pub fn phi_g<V>(&self, x: &V) -> Vec<V::Real>
    where
        V: Vector,
        Sys: Model<V>,
    {
        let c = self.sys.constraint();
        let m = c.dim();
        bracket(
            self.sys.structure(),
            x,
            m,
            |x, u, out| self.dphi(x, u, out),
            m,
            transpose_of(c),
        )
    }

    /// `⟨φ, H⟩ = (∂φ/∂x) M ∇H` (m entries), by central differences.
    pub fn phi_h<V>(&self, x: &V) -> Vec<V::Real>
    where
        V: Vector,
        Sys: Model<V>,
    {
        let mut out = vec![V::Real::zero(); self.sys.constraint().dim()];
        let (mut t, mut u) = (x.zeros_like(), x.zeros_like());
        self.sys.vector_field(x, &mut t, &mut u);
        self.dphi(x, &u, &mut out);
        out
    }

    /// Decides the case at `x`: degenerate if `‖⟨g,g⟩‖ ≤ tol · ‖G‖ ‖M Gᵀ‖` (then `⟨φ,g⟩` must be
    /// invertible), non-degenerate if `⟨g,g⟩` is invertible, an error otherwise.
    ///
    /// Invertibility is judged by the pivots of an LU with partial pivoting: the smallest must be
    /// above `rcond` times the largest.
    pub fn case<V>(&self, x: &V, tol: V::Real, rcond: V::Real) -> Result<Case, SetupError>
    where
        V: Vector,
        Sys: Model<V>,
    {
        if let Some(component) = ops::first_non_finite(x.as_slice()) {
            return Err(SetupError::NonFiniteState { component });
        }
        let c = self.sys.constraint();
        let m = c.dim();
        // Scale: largest column of Gᵀ times largest column of M Gᵀ.
        let (mut gt, mut mgt) = (x.zeros_like(), x.zeros_like());
        let mut e = vec![V::Real::zero(); m];
        let (mut gmax, mut mgmax) = (V::Real::zero(), V::Real::zero());
        for j in 0..m {
            e.iter_mut().for_each(|v| *v = V::Real::zero());
            e[j] = V::Real::one();
            c.jacobian_transpose_apply(x, &e, &mut gt);
            self.sys.structure().apply(x, &gt, &mut mgt);
            gmax = gmax.max(ops::norm_inf(gt.as_slice()));
            mgmax = mgmax.max(ops::norm_inf(mgt.as_slice()));
        }
        let gg = self.g_g(x);
        let norm = ops::norm_inf(&gg);
        if norm <= tol * gmax * mgmax * V::Real::lit(x.len() as f64) {
            let pg = self.phi_g(x);
            small_lu(m, pg, rcond).map_err(|(pivot, ratio)| {
                SetupError::SingularMultiplierMatrix {
                    bracket: "<phi,g>",
                    pivot,
                    ratio,
                }
            })?;
            Ok(Case::Degenerate)
        } else {
            match small_lu(m, gg, rcond) {
                Ok(_) => Ok(Case::NonDegenerate),
                Err((_, _)) => {
                    // Redundant constraints make ⟨g,g⟩ singular too: name them when `G Gᵀ`
                    // is singular, before calling it a mix of the two cases.
                    let mut ggt = vec![V::Real::zero(); m * m];
                    for j in 0..m {
                        e.iter_mut().for_each(|v| *v = V::Real::zero());
                        e[j] = V::Real::one();
                        c.jacobian_transpose_apply(x, &e, &mut gt);
                        c.jacobian_apply(x, &gt, &mut ggt[j * m..(j + 1) * m]);
                    }
                    Err(match small_lu(m, ggt, rcond) {
                        Err((constraint, ratio)) => SetupError::RankDeficient { constraint, ratio },
                        Ok(_) => SetupError::MixedCase {
                            norm: norm.to_f64_lossy(),
                        },
                    })
                }
            }
        }
    }

    /// The multiplier `μ` of the modified Hamiltonian `H_N1 = H + μᵀ g` at `x`:
    /// `μ = −⟨g,g⟩⁻¹⟨g,H⟩` (non-degenerate) or `μ = −⟨φ,g⟩⁻¹⟨φ,H⟩` (degenerate).
    pub fn modified_multiplier<V>(&self, x: &V, case: Case) -> Result<Vec<V::Real>, SetupError>
    where
        V: Vector,
        Sys: Model<V>,
    {
        let m = self.sys.constraint().dim();
        let (a, b, name) = match case {
            Case::NonDegenerate => (self.g_g(x), self.g_h(x), "<g,g>"),
            Case::Degenerate => (self.phi_g(x), self.phi_h(x), "<phi,g>"),
        };
        let lu = small_lu(m, a, V::Real::epsilon().sqrt()).map_err(|(pivot, ratio)| {
            SetupError::SingularMultiplierMatrix {
                bracket: name,
                pivot,
                ratio,
            }
        })?;
        let mut mu = b;
        lu.solve(&mut mu);
        mu.iter_mut().for_each(|v| *v = -*v);
        Ok(mu)
    }
}

/// A small dense LU with partial pivoting for analysis (allocates; not for the hot path).
struct SmallLu<T> {
    k: usize,
    a: Vec<T>,
    piv: Vec<usize>,
}

impl<T: Real> SmallLu<T> {
    fn solve(&self, b: &mut [T]) {
        let k = self.k;
        let at = |i: usize, j: usize| self.a[j * k + i];
        for (i, &p) in self.piv.iter().enumerate() {
            b.swap(i, p);
        }
        for i in 0..k {
            for j in 0..i {
                b[i] = b[i] - at(i, j) * b[j];
            }
        }
        for i in (0..k).rev() {
            for j in i + 1..k {
                b[i] = b[i] - at(i, j) * b[j];
            }
            b[i] = b[i] / at(i, i);
        }
    }
}

/// Factors a column-major `k × k` matrix; `Err((pivot, ratio))` if a pivot is below `rcond`
/// times the largest column max-norm of the input (or not finite).
fn small_lu<T: Real>(k: usize, mut a: Vec<T>, rcond: T) -> Result<SmallLu<T>, (usize, f64)> {
    let scale = ops::norm_inf(&a);
    let mut piv = vec![0; k];
    for col in 0..k {
        let mut p = col;
        for r in col..k {
            if a[col * k + r].abs() > a[col * k + p].abs() {
                p = r;
            }
        }
        piv[col] = p;
        let pv = a[col * k + p];
        let ratio = if scale > T::zero() {
            pv.abs() / scale
        } else {
            T::zero()
        };
        if ratio.is_nan() || ratio <= rcond {
            return Err((col, ratio.to_f64_lossy()));
        }
        if p != col {
            for j in 0..k {
                a.swap(j * k + col, j * k + p);
            }
        }
        for r in col + 1..k {
            let f = a[col * k + r] / pv;
            a[col * k + r] = f;
            for j in col + 1..k {
                a[j * k + r] = a[j * k + r] - f * a[j * k + col];
            }
        }
    }
    Ok(SmallLu { k, a, piv })
}
