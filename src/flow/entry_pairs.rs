//! The symbolic part of the products `G A Gᵀ` (`A` block-diagonal over the positions) that the
//! projection's multiplier Jacobians and the Petrov–Galerkin scheme's Schur complement sum:
//! the constraint's listed Jacobian entries and the pairs of entries that share a column,
//! grouped by the two rows they join — found once from the pattern, so that each product is a
//! pass over the pairs (faer's symbolic/numeric split).

use crate::linalg::Triplets;
use crate::system::HolonomicConstraint;
use crate::vector::Vector;

/// The entries of `G` and their pairs in a column (see the module documentation).
#[derive(Debug, Clone)]
pub(crate) struct EntryPairs {
    /// The entries' rows and columns, in the order the constraint lists them.
    pub(crate) rows: Vec<usize>,
    pub(crate) cols: Vec<usize>,
    /// The entries in each position column.
    pub(crate) of_col: Vec<Vec<usize>>,
    /// The pairs `(e₁, e₂)` of entries in one column, grouped by their rows: group `t` is
    /// `pairs[ptr[t]..ptr[t + 1]]` and adds to the entry `targets[t]` = (row of `e₁`, row of
    /// `e₂`) of the product; the groups in row-major order.
    pub(crate) pairs: Vec<(usize, usize)>,
    pub(crate) ptr: Vec<usize>,
    pub(crate) targets: Vec<(usize, usize)>,
}

impl EntryPairs {
    /// From the constraint's entries at `x0` (`nq` positions); `None` when it lists none, or
    /// one on a momentum or outside its rows.
    pub(crate) fn new<V, C>(constraint: &C, x0: &V, nq: usize) -> Option<Self>
    where
        V: Vector,
        C: HolonomicConstraint<V>,
    {
        let mut entries = Triplets::default();
        let m = constraint.dim();
        if !constraint.jacobian_entries(x0, &mut entries)
            || entries.entries.is_empty()
            || entries.entries.iter().any(|&(r, c, _)| c >= nq || r >= m)
        {
            return None;
        }
        let rows: Vec<usize> = entries.entries.iter().map(|e| e.0).collect();
        let cols: Vec<usize> = entries.entries.iter().map(|e| e.1).collect();
        let mut of_col: Vec<Vec<usize>> = vec![Vec::new(); nq];
        for (e, &d) in cols.iter().enumerate() {
            of_col[d].push(e);
        }
        let mut keyed: Vec<((usize, usize), (usize, usize))> = Vec::new();
        for es in &of_col {
            for &e1 in es {
                keyed.extend(es.iter().map(|&e2| ((rows[e1], rows[e2]), (e1, e2))));
            }
        }
        keyed.sort_unstable();
        let (mut ptr, mut targets) = (vec![0], Vec::new());
        for (i, &(key, _)) in keyed.iter().enumerate() {
            if targets.last() != Some(&key) {
                if i > 0 {
                    ptr.push(i);
                }
                targets.push(key);
            }
        }
        ptr.push(keyed.len());
        Some(Self {
            rows,
            cols,
            of_col,
            pairs: keyed.into_iter().map(|(_, p)| p).collect(),
            ptr,
            targets,
        })
    }

    /// The pairs of group `t`.
    #[inline]
    pub(crate) fn group(&self, t: usize) -> &[(usize, usize)] {
        &self.pairs[self.ptr[t]..self.ptr[t + 1]]
    }
}
