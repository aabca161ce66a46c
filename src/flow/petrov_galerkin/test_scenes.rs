//! The scenes the step's unit tests run on: a scene's text compiled to its model (as a
//! [`System`](crate::system::System)) and its initial state.

use crate::system::Model;
use nalgebra::DVector;

/// The compiled model of a scene's text and its initial state.
pub(super) fn scene(text: &str) -> (impl Model<DVector<f64>> + use<>, DVector<f64>) {
    let compiled = crate::scene::Scene::from_toml(text, "test.toml")
        .and_then(|s| s.compile())
        .unwrap_or_else(|e| panic!("{e}"));
    let x0 = DVector::from_column_slice(compiled.simulation.state());
    let model = compiled.model.expect("a scene of bodies");
    (
        crate::system::System::new(model.clone(), model.clone(), model),
        x0,
    )
}
