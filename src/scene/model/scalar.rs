//! The model in another scalar (double-double for reference runs).

use super::{
    Counter, SceneModel,
    terms::{ConstraintKind, ConstraintTerm, PairLaw, Potential, PotentialTerm, StructureTerm},
};
use crate::real::Real;

impl SceneModel<f64> {
    /// The same model in another scalar (e.g. double-double for reference runs): every
    /// parameter rounded to `T`, fresh counters, no profiling.
    pub fn with_scalar<T: Real>(&self) -> SceneModel<T> {
        let c = |x: f64| T::lit(x);
        let c3 = |v: [f64; 3]| v.map(T::lit);
        let law = |l: &PairLaw| match *l {
            PairLaw::InversePower { strength, power } => PairLaw::InversePower {
                strength: c(strength),
                power: c(power),
            },
            PairLaw::Log { strength } => PairLaw::Log {
                strength: c(strength),
            },
            PairLaw::LennardJones { epsilon, sigma } => PairLaw::LennardJones {
                epsilon: c(epsilon),
                sigma: c(sigma),
            },
            PairLaw::Spring { stiffness, rest } => PairLaw::Spring {
                stiffness: c(stiffness),
                rest: c(rest),
            },
        };
        let potentials = self
            .potentials
            .iter()
            .map(|t| PotentialTerm {
                label: t.label.clone(),
                kind: t.kind,
                potential: match &t.potential {
                    Potential::Gravity { forces } => Potential::Gravity {
                        forces: forces.iter().map(|&(b, f)| (b, c3(f))).collect(),
                    },
                    Potential::Pairs { pairs, law: l } => Potential::Pairs {
                        pairs: pairs.clone(),
                        law: law(l),
                    },
                    Potential::Trap {
                        stiffness,
                        center,
                        bodies,
                    } => Potential::Trap {
                        stiffness: c(*stiffness),
                        center: c3(*center),
                        bodies: bodies.clone(),
                    },
                },
                counter: Counter::default(),
            })
            .collect();
        let constraints = self
            .constraints
            .iter()
            .map(|t| ConstraintTerm {
                kind: match t.kind {
                    ConstraintKind::Pin { body, point } => ConstraintKind::Pin {
                        body,
                        point: c3(point),
                    },
                    ConstraintKind::Rod {
                        a,
                        b,
                        point,
                        length,
                    } => ConstraintKind::Rod {
                        a,
                        b,
                        point: c3(point),
                        length: c(length),
                    },
                    ConstraintKind::Sphere {
                        body,
                        center,
                        radius,
                    } => ConstraintKind::Sphere {
                        body,
                        center: c3(center),
                        radius: c(radius),
                    },
                    ConstraintKind::Plane {
                        body,
                        normal,
                        offset,
                    } => ConstraintKind::Plane {
                        body,
                        normal: c3(normal),
                        offset: c(offset),
                    },
                },
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
        SceneModel::new(
            self.dim,
            self.masses.iter().map(|&m| c(m)).collect(),
            potentials,
            constraints,
            self.damping.as_ref().map(structure),
            self.magnetic.as_ref().map(field),
            false,
        )
    }
}
