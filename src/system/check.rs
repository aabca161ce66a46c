//! A model checker: every derivative a model provides against finite differences of what it is
//! the derivative of, the adjoint identities of `G`, the sign of the structure's symmetric part,
//! and which optional hints the model gives (and so which fast paths it gets).
//!
//! A model's `G` is written three times — as `G v`, as `Gᵀ μ` and as Jacobian entries — and its
//! Hessian and `DM` once more each; nothing else checks that they agree. [`check_model`] does,
//! at a state the caller chooses, in `O(k)` evaluations for `k` probe directions (so it is
//! usable on models with 10⁵ unknowns).

use super::Model;
use super::{Hamiltonian, HolonomicConstraint, StructureMatrix};
use crate::linalg::Sink;
use crate::real::Real;
use crate::vector::{Vector, ops};
use core::fmt;
use num_traits::{Float, One, Zero};

/// Probe directions: the first few unit vectors and a few dense pseudo-random ones.
const PROBES: usize = 8;

/// Relative tolerance of a central difference with `δ = ε^{1/3} max(1, ‖x‖∞)`: its error is
/// `O(δ² |f'''|) + O(ε |f| / δ)`, both `O(ε^{2/3}) ≈ 4e-11` relative for an `O(1)`-scaled model;
/// `1e-6` leaves five orders of magnitude for larger third derivatives, while a wrong derivative
/// is wrong by `O(1)`.
const FD_RTOL: f64 = 1e-6;

/// Relative tolerance of identities that hold exactly up to rounding (`⟨Gv, μ⟩ = ⟨v, Gᵀμ⟩`,
/// entries against `G v`): `n ε` of the sum of the magnitudes, with room.
const EXACT_RTOL: f64 = 1e-11;

/// One comparison.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelCheck {
    /// What was compared (`"gradient vs energy differences"`, …).
    pub what: &'static str,
    /// The largest error over the probe directions.
    pub error: f64,
    /// The tolerance it was held to (scaled by the magnitudes compared).
    pub tolerance: f64,
    /// `error ≤ tolerance`.
    pub passed: bool,
}

/// Which optional hints the model provides.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Hints {
    /// [`Hamiltonian::hessian_apply`].
    pub hessian: bool,
    /// [`Hamiltonian::is_quadratic`].
    pub quadratic: bool,
    /// [`HolonomicConstraint::jacobian_entries`].
    pub jacobian_entries: bool,
    /// [`StructureMatrix::is_constant`].
    pub constant_structure: bool,
    /// [`StructureMatrix::derivative_apply_add`] (implied for a constant `M`).
    pub structure_derivative: bool,
    /// [`StructureMatrix::is_dissipative`].
    pub dissipative: bool,
}

/// The result of [`check_model`].
#[derive(Debug, Clone, PartialEq)]
pub struct ModelReport {
    /// Every comparison made.
    pub checks: Vec<ModelCheck>,
    /// The hints the model provides.
    pub hints: Hints,
    /// What the hints enable, and what a missing one costs, in words.
    pub notes: Vec<String>,
}

impl ModelReport {
    /// `true` when every check passed.
    pub fn passed(&self) -> bool {
        self.checks.iter().all(|c| c.passed)
    }
    /// The checks that failed.
    pub fn failures(&self) -> impl Iterator<Item = &ModelCheck> {
        self.checks.iter().filter(|c| !c.passed)
    }
}

impl fmt::Display for ModelReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for c in &self.checks {
            writeln!(
                f,
                "{:<4} {:<48} error {:.2e} (tolerance {:.2e})",
                if c.passed { "ok" } else { "FAIL" },
                c.what,
                c.error,
                c.tolerance
            )?;
        }
        for n in &self.notes {
            writeln!(f, "note {n}")?;
        }
        Ok(())
    }
}

/// Collects `(row, col, value)` entries and applies them to a vector.
struct Apply<'a, T> {
    v: &'a [T],
    out: &'a mut [T],
    outside: bool,
}

impl<T: Real> Sink<T> for Apply<'_, T> {
    fn add(&mut self, row: usize, col: usize, value: T) {
        match (self.out.get_mut(row), self.v.get(col)) {
            (Some(o), Some(&v)) => *o = *o + value * v,
            _ => self.outside = true,
        }
    }
}

