//! The Python exceptions: `SceneError` (a `ValueError`) carries the scene's located message and
//! its parts (`kind`, `path`, `line`, `column`); `StepError` (a `RuntimeError`) a failed step's.

use pyo3::create_exception;
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;

create_exception!(
    _lieflow,
    SceneError,
    PyValueError,
    "A scene that does not parse, check or compile: the message says what and where (file:line:column: `field`: what is wrong); `kind`, `path`, `line` and `column` hold the parts."
);
create_exception!(
    _lieflow,
    StepError,
    PyRuntimeError,
    "A step that failed (a Newton solve, a non-finite state): the simulation keeps its last good state."
);

/// A `SceneError` with the error's message and its parts as attributes.
pub(crate) fn scene_error(py: Python<'_>, e: &lieflow::scene::SceneError) -> PyErr {
    let err = SceneError::new_err(e.to_string());
    let value = err.value(py);
    let (line, column) = e
        .location
        .as_ref()
        .map_or((None, None), |l| (Some(l.line), Some(l.column)));
    // Attributes on the exception object; a failure to set one would only lose detail.
    let _ = value.setattr("kind", format!("{:?}", e.kind));
    let _ = value.setattr("path", e.path.to_string());
    let _ = value.setattr("line", line);
    let _ = value.setattr("column", column);
    err
}

/// A `StepError` with the step error's message.
pub(crate) fn step_error(e: &impl std::fmt::Display) -> PyErr {
    StepError::new_err(e.to_string())
}
