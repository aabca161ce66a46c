//! The exact flow of the kinetic term under `M`: each body's free flight, a drift, or rotated
//! about the magnetic field and damped in closed form.

use super::SceneModel;
use crate::real::Real;

/// The free flight of one body under `M`: what its kinetic flow has to do.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Flight<T> {
    /// `q += t p/m`.
    Drift,
    /// The closed form with `γ = c/m` and `ω⃗ = e B/m`.
    Exact { gamma: T, omega: [T; 3] },
}

/// The free flight of one body with `γ`, `ω⃗` for time `t` from momentum `p`: `(∫₀ᵗ p(s) ds, p(t))`.
pub(super) fn exact_flight<T: Real>(gamma: T, omega: [T; 3], t: T, p: [T; 3]) -> ([T; 3], [T; 3]) {
    let decay = (-gamma * t).exp();
    // φ∥ = ∫₀ᵗ e^{−γs} ds.
    let phi_par = if gamma == T::lit(0.0) {
        t
    } else {
        -(-gamma * t).exp_m1() / gamma
    };
    let om = (omega[0] * omega[0] + omega[1] * omega[1] + omega[2] * omega[2]).sqrt();
    if om == T::lit(0.0) {
        return (p.map(|pk| phi_par * pk), p.map(|pk| decay * pk));
    }
    let bh = omega.map(|o| o / om);
    let along = bh[0] * p[0] + bh[1] * p[1] + bh[2] * p[2];
    let par = bh.map(|b| along * b);
    let perp = [p[0] - par[0], p[1] - par[1], p[2] - par[2]];
    let w = cross(bh, perp);
    let (s, c) = (om * t).sin_cos();
    let half = (T::lit(0.5) * om * t).sin();
    // e^{zt} − 1 = (e^{−γt} cos ωt − 1) + i e^{−γt} sin ωt, the real part without cancellation.
    let nr = (-gamma * t).exp_m1() * c - T::lit(2.0) * half * half;
    let ni = decay * s;
    // (nr + i ni) / z with z scaled by s = max(γ, ω) first, so that a field so weak that
    // γ² + ω² underflows still divides correctly.
    let scale = gamma.max(om);
    let (zr, zi) = (-gamma / scale, om / scale);
    let den = (zr * zr + zi * zi) * scale;
    let a = (zr * nr + zi * ni) / den;
    let bb = (zr * ni - zi * nr) / den;
    let mut dq = [T::lit(0.0); 3];
    let mut pn = [T::lit(0.0); 3];
    for k in 0..3 {
        dq[k] = phi_par * par[k] + a * perp[k] - bb * w[k];
        pn[k] = decay * (par[k] + c * perp[k] - s * w[k]);
    }
    (dq, pn)
}

#[inline]
pub(super) fn cross<T: Real>(a: [T; 3], b: [T; 3]) -> [T; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

impl<T: Real> SceneModel<T> {
    /// The exact flow of the kinetic term under `M` for time `t`: per body, `q' = v = p/m`,
    /// `p' = e v × B − c v`. With `γ = c/m`, `ω⃗ = e B/m = ω b̂`, `p = p∥ + p⊥` along and
    /// across `b̂`, `w = b̂ × p⊥` and `z = −γ + iω`:
    ///
    /// ```text
    /// p(t) = e^{−γt} (p∥ + cos(ωt) p⊥ − sin(ωt) w),
    /// q(t) = q + (1/m) (φ∥ p∥ + a p⊥ − b w),   φ∥ = (1 − e^{−γt})/γ,   a + ib = (e^{zt} − 1)/z,
    /// ```
    ///
    /// evaluated without cancellation (`expm1`, `1 − cos = 2 sin²`). Bodies without field and
    /// damping take the plain drift `q += t p/m`.
    ///
    /// Returns the kinetic energy the damping removed, `Σ (|p_b|² − |p_b(t)|²)/(2 m_b)` over the
    /// damped bodies: the exact `∫ vᵀ R v dt` along this sub-flow (the field only turns `p`).
    pub fn free_flight(&self, t: T, x: &mut [T]) -> T {
        let mut removed = T::lit(0.0);
        let d = self.dim;
        let nq = d * self.masses.len();
        let (q, p) = x.split_at_mut(nq);
        self.kinetic.hit();
        if let Some(damping) = &self.damping {
            damping.counter.hit();
        }
        if let Some(magnetic) = &self.magnetic {
            magnetic.counter.hit();
        }
        for (b, flight) in self.flights.iter().enumerate() {
            let w = self.inv_masses[b];
            let (qb, pb) = (&mut q[b * d..b * d + d], &mut p[b * d..b * d + d]);
            match *flight {
                Flight::Drift => {
                    for k in 0..d {
                        qb[k] = qb[k] + (t * w * pb[k]);
                    }
                }
                Flight::Exact { gamma, omega } => {
                    let mut p3 = [T::lit(0.0); 3];
                    p3[..d].copy_from_slice(pb);
                    let (dq, pn) = exact_flight(gamma, omega, t, p3);
                    for k in 0..d {
                        qb[k] = qb[k] + (w * dq[k]);
                    }
                    if gamma != T::lit(0.0) {
                        // |p|² − |p(t)|² = (1 − e^{−2γt}) |p|², without cancellation.
                        let p2 = p3.iter().fold(T::lit(0.0), |s, &v| s + v * v);
                        let lost = -(T::lit(-2.0) * gamma * t).exp_m1();
                        removed = removed + T::lit(0.5) * w * lost * p2;
                    }
                    pb.copy_from_slice(&pn[..d]);
                }
            }
        }
        removed
    }
}
