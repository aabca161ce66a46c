//! Every `every`-th state of a run, with its time.

use super::Observer;
use crate::vector::Vector;

/// Records every `every`-th state with its time (allocates as it grows: only when asked for).
#[derive(Debug, Clone)]
pub struct Trajectory<V: Vector> {
    every: usize,
    /// Recorded times.
    pub t: Vec<V::Real>,
    /// Recorded states.
    pub x: Vec<V>,
}

impl<V: Vector> Trajectory<V> {
    /// Records every `every`-th state (`every ≥ 1`).
    pub fn every(every: usize) -> Self {
        Self {
            every: every.max(1),
            t: Vec::new(),
            x: Vec::new(),
        }
    }
}

impl<V: Vector> Observer<V> for Trajectory<V> {
    fn observe(&mut self, k: usize, t: V::Real, x: &V) {
        if k.is_multiple_of(self.every) {
            self.t.push(t);
            self.x.push(x.clone());
        }
    }
}
