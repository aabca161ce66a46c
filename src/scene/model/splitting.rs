//! The kick of a scene's splitting as one type — the potential's [`Kick`] alone, or that kick
//! composed with the scene's dashpots and inputs — and the splitting itself as one type.
//!
//! The splitting `kick(h/2) ∘ free flight(h) ∘ kick(h/2)` is generic over its kick, and every
//! kick type is a new projected flow for every state storage, compiled in full. The optional
//! parts (dashpots `D(τ/2) ∘ K(τ) ∘ D(τ/2)`, inputs `K(τ/2) ∘ U(τ) ∘ K(τ/2)`) are therefore
//! composed behind one pointer, and the scene's splitting has one kick type whatever it declares:
//! the plain kick, the common case, is called directly; the composed one costs one indirect
//! call per sub-step, beside the dashpots' exponentials and the signals' integrals it runs.

use super::{FreeFlight, Kick, SceneModel};
use crate::flow::{Flow, Strang};
use crate::vector::Vector;
use std::sync::Arc;

crate::flow::flow_enum! {
    /// A scene's kick: the potential's alone, or composed with dashpots and inputs (see the
    /// module docs). Every [`Flow`] method is that of the flow it holds.
    pub enum SceneKick<V> {
        /// The potential terms' kick.
        Potential(Kick<V::Real>),
        /// The kick composed with the scene's dashpots and inputs.
        Composed(Box<dyn Flow<V>>),
    }
}

impl<V: Vector> SceneKick<V> {
    /// The kick of `model`'s potential terms alone.
    pub fn potential(model: Arc<SceneModel<V::Real>>) -> Self {
        SceneKick::Potential(Kick::new(model))
    }
}

crate::flow::flow_enum! {
    /// A scene's splitting, the flow its projection wraps: the free flight alone (a scene of no
    /// potential, dashpot or input), or `kick(h/2) ∘ free flight(h) ∘ kick(h/2)`. One type for
    /// both, so that each state storage compiles one projected flow for scenes.
    pub enum SceneSplitting<V> {
        /// The exact free flight.
        Drift(FreeFlight<V::Real>),
        /// The kick around the free flight (Strang).
        Kicked(Strang<V, SceneKick<V>, FreeFlight<V::Real>>),
    }
}
