//! The terms a scene assembles besides its potentials (those are in `scene/effects/`):
//! constraint kinds with their rows, and the merged per-body coefficients of `M`'s terms.

use super::Counter;

/// A holonomic constraint term.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum ConstraintKind<T = f64> {
    /// `q_b − point = 0` (`d` rows).
    Pin { body: usize, point: [T; 3] },
    /// `(|q_a − r|² − L²)/2 = 0` with `r = q_b`, or the fixed `point` when `b` is `None`.
    Rod {
        a: usize,
        b: Option<usize>,
        point: [T; 3],
        length: T,
    },
    /// `(|q_b − c|² − r²)/2 = 0`.
    Sphere {
        body: usize,
        center: [T; 3],
        radius: T,
    },
    /// `n · q_b − offset = 0`, `|n| = 1`.
    Plane {
        body: usize,
        normal: [T; 3],
        offset: T,
    },
}

/// A constraint term, its first row in `g`, and a label naming where it came from.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct ConstraintTerm<T = f64> {
    pub(crate) kind: ConstraintKind<T>,
    pub(crate) row: usize,
    pub(crate) label: String,
    /// Where the scene declares it (for errors).
    pub(crate) path: crate::scene::error::FieldPath,
}

impl<T> ConstraintTerm<T> {
    /// Number of rows (`d` for a pin, 1 otherwise).
    pub(crate) fn rows(&self, d: usize) -> usize {
        match self.kind {
            ConstraintKind::Pin { .. } => d,
            _ => 1,
        }
    }
}

/// The merged per-body coefficients of one kind of `M` term (damping `c_b` or `e_b B`).
#[derive(Debug)]
pub(crate) struct StructureTerm<P> {
    pub(crate) label: String,
    pub(crate) per_body: Vec<P>,
    pub(crate) counter: Counter,
}
