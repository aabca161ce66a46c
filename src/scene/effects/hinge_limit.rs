//! A hinge's stops as one-sided springs (a penalty contact law): with `θ` the angle about the
//! hinge's axis from the initial poses ([`crate::rigid::HingeAngle`], taken in `(−π, π]`) and the stops
//! `θ_min < θ_max`,
//!
//! ```text
//! V = k/2 (θ − θ_max)²   for θ > θ_max,     k/2 (θ_min − θ)²   for θ < θ_min,     0 between.
//! ```
//!
//! The law is conservative: a body meets the stop, stores its kinetic energy in the spring and
//! leaves at the speed it came (restitution 1, the contact lasting half the spring's period
//! `π √(J/k)`), and what the stop holds is potential energy in the run's energy — booked, never
//! lost or made. The overshoot at a speed `ω` is `ω √(J/k)` (`J` the moment of inertia about the
//! axis): the stiffer the stop, the smaller, and the smaller the step it needs (`h √(k/J) ≲ 0.1`
//! for the scheme's accuracy through a contact). Losses at the stop: a `hinge-damper` beside it.
//! `V` is once continuously differentiable (its second derivative jumps at the stops): the
//! schemes keep their orders between contacts; a step through one is as accurate as
//! `h √(k/J)` makes it.

use super::coordinate::{slot_pairs, spring_hessian_add};
use super::{Assembler, Effect, Potential, PotentialOps};
use crate::real::Real;
use crate::rigid::{Coordinate, JointCoordinate};
use crate::scene::error::{FieldPath, SceneErrorKind};
use crate::scene::names::Flag;
use crate::scene::validate::{Result, err, finite, positive};
use serde::Deserialize;

/// `type = "hinge-limit"`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HingeLimitSpec {
    /// Label in summaries (default `hinge-limit`).
    #[serde(default)]
    pub name: Option<String>,
    /// One rigid body (turning against the world) or two, the first rigid.
    pub bodies: Vec<String>,
    /// The axis in the world at the start.
    #[serde(default)]
    pub axis: Option<Vec<f64>>,
    /// Or: the axis in each body's frame (a world direction for the world).
    #[serde(default)]
    pub axes: Option<Vec<Vec<f64>>>,
    /// The stops' stiffness `k > 0`, N m per radian.
    pub stiffness: f64,
    /// The lower stop `θ_min` from the initial poses, degrees in (−180, 180) (none if absent).
    #[serde(default)]
    pub min_deg: Option<f64>,
    /// The upper stop `θ_max`, degrees in (−180, 180), above `min_deg` (none if absent).
    #[serde(default)]
    pub max_deg: Option<f64>,
}

/// The one-sided springs of a joint's stops: a hinge's (its angle, radians) or a slider's (its
/// displacement, metres: `slider_limit.rs`).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct HingeLimit<T> {
    coordinate: Coordinate,
    stiffness: T,
    /// The stops in the coordinate's unit (`−∞`/`+∞` for a side without one).
    min: T,
    max: T,
    slots: Vec<usize>,
}

/// A stop's angle in radians, checked within (−180°, 180°).
fn stop(d: f64, path: &FieldPath) -> Result<f64> {
    let d = finite(d, path)?;
    if d.abs() >= 180.0 {
        return Err(err(
            SceneErrorKind::Value,
            path.clone(),
            format!("a stop is an angle from the initial poses in (-180, 180) degrees, not {d}"),
        ));
    }
    Ok(d.to_radians())
}