fn probe<V: Vector>(x: &V, k: usize) -> V {
    let n = x.len();
    let mut v = x.zeros_like();
    let s = v.as_mut_slice();
    if k < PROBES / 2 && k < n {
        s[k] = V::Real::one();
    } else {
        // A dense direction with entries in [−1, 1] (golden-ratio sequence): touches every
        // coordinate, so a wrong entry anywhere shows.
        for (i, si) in s.iter_mut().enumerate() {
            let t = ((i + 1) as f64 * 0.618_033_988_749_894_9
                + (k + 1) as f64 * 0.414_213_562_373_095)
                .fract();
            *si = V::Real::lit(2.0 * t - 1.0);
        }
    }
    v
}

fn axpy_new<V: Vector>(x: &V, a: V::Real, v: &V) -> V {
    let mut y = x.clone();
    ops::axpy(y.as_mut_slice(), a, v.as_slice());
    y
}

fn max_abs<T: Real>(a: &[T]) -> f64 {
    ops::norm_inf(a).to_f64_lossy()
}

/// Tracks the worst error of one kind of check over the probes.
struct Worst {
    what: &'static str,
    error: f64,
    tolerance: f64,
    passed: bool,
}

impl Worst {
    fn new(what: &'static str) -> Self {
        Self {
            what,
            error: 0.0,
            tolerance: 0.0,
            passed: true,
        }
    }
    fn add(&mut self, error: f64, tolerance: f64) {
        let ok = error.is_finite() && error <= tolerance;
        if !ok
            || (self.passed
                && error / tolerance.max(f64::MIN_POSITIVE)
                    > self.error / self.tolerance.max(f64::MIN_POSITIVE))
        {
            self.error = error;
            self.tolerance = tolerance;
        }
        self.passed &= ok;
    }
    fn done(self) -> ModelCheck {
        ModelCheck {
            what: self.what,
            error: self.error,
            tolerance: self.tolerance,
            passed: self.passed,
        }
    }
}

