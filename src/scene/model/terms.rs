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

impl<T> ConstraintKind<T> {
    /// Number of rows (`d` for a pin, 1 otherwise).
    pub(crate) fn rows(&self, d: usize) -> usize {
        match self {
            ConstraintKind::Pin { .. } => d,
            _ => 1,
        }
    }
}

impl ConstraintKind<f64> {
    /// The force of a row per unit multiplier at positions `q` (`d` per body), with the sign
    /// of its output (`constraint-force`): the force on the body is `−G_qᵀλ`, so a rod pulls
    /// its ends together with the tension `λ |q_a − r|`, a sphere pulls toward its centre with
    /// `λ |q − c|`, a plane pushes along its unit normal with `−λ`, a pin with `−λ_k` along
    /// axis `k`.
    pub(crate) fn force_per_multiplier(&self, q: &[f64], d: usize) -> f64 {
        let distance = |b: usize, r: &[f64; 3]| {
            (0..d)
                .map(|k| (q[b * d + k] - r[k]).powi(2))
                .sum::<f64>()
                .sqrt()
        };
        match self {
            ConstraintKind::Pin { .. } | ConstraintKind::Plane { .. } => -1.0,
            ConstraintKind::Rod { a, b, point, .. } => {
                let r = match b {
                    Some(b) => core::array::from_fn(|k| if k < d { q[b * d + k] } else { 0.0 }),
                    None => *point,
                };
                distance(*a, &r)
            }
            ConstraintKind::Sphere { body, center, .. } => distance(*body, center),
        }
    }
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
