//! What every constrained flow checks about a model at its initial state, before it steps:
//! finiteness, dimensions, independent constraint gradients (the Gram matrix `G Gᵀ` and the
//! multiplier pattern it gives), the case from the brackets, the manifold, and whether the two
//! projection half-steps decouple. Shared by the projection and the constrained discrete
//! gradient.

use super::Model;
use super::{Brackets, Case, HolonomicConstraint};
use crate::error::SetupError;
use crate::linalg::{LinearSolver, SolverChoice, Structure, Triplets};
use crate::real::Real;
use crate::vector::{Vector, ops};
use num_traits::Float as _;
use num_traits::{One, Zero};

/// The tolerances and choices of the initial-state checks (from
/// [`ProjectionOptions`](crate::flow::ProjectionOptions)).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct InitialChecks<T> {
    /// The case; `None` decides it from the brackets.
    pub case: Option<Case>,
    /// `⟨g,g⟩` counts as zero below this relative size.
    pub degeneracy_tol: T,
    /// Relative pivot size below which a bracket matrix is singular.
    pub rcond: T,
    /// `‖g(x0)‖∞` (and `‖φ(x0)‖∞`) must not exceed this; `None` skips the check.
    pub manifold_tol: Option<T>,
    /// The backend of the Gram-matrix factorization.
    pub solver: SolverChoice,
}

/// A probe of the second half-step at `x0`: a fixed multiplier `μ`, the direction
/// `d = M Gᵀ μ` at `x0`, and the displaced point `x0 + s d` with `s` a small step relative to
/// `x0`. `None` when the direction vanishes (the half-step cannot move anything).
struct HalfStepProbe<V: Vector> {
    mu: Vec<V::Real>,
    d: V,
    xp: V,
    tmp: V,
}

impl<V: Vector> HalfStepProbe<V> {
    fn new<Sys>(system: &Sys, x0: &V) -> Option<Self>
    where
        Sys: Model<V>,
    {
        let m = system.constraint().dim();
        let mu: Vec<V::Real> = (0..m)
            .map(|j| V::Real::one() + V::Real::lit(j as f64 / (m as f64 + 1.0)))
            .collect();
        let (mut tmp, mut d, mut xp) = (x0.zeros_like(), x0.zeros_like(), x0.zeros_like());
        system.constraint_force(x0, &mu, &mut tmp, &mut d);
        let dn = ops::norm_inf(d.as_slice());
        if dn == V::Real::zero() {
            return None;
        }
        let s = V::Real::lit(1e-3) * (V::Real::one() + ops::norm_inf(x0.as_slice())) / dn;
        ops::add_scaled(xp.as_mut_slice(), x0.as_slice(), s, d.as_slice());
        Some(Self { mu, d, xp, tmp })
    }
}

/// Probes at `x0` whether a second half-step `x ↦ x + s M(x) G(x)ᵀ μ` leaves both `g` and the
/// direction `M Gᵀ μ` unchanged (position constraints with `M Gᵀ` acting on momenta).
/// Every decoupled step re-checks that `g(x_{k+1})` equals `g(y)`, which catches a second
/// half-step that moves `g`; a direction `M Gᵀ` that changes along it is only probed here.
pub(crate) fn probe_decoupled<V, Sys>(system: &Sys, x0: &V) -> bool
where
    V: Vector,
    Sys: Model<V>,
{
    let Some(mut p) = HalfStepProbe::new(system, x0) else {
        return true;
    };
    let m = system.constraint().dim();
    let (mut g0, mut g1) = (vec![V::Real::zero(); m], vec![V::Real::zero(); m]);
    system.constraint().residual(x0, &mut g0);
    system.constraint().residual(&p.xp, &mut g1);
    let mut d1 = x0.zeros_like();
    system.constraint_force(&p.xp, &p.mu, &mut p.tmp, &mut d1);
    let tol = V::Real::lit(64.0) * V::Real::epsilon();
    let gscale = V::Real::one() + ops::norm_inf(&g0);
    let dn = ops::norm_inf(p.d.as_slice());
    ops::dist_inf(&g0, &g1) <= tol * gscale
        && ops::dist_inf(p.d.as_slice(), d1.as_slice()) <= tol * dn
}

