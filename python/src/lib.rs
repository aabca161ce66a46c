//! Python bindings of lieflow (the module `lieflow._lieflow`, re-exported by the package
//! `lieflow`): scenes from a file or a string, run to their end with a summary, or stepped by
//! the caller — advance to a time, set held inputs, read outputs, multipliers and energies,
//! save and restore — and the lab's work–precision sets and sweeps, with states and trajectories as numpy arrays built once from Rust vectors
//! (nothing is allocated in Python per step). A scene's located errors become `SceneError`, a
//! failed step `StepError`.

mod animate;
mod errors;
mod lab;
mod simulation;

use pyo3::prelude::*;

/// The extension module.
#[pymodule]
fn _lieflow(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<simulation::Simulation>()?;
    m.add_class::<simulation::Checkpoint>()?;
    m.add_function(wrap_pyfunction!(simulation::run, m)?)?;
    m.add_function(wrap_pyfunction!(simulation::default_scene, m)?)?;
    m.add_function(wrap_pyfunction!(lab::precision, m)?)?;
    m.add_function(wrap_pyfunction!(lab::sweep, m)?)?;
    m.add("SceneError", m.py().get_type::<errors::SceneError>())?;
    m.add("StepError", m.py().get_type::<errors::StepError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
