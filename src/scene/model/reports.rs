//! What each assembled term of a scene cost in a run: its evaluation count (and time share
//! when profiling), for the run's summary.

use super::SceneModel;
use crate::scene::simulation::EffectReport;

impl SceneModel {
    /// The assembled terms with their evaluation counts (and time shares when profiling).
    pub fn reports(&self) -> Vec<EffectReport> {
        // A free flight evaluates the kinetic term, the damping, the field and the gravity
        // joined to it at once (one count for all of them).
        let flights = self.flight_counter.evaluations();
        let mut out = vec![EffectReport {
            name: "kinetic".into(),
            kind: "kinetic",
            evaluations: self.kinetic.evaluations() + flights,
            time_share: None,
        }];
        for t in &self.potentials {
            let joined = if self.gravity_in_flight() && t.is_gravity() {
                flights
            } else {
                0
            };
            out.push(EffectReport {
                name: t.label.clone(),
                kind: t.kind.name(),
                evaluations: t.counter.evaluations() + joined,
                time_share: self.profile.then(|| t.counter.nanos() as f64),
            });
        }
        if let Some(t) = &self.damping {
            out.push(EffectReport {
                name: t.label.clone(),
                kind: "damping",
                evaluations: t.counter.evaluations() + flights,
                time_share: None,
            });
        }
        if let Some(t) = &self.dashpots {
            out.push(EffectReport {
                name: t.label.clone(),
                kind: "dashpot",
                evaluations: t.counter.evaluations(),
                time_share: None,
            });
        }
        if let Some(t) = &self.hinge_dampers {
            out.push(EffectReport {
                name: t.label.clone(),
                kind: t.kind(),
                evaluations: t.counter.evaluations(),
                time_share: None,
            });
        }
        if let Some(t) = &self.magnetic {
            out.push(EffectReport {
                name: t.label.clone(),
                kind: "magnetic",
                evaluations: t.counter.evaluations() + flights,
                time_share: None,
            });
        }
        if !self.constraints.is_empty() {
            out.push(EffectReport {
                name: "constraints".into(),
                kind: "constraints",
                evaluations: self.constraint_counter.evaluations(),
                time_share: self.profile.then(|| self.constraint_counter.nanos() as f64),
            });
        }
        out
    }
}