/// Probes at `x0` whether `G` is unchanged along a second half-step `x0 + s M Gᵀ μ` (for
/// position constraints and a momentum-only direction it is, exactly): `G v` for a fixed `v`
/// at both points. With a quadratic `H` and a constant `M` the hidden constraint is then
/// affine in the half-step's multiplier.
pub(crate) fn half_step_keeps_jacobian<V, Sys>(system: &Sys, x0: &V) -> bool
where
    V: Vector,
    Sys: Model<V>,
{
    let Some(p) = HalfStepProbe::new(system, x0) else {
        return true;
    };
    let (m, n) = (system.constraint().dim(), x0.len());
    let mut v = x0.zeros_like();
    for (i, vi) in v.as_mut_slice().iter_mut().enumerate() {
        *vi = V::Real::one() + V::Real::lit(i as f64 / (n as f64 + 1.0));
    }
    let (mut a, mut b) = (vec![V::Real::zero(); m], vec![V::Real::zero(); m]);
    system.constraint().jacobian_apply(x0, &v, &mut a);
    system.constraint().jacobian_apply(&p.xp, &v, &mut b);
    let scale = V::Real::one() + ops::norm_inf(&a);
    ops::dist_inf(&a, &b) <= V::Real::lit(64.0) * V::Real::epsilon() * scale
}

/// The checks every constrained flow makes at construction: `x0` finite, `m ≤ n`, independent
/// constraint gradients when the constraint provides its sparse Jacobian ([`constraint_gram`],
/// with the solver `L`), the case (from `options.case` or the brackets at `x0`), and
/// `‖g(x0)‖∞ ≤ options.manifold_tol` — with `check_phi`, also `‖φ(x0)‖∞` in the degenerate
/// case. Returns the case and the multiplier pattern (`None` for a dense `G`).
#[allow(clippy::type_complexity)]
pub(crate) fn check_initial_state<V, Sys, L>(
    system: &Sys,
    x0: &V,
    options: &InitialChecks<V::Real>,
    check_phi: bool,
) -> Result<(Case, Option<Vec<(usize, usize)>>), SetupError>
where
    V: Vector,
    Sys: Model<V>,
    L: LinearSolver<V::Real>,
{
    if let Some(component) = ops::first_non_finite(x0.as_slice()) {
        return Err(SetupError::NonFiniteState { component });
    }
    let n = x0.len();
    let m = system.constraint().dim();
    if m > n {
        return Err(SetupError::Dimension {
            what: format!("{m} constraints on a state of dimension {n}"),
        });
    }
    // Redundant constraints first: the bracket matrices would only report them as singular.
    let pattern = constraint_gram::<V, Sys, L>(system, x0, options.solver)?;
    let brackets = Brackets::new(system);
    let case = match options.case {
        Some(c) => c,
        None if m > MAX_BRACKET_CONSTRAINTS => {
            return Err(SetupError::Dimension {
                what: format!(
                    "{m} constraints: deciding the case from the dense bracket matrices costs O(m^2 n); \
                     set it with ProjectionOptions::with_case (and with_coupling)"
                ),
            });
        }
        None => brackets.case(x0, options.degeneracy_tol, options.rcond)?,
    };
    if let Some(tol) = options.manifold_tol {
        let mut gv = vec![V::Real::zero(); m];
        system.constraint().residual(x0, &mut gv);
        let g = ops::norm_inf(&gv);
        if g.is_nan() || g > tol {
            return Err(SetupError::OffManifold {
                what: "g",
                residual: g.to_f64_lossy(),
            });
        }
        if check_phi && case == Case::Degenerate {
            let phi = ops::norm_inf(&brackets.g_h(x0));
            if phi.is_nan() || phi > tol {
                return Err(SetupError::OffManifold {
                    what: "phi",
                    residual: phi.to_f64_lossy(),
                });
            }
        }
    }
    Ok((case, pattern))
}

/// Above this many constraints the case is not decided from the (dense, `O(m² n)`) bracket
/// matrices: the options must name it.
pub const MAX_BRACKET_CONSTRAINTS: usize = 1024;

