//! The initial state: how far it is off the constraints and their hidden constraints, and its
//! projection onto both when the scene asks for it.

use crate::scene::gram::MassGram;
use crate::scene::model::SceneModel;
use crate::system::HolonomicConstraint;
use crate::vector::Vector;
use faer::Col;
use std::sync::Arc;

/// Per constraint row: the size `ρ` of the terms its residual rounds (a rod `(|u|² − L²)/2`
/// rounds at `ε L (L + |q_a| + |q_b|)`, a plane at `ε (|q| + |offset|)`, …) and its length `ℓ`
/// (the factor between a velocity and its hidden-constraint residual).
pub(super) fn row_scales(model: &SceneModel, q: &[f64]) -> Vec<(f64, f64)> {
    let mut out = vec![(0.0, 0.0); model.m];
    for c in &model.constraints {
        c.kind.info().scales(q, model.dim, &mut out[c.row..]);
    }
    out
}

/// `Some((value, row, "position"|"velocity"))` for the row that violates `g = 0` or `G v = 0`
/// most beyond `√ε` relative to its own scale ([`row_scales`]).
pub(super) fn off_constraints(
    model: &Arc<SceneModel>,
    x: &Col<f64>,
) -> Option<(f64, usize, &'static str)> {
    constraint_offset(model, x, f64::EPSILON.sqrt()).map(|(_, v, r, level)| (v, r, level))
}

/// The worst violation of `g = 0` (then of `G v = 0`) whose ratio to its row's scale
/// ([`row_scales`]) exceeds `tol`: `(ratio, value, row, "position"|"velocity")`.
pub(super) fn constraint_offset(
    model: &Arc<SceneModel>,
    x: &Col<f64>,
    tol: f64,
) -> Option<(f64, f64, usize, &'static str)> {
    let m = model.m;
    let nq = model.state_len() / 2;
    let scales = row_scales(model, &x.as_slice()[..nq]);
    let mut g = vec![0.0; m];
    HolonomicConstraint::<Col<f64>>::residual(model, x, &mut g);
    let worst = |g: &[f64], scale: &dyn Fn(usize) -> f64| {
        g.iter()
            .enumerate()
            .map(|(i, v)| (v.abs() / scale(i), v.abs(), i))
            .fold((0.0f64, 0.0, 0usize), |a, b| if b.0 > a.0 { b } else { a })
    };
    let (ratio, v, r) = worst(&g, &|i| scales[i].0);
    if ratio > tol {
        return Some((ratio, v, r, "position"));
    }
    let vel = velocity_state(model, x);
    let vscale = vel.as_slice()[..nq]
        .iter()
        .fold(0.0f64, |a, &b| a.max(b.abs()));
    if vscale == 0.0 {
        return None;
    }
    HolonomicConstraint::<Col<f64>>::jacobian_apply(model, x, &vel, &mut g);
    let (ratio, v, r) = worst(&g, &|i| scales[i].1 * vscale);
    (ratio > tol).then_some((ratio, v, r, "velocity"))
}

/// How far above round-off an accepted initial state may be off its constraints before the
/// run says so: `64 ε` relative to a row's scale.
pub(super) const ROUND_OFF_RATIO: f64 = 64.0 * f64::EPSILON;

/// `(v, 0)` as a state-sized vector whose first half holds the velocities `p/m`.
pub(super) fn velocity_state(model: &SceneModel, x: &Col<f64>) -> Col<f64> {
    let n = model.state_len();
    let (nq, d) = (n / 2, model.dim);
    let mut v = Col::<f64>::zeros(n);
    for (b, w) in model.inv_masses.iter().enumerate() {
        for k in 0..d {
            v[b * d + k] = w * x[nq + b * d + k];
        }
    }
    v
}

