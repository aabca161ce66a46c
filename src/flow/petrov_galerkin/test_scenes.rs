//! The scenes the step's unit tests run on: a scene's text compiled to its model (as a
//! [`System`](crate::system::System)) and its initial state.

use crate::system::Model;
use crate::vector::Vector;
use nalgebra::DVector;

/// The compiled model of a scene's text and its initial state.
pub(super) fn scene(text: &str) -> (impl Model<DVector<f64>> + use<>, DVector<f64>) {
    // The model alone: compiling the scene's flow would instantiate every flow a scene can run
    // in this test binary.
    let (model, x0) = crate::scene::Scene::from_toml(text, "test.toml")
        .and_then(|s| crate::scene::model_of(&s.file).map_err(|e| e.locate("test.toml", text)))
        .unwrap_or_else(|e| panic!("{e}"));
    let x0 = DVector::from_column_slice(x0.as_slice());
    (
        crate::system::System::new(model.clone(), model.clone(), model),
        x0,
    )
}