impl Effect for HingeLimitSpec {
    const FLAG: Flag = Flag::Springs;
    fn assemble(
        &self,
        cx: &mut Assembler<'_>,
        path: &FieldPath,
        _label: &str,
        _on: bool,
    ) -> Result<Option<Potential<f64>>> {
        let angle = crate::scene::ports::hinge_angle(
            &self.bodies,
            &self.axis,
            &self.axes,
            cx.bodies,
            path,
        )?;
        let min = self
            .min_deg
            .map(|d| stop(d, &path.key("min_deg")))
            .transpose()?;
        let max = self
            .max_deg
            .map(|d| stop(d, &path.key("max_deg")))
            .transpose()?;
        let limit = HingeLimit::checked(
            Coordinate::Angle(angle),
            self.stiffness,
            [min, max],
            path,
            ("hinge", ["min_deg", "max_deg"]),
        )?;
        Ok(Some(Potential::HingeLimit(limit)))
    }
}

impl HingeLimit<f64> {
    /// The stops `[min, max]` (in the coordinate's unit; `None` for a side without one) of
    /// stiffness `k` on `coordinate`, checked: `k > 0`, a stop at least, `min < max`. `kind` and
    /// `keys` name the joint and the stops' fields in the messages, the lower stop as the
    /// unit's reading given, the upper one likewise.
    pub(super) fn checked(
        coordinate: Coordinate,
        k: f64,
        [min, max]: [Option<f64>; 2],
        path: &FieldPath,
        (kind, keys): (&str, [&str; 2]),
    ) -> Result<Self> {
        let k = positive(k, &path.key("stiffness"), "stiffness")?;
        if min.is_none() && max.is_none() {
            return Err(err(
                SceneErrorKind::Value,
                path.clone(),
                format!(
                    "a {kind} limit needs a stop: {}, {} or both",
                    keys[0], keys[1]
                ),
            ));
        }
        let (min, max) = (
            min.unwrap_or(f64::NEG_INFINITY),
            max.unwrap_or(f64::INFINITY),
        );
        if min >= max {
            return Err(err(
                SceneErrorKind::Value,
                path.key(keys[1]),
                format!(
                    "the upper stop must lie above the lower one ({} <= {})",
                    keys[1], keys[0]
                ),
            ));
        }
        let slots = coordinate.slots();
        Ok(Self {
            coordinate,
            stiffness: k,
            min,
            max,
            slots,
        })
    }

    pub(crate) fn with_scalar<U: Real>(&self) -> HingeLimit<U> {
        HingeLimit {
            coordinate: self.coordinate.clone(),
            stiffness: U::lit(self.stiffness),
            min: U::lit(self.min),
            max: U::lit(self.max),
            slots: self.slots.clone(),
        }
    }
}

impl<T: Real> HingeLimit<T> {
    /// How far past a stop the coordinate is (`θ − θ_max > 0`, `θ − θ_min < 0`), zero between
    /// them (an angle in `(−π, π]`, as [`crate::rigid::HingeAngle::value`] gives it).
    fn overshoot(&self, q: &[T]) -> T {
        let theta = self.coordinate.value(q);
        if theta > self.max {
            theta - self.max
        } else if theta < self.min {
            theta - self.min
        } else {
            T::zero()
        }
    }
}

impl<T: Real> PotentialOps<T> for HingeLimit<T> {
    fn energy(&self, q: &[T], _d: usize) -> T {
        let o = self.overshoot(q);
        T::lit(0.5) * self.stiffness * o * o
    }
    fn gradient_add(&self, q: &[T], _d: usize, alpha: T, out: &mut [T]) {
        let o = self.overshoot(q);
        if o != T::zero() {
            self.coordinate
                .gradient_add(q, alpha * self.stiffness * o, out);
        }
    }
    /// `k (∇θ·v) ∇θ + k o ∇²θ v` past a stop, zero between them.
    fn hessian_apply_add(&self, q: &[T], _d: usize, v: &[T], out: &mut [T]) {
        let o = self.overshoot(q);
        if o != T::zero() {
            spring_hessian_add(&self.coordinate, q, v, self.stiffness, o, out);
        }
    }
    fn is_quadratic(&self) -> bool {
        false
    }
    fn hessian_bodies(&self, out: &mut Vec<(usize, usize)>) {
        slot_pairs(&self.slots, out);
    }
}
