//! The reversible controller's step density of a scene (`integrator.density`): a power of the
//! distance between two bodies, or of one body from the origin.

use super::{Result, err};
use crate::flow::StepDensity;
use crate::real::Real;
use crate::scene::bodies::Bodies;
use crate::scene::error::{FieldPath, SceneErrorKind};
use crate::scene::schema::DensitySpec;
use crate::vector::Vector;
use num_traits::Float as _;

/// `ρ(x) = r^{−α}`, `r = |q_a − q_b|` (or `|q_a|`), on a scene's state `x = (q, p)` with
/// `p = m v` per slot: `G = d/dt log ρ = −α (r · ṙ)/|r|²`, `ṙ = p_a/m_a − p_b/m_b`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DistanceDensity {
    /// The first body's first position index and inverse mass.
    a: (usize, f64),
    /// The second body's, when the distance is between two.
    b: Option<(usize, f64)>,
    dim: usize,
    power: f64,
}

impl DistanceDensity {
    /// `r` and `r · ṙ` at `x`.
    fn relative<T: Real>(&self, x: &[T]) -> (T, T) {
        let nq = x.len() / 2;
        let (mut rr, mut rv) = (T::zero(), T::zero());
        for k in 0..self.dim {
            let (ia, ma) = self.a;
            let mut r = x[ia + k];
            let mut v = x[nq + ia + k] * T::lit(ma);
            if let Some((ib, mb)) = self.b {
                r = r - x[ib + k];
                v = v - x[nq + ib + k] * T::lit(mb);
            }
            rr = rr + r * r;
            rv = rv + r * v;
        }
        (rr, rv)
    }
}

impl<V: Vector> StepDensity<V> for DistanceDensity {
    fn density(&mut self, x: &V) -> V::Real {
        let (rr, _) = self.relative(x.as_slice());
        rr.powf(V::Real::lit(-0.5 * self.power))
    }
    fn log_rate(&mut self, x: &V) -> V::Real {
        let (rr, rv) = self.relative(x.as_slice());
        -V::Real::lit(self.power) * rv / rr
    }
}

/// The density a scene declares, its bodies found by name (`path` is `integrator.density`).
pub(super) fn compile_density(
    spec: &DensitySpec,
    bodies: &Bodies,
    path: &FieldPath,
) -> Result<DistanceDensity> {
    if !(spec.power > 0.0 && spec.power.is_finite()) {
        return Err(err(
            SceneErrorKind::Value,
            path.key("power"),
            format!("power {}: positive and finite", spec.power),
        ));
    }
    let at = path.key("distance");
    let one = |i: usize, name: &str| -> Result<(usize, f64)> {
        match bodies.select(name, &at.index(i))?.as_slice() {
            [b] => Ok((b * bodies.dim, 1.0 / bodies.list[*b].mass)),
            many => Err(err(
                SceneErrorKind::Reference,
                at.index(i),
                format!(
                    "'{name}' names {} bodies; a distance is between two bodies",
                    many.len()
                ),
            )),
        }
    };
    let (a, b) = match spec.distance.as_slice() {
        [a] => (one(0, a)?, None),
        [a, b] if a != b => (one(0, a)?, Some(one(1, b)?)),
        _ => {
            return Err(err(
                SceneErrorKind::Value,
                at,
                "one body (its distance from the origin) or two different bodies",
            ));
        }
    };
    Ok(DistanceDensity {
        a,
        b,
        dim: bodies.dim,
        power: spec.power,
    })
}