/// Projects `x` onto `g = 0`, then its velocities onto `G v = 0`, in the mass metric:
/// `q ← q − W⁻¹Gᵀ (G W⁻¹ Gᵀ)⁻¹ g` (Gauss–Newton, to round-off), `v ← v − W⁻¹Gᵀ (G W⁻¹ Gᵀ)⁻¹ G v`.
/// Returns `(max |Δq|, max |Δp|)`.
///
/// With `velocities_only`, the positions are kept and only the velocities are projected.
pub(super) fn project_initial(
    model: &Arc<SceneModel>,
    x: &mut Col<f64>,
    velocities_only: bool,
) -> std::result::Result<(f64, f64), String> {
    let n = model.state_len();
    let (nq, d, m) = (n / 2, model.dim, model.m);
    let x_start = x.clone();
    let w_inv: Vec<f64> = (0..nq).map(|i| model.inv_masses[i / d]).collect();
    let mut g = vec![0.0; m];
    let mut gram = MassGram::new(model, &x.as_slice()[..nq]).map_err(|e| e.to_string())?;
    // δ = W⁻¹ Gᵀ (G W⁻¹ Gᵀ)⁻¹ rhs, on the positions.
    let mut solve = |x: &Col<f64>, rhs: &mut [f64]| -> std::result::Result<Col<f64>, String> {
        gram.factor(model, &x.as_slice()[..nq]).map_err(|e| {
            format!("the constraints are redundant or singular at the initial state ({e})")
        })?;
        gram.solve(rhs).map_err(|e| e.to_string())?;
        let mut delta = Col::<f64>::zeros(n);
        HolonomicConstraint::<Col<f64>>::jacobian_transpose_apply_add(
            model, x, rhs, 1.0, &mut delta,
        );
        for i in 0..nq {
            delta[i] *= w_inv[i];
        }
        Ok(delta)
    };
    if velocities_only {
        project_velocities(model, x, &mut g, &w_inv, &mut solve)?;
        let dp = (0..nq).fold(0.0f64, |a, i| a.max((x[nq + i] - x_start[nq + i]).abs()));
        return Ok((0.0, dp));
    }
    let mut converged = false;
    for _ in 0..50 {
        HolonomicConstraint::<Col<f64>>::residual(model, x, &mut g);
        let scales = row_scales(model, &x.as_slice()[..nq]);
        if g.iter()
            .zip(&scales)
            .all(|(v, s)| v.abs() <= 8.0 * f64::EPSILON * s.0)
        {
            converged = true;
            break;
        }
        let delta = solve(x, &mut g)?;
        for i in 0..nq {
            x[i] -= delta[i];
        }
    }
    if !converged {
        return Err("projecting the initial positions onto the constraints did not converge in 50 Gauss–Newton steps".into());
    }
    project_velocities(model, x, &mut g, &w_inv, &mut solve)?;
    let dq = (0..nq).fold(0.0f64, |a, i| a.max((x[i] - x_start[i]).abs()));
    let dp = (0..nq).fold(0.0f64, |a, i| a.max((x[nq + i] - x_start[nq + i]).abs()));
    Ok((dq, dp))
}

/// `rhs ↦ W⁻¹ Gᵀ (G W⁻¹ Gᵀ)⁻¹ rhs` at the positions of a state.
type MassSolve<'a> = dyn FnMut(&Col<f64>, &mut [f64]) -> std::result::Result<Col<f64>, String> + 'a;

/// `v ← v − W⁻¹Gᵀ (G W⁻¹ Gᵀ)⁻¹ G v` on the momenta of `x` (`Δp = m Δv`); `solve` applies
/// `W⁻¹ Gᵀ (G W⁻¹ Gᵀ)⁻¹` to a right-hand side of constraint rows.
fn project_velocities(
    model: &Arc<SceneModel>,
    x: &mut Col<f64>,
    g: &mut [f64],
    w_inv: &[f64],
    solve: &mut MassSolve<'_>,
) -> std::result::Result<(), String> {
    let nq = w_inv.len();
    let vel = velocity_state(model, x);
    HolonomicConstraint::<Col<f64>>::jacobian_apply(model, x, &vel, g);
    let delta = solve(x, g)?;
    for i in 0..nq {
        x[nq + i] -= delta[i] / w_inv[i];
    }
    Ok(())
}