/// Checks a model at the state `x`: every provided derivative against central differences of
/// the function it differentiates, along a few unit and dense probe directions, and the
/// identities that must hold exactly:
///
/// - `∇H · v` against `(H(x + δv) − H(x − δv)) / 2δ`;
/// - `∇²H v` (if provided) against `(∇H(x + δv) − ∇H(x − δv)) / 2δ`;
/// - `G v` against `(g(x + δv) − g(x − δv)) / 2δ`;
/// - `⟨G v, μ⟩ = ⟨v, Gᵀ μ⟩` for dense `v`, `μ` (the transpose is the adjoint);
/// - the direct forms `M v` ([`StructureMatrix::apply`]) and `Gᵀ μ`
///   ([`HolonomicConstraint::jacobian_transpose_apply`]), which a model may write itself,
///   against the accumulating ones into a zeroed vector, whatever `out` held before;
/// - the Jacobian entries (if provided) applied to `v` against `G v`, all inside `m × n`;
/// - `DM(x)[u] w` (if provided, `M` not constant) against `(M(x + δu) − M(x − δu)) w / 2δ`;
/// - for a structure that says it is dissipative ([`StructureMatrix::is_dissipative`]),
///   `vᵀ M(x) v ≤ 0` (`R ⪰ 0`: it does not create energy); for one that does not say so, that
///   no probe finds damping only (`vᵀ M v < 0` and never `> 0`): compositions with backward
///   sub-steps rely on the flag to refuse running damping backwards. An indefinite symmetric
///   part (the paper's example) is reported in the notes.
///
/// `δ = ε^{1/3} max(1, ‖x‖∞)`; the difference checks hold to `1e-6` relative, the exact
/// identities to `1e-11` relative (see the constants' docs). The report also lists the hints
/// the model provides and what each enables.
pub fn check_model<V, Sys>(system: &Sys, x: &V) -> ModelReport
where
    V: Vector,
    Sys: Model<V>,
{
    let (h, c, s) = (
        system.hamiltonian(),
        system.constraint(),
        system.structure(),
    );
    let n = x.len();
    let m = c.dim();
    let eps = V::Real::epsilon();
    let xs = V::Real::one().max(ops::norm_inf(x.as_slice()));
    let delta = eps.cbrt() * xs;
    let two_delta = V::Real::lit(2.0) * delta;
    let fd = V::Real::lit(FD_RTOL);
    let exact = EXACT_RTOL;

    let mut grad = x.zeros_like();
    h.gradient(x, &mut grad);
    let (mut gp, mut gm, mut hv) = (x.zeros_like(), x.zeros_like(), x.zeros_like());
    let mut hessian = true;
    let mut w_grad = Worst::new("gradient vs energy differences");
    let mut w_hess = Worst::new("Hessian product vs gradient differences");
    let mut w_g = Worst::new("G v vs constraint differences");
    let mut w_adj = Worst::new("<G v, mu> vs <v, G^T mu>");
    let mut w_entries = Worst::new("Jacobian entries vs G v");
    let mut w_dm = Worst::new("DM[u] w vs structure differences");
    let mut w_sign = Worst::new("v^T M v <= 0 (no energy created)");
    let mut w_direct = Worst::new("M v, G^T mu written directly vs accumulated");
    let mut entries = m > 0;
    let mut structure_derivative = true;
    let (mut dissipates_seen, mut creates_seen) = (false, false);
    let (mut ga, mut gb, mut gv) = (
        vec![V::Real::zero(); m],
        vec![V::Real::zero(); m],
        vec![V::Real::zero(); m],
    );
    let (mut mv, mut mp, mut mm, mut dm) = (
        x.zeros_like(),
        x.zeros_like(),
        x.zeros_like(),
        x.zeros_like(),
    );
    for k in 0..PROBES {
        let v = probe(x, k);
        let (xp, xm) = (axpy_new(x, delta, &v), axpy_new(x, -delta, &v));
        // Gradient.
        let d = (h.energy(&xp) - h.energy(&xm)) / two_delta;
        let a = ops::dot(grad.as_slice(), v.as_slice());
        w_grad.add(
            (d - a).abs().to_f64_lossy(),
            (fd * (V::Real::one() + a.abs() + d.abs())).to_f64_lossy(),
        );
        // Hessian.
        h.gradient(&xp, &mut gp);
        h.gradient(&xm, &mut gm);
        if hessian && h.hessian_apply(x, &v, &mut hv) {
            let mut err = 0.0f64;
            for ((&p, &q), &e) in gp.as_slice().iter().zip(gm.as_slice()).zip(hv.as_slice()) {
                err = err.max(((p - q) / two_delta - e).abs().to_f64_lossy());
            }
            let scale = V::Real::one() + ops::norm_inf(hv.as_slice());
            w_hess.add(err, (fd * scale).to_f64_lossy());
        } else {
            hessian = false;
        }
        if m > 0 {
            // G v against differences of g.
            c.residual(&xp, &mut ga);
            c.residual(&xm, &mut gb);
            c.jacobian_apply(x, &v, &mut gv);
            let mut err = 0.0f64;
            for ((&p, &q), &e) in ga.iter().zip(&gb).zip(&gv) {
                err = err.max(((p - q) / two_delta - e).abs().to_f64_lossy());
            }
            w_g.add(
                err,
                (fd * (V::Real::one() + ops::norm_inf(&gv))).to_f64_lossy(),
            );
            // Adjoint: <G v, μ> = <v, Gᵀ μ>.
            let mu: Vec<V::Real> = (0..m)
                .map(|i| V::Real::lit(((i * 5 + k * 3 + 2) as f64 * 0.754_877_666).fract() - 0.5))
                .collect();
            let mut gt = x.zeros_like();
            c.jacobian_transpose_apply_add(x, &mu, V::Real::one(), &mut gt);
            // The direct form, into a vector holding something else first.
            let mut direct = axpy_new(&v, V::Real::one(), &v);
            c.jacobian_transpose_apply(x, &mu, &mut direct);
            w_direct.add(
                ops::dist_inf(direct.as_slice(), gt.as_slice()).to_f64_lossy(),
                exact * (1.0 + ops::norm_inf(gt.as_slice()).to_f64_lossy()),
            );
            let lhs = ops::dot(&gv, &mu);
            let rhs = ops::dot(v.as_slice(), gt.as_slice());
            let mag: V::Real = gv
                .iter()
                .zip(&mu)
                .fold(V::Real::zero(), |s, (a, b)| s + (*a * *b).abs())
                + v.as_slice()
                    .iter()
                    .zip(gt.as_slice())
                    .fold(V::Real::zero(), |s, (a, b)| s + (*a * *b).abs());
            w_adj.add(
                (lhs - rhs).abs().to_f64_lossy(),
                exact * (1.0 + mag.to_f64_lossy()),
            );
            // Entries.
            if entries {
                let mut applied = vec![V::Real::zero(); m];
                let mut sink = Apply {
                    v: v.as_slice(),
                    out: &mut applied,
                    outside: false,
                };
                if c.jacobian_entries(x, &mut sink) {
                    let outside = sink.outside;
                    let err = if outside {
                        f64::INFINITY
                    } else {
                        max_abs(
                            &applied
                                .iter()
                                .zip(&gv)
                                .map(|(a, b)| *a - *b)
                                .collect::<Vec<_>>(),
                        )
                    };
                    let scale: V::Real = gv.iter().fold(V::Real::zero(), |s, a| s + a.abs());
                    w_entries.add(
                        err,
                        exact * (1.0 + scale.to_f64_lossy()) * (n as f64).sqrt(),
                    );
                } else {
                    entries = false;
                }
            }
        }
        // Structure: the direct form against the accumulating one; sign; derivative.
        s.apply(x, &v, &mut mv);
        ops::fill_zero(mp.as_mut_slice());
        s.apply_add(x, &v, V::Real::one(), &mut mp);
        w_direct.add(
            ops::dist_inf(mv.as_slice(), mp.as_slice()).to_f64_lossy(),
            exact * (1.0 + ops::norm_inf(mp.as_slice()).to_f64_lossy()),
        );
        let q = ops::dot(v.as_slice(), mv.as_slice());
        let mag: V::Real = v
            .as_slice()
            .iter()
            .zip(mv.as_slice())
            .fold(V::Real::zero(), |a, (p, r)| a + (*p * *r).abs());
        let floor = V::Real::lit(exact) * (V::Real::one() + mag);
        if q < -floor {
            dissipates_seen = true;
        }
        if q > floor {
            creates_seen = true;
        }
        w_sign.add(q.max(V::Real::zero()).to_f64_lossy(), floor.to_f64_lossy());
        if !s.is_constant() && structure_derivative {
            let w = probe(x, k + 1);
            ops::fill_zero(dm.as_mut_slice());
            if s.derivative_apply_add(x, &v, &w, V::Real::one(), &mut dm) {
                s.apply(&xp, &w, &mut mp);
                s.apply(&xm, &w, &mut mm);
                let mut err = 0.0f64;
                for ((&p, &q), &e) in mp.as_slice().iter().zip(mm.as_slice()).zip(dm.as_slice()) {
                    err = err.max(((p - q) / two_delta - e).abs().to_f64_lossy());
                }
                let scale = V::Real::one() + ops::norm_inf(dm.as_slice());
                w_dm.add(err, (fd * scale).to_f64_lossy());
            } else {
                structure_derivative = false;
            }
        }
    }
    let hints = Hints {
        hessian,
        quadratic: h.is_quadratic(),
        jacobian_entries: m > 0 && entries,
        constant_structure: s.is_constant(),
        structure_derivative: s.is_constant() || structure_derivative,
        dissipative: s.is_dissipative(),
    };
    let mut checks = vec![w_grad.done(), w_direct.done()];
    if hints.hessian {
        checks.push(w_hess.done());
    }
    if m > 0 {
        checks.push(w_g.done());
        checks.push(w_adj.done());
        if hints.jacobian_entries {
            checks.push(w_entries.done());
        }
    }
    if !hints.constant_structure && hints.structure_derivative {
        checks.push(w_dm.done());
    }
    // A structure that says it is dissipative (R ⪰ 0) must not create energy; one that damps
    // (vᵀ M v < 0, never > 0) must say so, or compositions with backward sub-steps would run
    // its damping backwards. An indefinite symmetric part (the paper's example) is neither.
    if hints.dissipative {
        checks.push(w_sign.done());
    }
    let undeclared = dissipates_seen && !creates_seen && !hints.dissipative;
    checks.push(ModelCheck {
        what: "is_dissipative() where v^T M v < 0",
        error: if undeclared { 1.0 } else { 0.0 },
        tolerance: 0.0,
        passed: !undeclared,
    });
    let mut notes = Vec::new();
    if dissipates_seen && creates_seen {
        notes.push("the symmetric part of M is indefinite: H is not a Lyapunov function (the flow neither conserves nor dissipates it)".to_owned());
    }
    notes.push(if hints.hessian {
        "Hessian products given: closed-form Newton matrices in the implicit flows, and the small projection path (stack Newton) for up to 4 constraints".to_owned()
    } else {
        "no Hessian products: the implicit flows and the projection build their Newton matrices by finite differences (more residual evaluations, and no small projection path)".to_owned()
    });
    if hints.quadratic {
        notes.push("H quadratic: with a constant M the projection's lambda_{k+1} system is one linear solve".to_owned());
    }
    if m > 0 {
        notes.push(if hints.jacobian_entries {
            "Jacobian entries given: sparse or banded multiplier systems, and redundant constraints named at construction".to_owned()
        } else {
            format!(
                "no Jacobian entries: G is treated as dense ({m} x {n}); with many constraints give them for the sparse path"
            )
        });
    }
    if !hints.constant_structure {
        notes.push(if hints.structure_derivative {
            "DM given: implicit flows with a state-dependent M use closed-form Newton matrices"
                .to_owned()
        } else {
            "no DM: implicit flows with this state-dependent M difference it".to_owned()
        });
    }
    ModelReport {
        checks,
        hints,
        notes,
    }
}
