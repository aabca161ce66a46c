//! A joint's coordinate as an output or an event's quantity (`joint-position`,
//! `joint-velocity`, `constraint = "<name>"`): a hinge's angle, unwrapped across turns, or a
//! slider's displacement, zero at the initial poses, and their rates `∇c · q̇`.
//!
//! **Unwrapping.** The hinge's angle `θ(q)` is a function of the positions only modulo a turn
//! (`HingeAngle` gives it in `(−π, π]`). The run keeps, for each angle it reads, the last
//! unwrapped value `r` (after every step, and in checkpoints) and reads
//! `r + wrap(θ(q) − r)`, `wrap` to `(−π, π]`: continuous, and exact as long as the joint turns
//! less than half a turn in a step (a step that resolves the motion turns it far less). Events
//! read the same value, so a level such as `θ = 2π` is crossed once, a turn in.

use crate::rigid::{Coordinate, JointCoordinate};
use std::f64::consts::{PI, TAU};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

/// The coordinates of the scene's named hinges and sliders, and a run's unwrapping state: for
/// each angle, the last unwrapped value, and whether anything reads it.
#[derive(Debug, Default)]
pub(crate) struct JointTable {
    joints: Vec<(String, Coordinate)>,
    /// `r`, as `f64` bits (shared by the outputs and the events' functions of one run).
    reference: Vec<AtomicU64>,
    read: Vec<AtomicBool>,
}

/// `x` to `(−π, π]`.
fn wrap(x: f64) -> f64 {
    let y = x - TAU * (x / TAU).round();
    if y <= -PI { y + TAU } else { y }
}

impl JointTable {
    /// The table of `joints` (name, coordinate), every angle at zero (the initial poses').
    pub(crate) fn new(joints: Vec<(String, Coordinate)>) -> Self {
        let n = joints.len();
        Self {
            joints,
            reference: (0..n).map(|_| AtomicU64::new(0f64.to_bits())).collect(),
            read: (0..n).map(|_| AtomicBool::new(false)).collect(),
        }
    }

    /// The index of the joint `name`, marking it read; `None` for a name that is not a named
    /// hinge or slider.
    pub(crate) fn find(&self, name: &str) -> Option<usize> {
        let j = self.joints.iter().position(|(n, _)| n == name)?;
        self.read[j].store(true, Ordering::Relaxed);
        Some(j)
    }

    /// The names of the joints it holds.
    pub(crate) fn names(&self) -> Vec<&str> {
        self.joints.iter().map(|(n, _)| n.as_str()).collect()
    }

    /// Whether an output reads a hinge's angle (unwrapped step by step).
    pub(crate) fn reads_angles(&self) -> bool {
        (0..self.joints.len()).any(|j| self.read[j].load(Ordering::Relaxed) && self.is_angle(j))
    }

    /// Whether joint `j` is a hinge (its coordinate an angle).
    pub(crate) fn is_angle(&self, j: usize) -> bool {
        matches!(self.joints[j].1, Coordinate::Angle(_))
    }

    fn reference(&self, j: usize) -> f64 {
        f64::from_bits(self.reference[j].load(Ordering::Relaxed))
    }

    /// Joint `j`'s coordinate at positions `q` (an angle unwrapped against the run's last).
    pub(crate) fn position(&self, j: usize, q: &[f64]) -> f64 {
        match &self.joints[j].1 {
            Coordinate::Angle(a) => {
                let r = self.reference(j);
                r + wrap(a.value(q) - r)
            }
            c => c.value(q),
        }
    }

    /// Joint `j`'s rate `∇c(q) · v` at velocities `v`.
    pub(crate) fn velocity(&self, j: usize, q: &[f64], v: &[f64]) -> f64 {
        self.joints[j].1.derivative(q, v)
    }

    /// After a step to positions `q`: every read angle's reference moves to its unwrapped value.
    pub(crate) fn advance(&self, q: &[f64]) {
        for j in 0..self.joints.len() {
            if self.read[j].load(Ordering::Relaxed) && self.is_angle(j) {
                let value = self.position(j, q);
                self.reference[j].store(value.to_bits(), Ordering::Relaxed);
            }
        }
    }

    /// The run's unwrapping state (for a checkpoint).
    pub(crate) fn save(&self) -> Vec<f64> {
        (0..self.joints.len()).map(|j| self.reference(j)).collect()
    }

    /// Restores [`save`](Self::save)'s state (ignored if of another table).
    pub(crate) fn restore(&self, saved: &[f64]) {
        if saved.len() == self.reference.len() {
            for (r, &v) in self.reference.iter().zip(saved) {
                r.store(v.to_bits(), Ordering::Relaxed);
            }
        }
    }

    /// Whether any joint is read (the run then advances the table every step).
    pub(crate) fn any_read(&self) -> bool {
        self.read.iter().any(|r| r.load(Ordering::Relaxed))
    }
}

/// The coordinates of the scene's named hinges and sliders, as their joints read the bodies:
/// a hinge's angle of its first body against its second (or the world), counter-clockwise
/// about its axis; a slider's displacement of its first body from its second (or the world)
/// along the axis the first carries, `(P_A − P_B)·u_A`.
pub(crate) fn joint_table(
    file: &crate::scene::schema::SceneFile,
    bodies: &crate::scene::bodies::Bodies,
) -> crate::scene::validate::Result<JointTable> {
    use crate::scene::constraints::ConstraintSpec;
    let root = crate::scene::error::FieldPath::root().key("constraints");
    let mut joints = Vec::new();
    for (i, c) in file.constraints.iter().enumerate() {
        let path = root.index(i);
        let coordinate = match c {
            ConstraintSpec::Hinge(h) if h.name.is_some() => Coordinate::Angle(super::hinge_angle(
                &h.bodies, &h.axis, &h.axes, bodies, &path,
            )?),
            ConstraintSpec::Slider(s) if s.name.is_some() => {
                Coordinate::Displacement(super::slider_displacement(
                    &s.bodies, &s.anchor, &s.anchors, &s.axis, &s.axes, bodies, &path,
                )?)
            }
            _ => continue,
        };
        joints.push((c.name().cloned().unwrap_or_default(), coordinate));
    }
    Ok(JointTable::new(joints))
}

#[cfg(test)]
mod tests {
    use super::wrap;
    use std::f64::consts::PI;

    #[test]
    fn wrap_lands_in_the_half_open_turn() {
        for (x, want) in [
            (0.0, 0.0),
            (PI, PI),
            (-PI, PI),
            (3.0 * PI, PI),
            (2.0 * PI + 0.1, 0.1),
            (-2.0 * PI - 0.1, -0.1),
            (7.0, 7.0 - 2.0 * PI),
        ] {
            assert!((wrap(x) - want).abs() < 1e-14, "{x}: {} vs {want}", wrap(x));
        }
    }
}
