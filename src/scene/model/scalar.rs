//! The model in another scalar (double-double for reference runs).

use super::{
    Counter, SceneModel,
    terms::{ConstraintTerm, StructureTerm},
};
use crate::real::Real;
use crate::scene::effects::PotentialTerm;

impl SceneModel<f64> {
    /// The same model in another scalar (e.g. double-double for reference runs): every
    /// parameter rounded to `T`, fresh counters, no profiling.
    pub fn with_scalar<T: Real>(&self) -> SceneModel<T> {
        let c = |x: f64| T::lit(x);
        let c3 = |v: [f64; 3]| v.map(T::lit);
        let potentials = self
            .potentials
            .iter()
            .map(|t| PotentialTerm {
                label: t.label.clone(),
                kind: t.kind,
                potential: t.potential.with_scalar(),
                counter: Counter::default(),
            })
            .collect();
        let constraints = self
            .constraints
            .iter()
            .map(|t| ConstraintTerm {
                kind: t.kind.with_scalar(),
                row: t.row,
                label: t.label.clone(),
                path: t.path.clone(),
            })
            .collect();
        let structure = |t: &StructureTerm<f64>| StructureTerm {
            label: t.label.clone(),
            per_body: t.per_body.iter().map(|&x| c(x)).collect(),
            counter: Counter::default(),
        };
        let field = |t: &StructureTerm<[f64; 3]>| StructureTerm {
            label: t.label.clone(),
            per_body: t.per_body.iter().map(|&x| c3(x)).collect(),
            counter: Counter::default(),
        };
        let mut model = SceneModel::new(
            self.dim,
            self.masses.iter().map(|&m| c(m)).collect(),
            potentials,
            constraints,
            self.damping.as_ref().map(structure),
            self.magnetic.as_ref().map(field),
            false,
        );
        model.inputs = self.inputs.as_ref().map(|i| i.with_scalar());
        model.zero_damping = self.zero_damping;
        model.dashpots = self.dashpots.as_ref().map(|t| super::Dashpots {
            label: t.label.clone(),
            pairs: t.pairs.iter().map(|&(a, b, k)| (a, b, c(k))).collect(),
            counter: Counter::default(),
        });
        model.hinge_dampers = self.hinge_dampers.as_ref().map(|t| super::HingeDampers {
            label: t.label.clone(),
            dampers: t.dampers.iter().map(|(a, k)| (a.clone(), c(*k))).collect(),
            counter: Counter::default(),
        });
        model.state_names.clone_from(&self.state_names);
        model.multiplier_names.clone_from(&self.multiplier_names);
        model
    }
}
