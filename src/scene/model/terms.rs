//! The terms a scene assembles besides its potentials (those are in `scene/effects/`): its
//! constraint terms (their rows are in `scene/constraints/`) and the merged per-body
//! coefficients of `M`'s terms.

use super::Counter;
use crate::real::Real;
use crate::scene::constraints::Constraint;

/// A constraint term, its first row in `g`, and a label naming where it came from.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct ConstraintTerm<T = f64> {
    pub(crate) kind: Constraint<T>,
    pub(crate) row: usize,
    pub(crate) label: String,
    /// Where the scene declares it (for errors).
    pub(crate) path: crate::scene::error::FieldPath,
}

impl<T: Real> ConstraintTerm<T> {
    /// Number of rows (`d` for a pin, 1 otherwise).
    pub(crate) fn rows(&self, d: usize) -> usize {
        self.kind.rows(d)
    }
}

/// The merged per-body coefficients of one kind of `M` term (damping `c_b` or `e_b B`).
#[derive(Debug)]
pub(crate) struct StructureTerm<P> {
    pub(crate) label: String,
    pub(crate) per_body: Vec<P>,
    pub(crate) counter: Counter,
}