/// Adds (as zeros) to the pattern of `G Gᵀ` the pairs of constraints whose gradients touch
/// positions whose momenta the structure's `B` block couples ([`StructureMatrix::momentum_block`]'s
/// off-diagonal entries), closed transitively: a flow of those couplings over a step (the exact
/// damping of a chain of dashpots, applied pair after pair) reaches every variable of a
/// connected group. `by_col`: the entries of `G` as `(column, row, value)`, sorted by column.
///
/// [`StructureMatrix::momentum_block`]: crate::system::StructureMatrix::momentum_block
fn couple_through_momenta<V, Sys>(
    system: &Sys,
    n: usize,
    by_col: &[(usize, usize, V::Real)],
    gram: &mut Vec<(usize, usize, V::Real)>,
) where
    V: Vector,
    Sys: Model<V>,
{
    use crate::system::StructureMatrix as _;
    let mut block = Triplets::default();
    if !system.structure().momentum_block(n, &mut block) {
        return;
    }
    let nq = n / 2;
    // Union–find over the positions by the off-diagonal couplings.
    let mut parent: Vec<usize> = (0..nq).collect();
    fn root(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    let mut coupled = false;
    for &(i, j, _) in &block.entries {
        if i != j && i < nq && j < nq {
            let (a, b) = (root(&mut parent, i), root(&mut parent, j));
            if a != b {
                parent[a] = b;
                coupled = true;
            }
        }
    }
    if !coupled {
        return;
    }
    // The constraints touching each group of more than one position.
    let mut groups: Vec<(usize, usize)> = by_col
        .iter()
        .filter(|&&(c, _, _)| c < nq)
        .map(|&(c, r, _)| (root(&mut parent, c), r))
        .collect();
    groups.sort_unstable();
    groups.dedup();
    let mut start = 0;
    while start < groups.len() {
        let g = groups[start].0;
        let end = start + groups[start..].iter().take_while(|e| e.0 == g).count();
        for &(_, i) in &groups[start..end] {
            for &(_, j) in &groups[start..end] {
                gram.push((i, j, V::Real::zero()));
            }
        }
        start = end;
    }
}

/// When the constraint provides its sparse Jacobian ([`HolonomicConstraint::jacobian_entries`]):
/// checks at `x0` that the constraint gradients are independent (`G Gᵀ` non-singular, factored
/// by the backend `choice` picks) and returns the pattern of `G Gᵀ` — the pairs of constraints
/// whose gradients share a state variable, which is the sparsity of the multiplier systems when
/// the inner flow moves each variable along its own gradient components. `None` when `G` is
/// not provided. Errors: [`SetupError::RankDeficient`] naming a redundant constraint.
pub(crate) fn constraint_gram<V, Sys, L>(
    system: &Sys,
    x0: &V,
    choice: SolverChoice,
) -> Result<Option<Vec<(usize, usize)>>, SetupError>
where
    V: Vector,
    Sys: Model<V>,
    L: LinearSolver<V::Real>,
{
    let (m, n) = (system.constraint().dim(), x0.len());
    let mut g = Triplets::default();
    if !system.constraint().jacobian_entries(x0, &mut g) {
        return Ok(None);
    }
    if let Some(&(row, col, _)) = g.entries.iter().find(|&&(r, c, _)| r >= m || c >= n) {
        return Err(SetupError::Dimension {
            what: format!(
                "constraint Jacobian entry ({row}, {col}) outside {m} constraints x {n} state components"
            ),
        });
    }
    // Rows of G by state variable: (G Gᵀ)_ij = Σ_c G_ic G_jc.
    let mut by_col: Vec<(usize, usize, V::Real)> =
        g.entries.iter().map(|&(r, c, v)| (c, r, v)).collect();
    by_col.sort_unstable_by_key(|&(c, r, _)| (c, r));
    let mut gram: Vec<(usize, usize, V::Real)> = Vec::new();
    let mut start = 0;
    while start < by_col.len() {
        let c = by_col[start].0;
        let end = start + by_col[start..].iter().take_while(|e| e.0 == c).count();
        for &(_, i, a) in &by_col[start..end] {
            for &(_, j, b) in &by_col[start..end] {
                gram.push((i, j, a * b));
            }
        }
        start = end;
    }
    // The inner flow of a mechanical form couples the momenta its `B` block couples (dashpots:
    // their exact flows in sequence couple every body of a chain of them): constraints on
    // positions whose momenta are so coupled couple in the multiplier systems too.
    couple_through_momenta(system, n, &by_col, &mut gram);
    gram.sort_unstable_by_key(|&(i, j, _)| (j, i));
    // Each (i, j) once: two constraints that share several state variables (a rigid body's
    // rows share its directors' nine) meet once per variable, and a count with repeats would
    // take a sparse system for a dense one.
    let mut pattern: Vec<(usize, usize)> = gram.iter().map(|&(i, j, _)| (i, j)).collect();
    pattern.dedup();
    // Every constraint needs a diagonal entry: a constraint with a zero gradient row is
    // redundant (it constrains nothing to first order).
    let structure = match Structure::of_pattern(&pattern) {
        Structure::Banded { lower, upper, .. } => Structure::Banded {
            lower,
            upper,
            nnz: pattern.len() + m,
        },
        other => other,
    };
    let mut lin = L::with_structure(m, structure, choice)?;
    lin.clear();
    for &(i, j, v) in &gram {
        lin.add(i, j, v);
    }
    for i in 0..m {
        lin.add(i, i, V::Real::zero());
    }
    match lin.factor() {
        Ok(()) => Ok(Some(pattern)),
        Err(crate::LinearSolveError::Singular { pivot, ratio, .. }) => {
            Err(SetupError::RankDeficient {
                constraint: pivot,
                ratio,
            })
        }
        Err(crate::LinearSolveError::StructurallySingular { column }) => {
            Err(SetupError::RankDeficient {
                constraint: column,
                ratio: 0.0,
            })
        }
        Err(e) => Err(e.into()),
    }
}
