//! The measuring tools from Python: work–precision sets against a reference and the peers, and
//! parameter sweeps — the same functions `lieflow precision` and `lieflow sweep` call, their
//! rows as dicts with the command's CSV/JSONL fields.

use crate::errors::scene_error;
use lieflow::scene::Scene;
use lieflow_lab::precision::{
    PrecisionPlan, fitted_slopes, fitting_window, reference, work_precision,
};
use lieflow_lab::sweep::{Sweep, run_all};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::path::PathBuf;

/// A JSON text as the Python object `json.loads` makes of it.
fn from_json<'py>(py: Python<'py>, json: &str) -> PyResult<Bound<'py, PyAny>> {
    py.import("json")?.call_method1("loads", (json,))
}

/// The work–precision set of the scene at `path` (as `lieflow precision`): every scheme over
/// the step sizes `dts` (default: four around the scene's `dt` that divide `t_end`), the peers
/// (DOP853, Radau5) over `tolerances`, against a reference (closed form, double-double
/// extrapolation, or double precision with `f64_reference`). Returns
/// `{"reference": {...}, "rows": [...], "fitted_orders": {method: slope}}`; every row has the
/// command's CSV fields (`method`, `dt`, `tol`, `status`, `error`, `max_abs_g`, `time_min_s`, …).
#[pyfunction]
#[pyo3(signature = (path, dts = None, orders = None, tolerances = None, repeats = 1, peers = true, implicit = true, f64_reference = false))]
#[allow(clippy::too_many_arguments)]
pub fn precision<'py>(
    py: Python<'py>,
    path: PathBuf,
    dts: Option<Vec<f64>>,
    orders: Option<Vec<u32>>,
    tolerances: Option<Vec<f64>>,
    repeats: usize,
    peers: bool,
    implicit: bool,
    f64_reference: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let scene = Scene::from_path(&path).map_err(|e| scene_error(py, &e))?;
    let mut plan = PrecisionPlan::around(scene.file.integrator.step(), scene.file.integrator.t_end);
    if let Some(d) = dts {
        plan.dts = d;
    }
    if let Some(o) = orders {
        plan.orders = o;
    }
    if let Some(t) = tolerances {
        plan.tolerances = t;
    }
    if let Some(bad) = plan
        .dts
        .iter()
        .chain(&plan.tolerances)
        .find(|v| !(v.is_finite() && **v > 0.0))
    {
        return Err(PyValueError::new_err(format!(
            "step sizes and tolerances must be positive and finite, not {bad}"
        )));
    }
    if repeats == 0 {
        return Err(PyValueError::new_err("repeats must be at least 1"));
    }
    plan.repeats = repeats;
    plan.double_double = !f64_reference;
    plan.peers = peers;
    if !implicit {
        plan.discrete_gradient = false;
        plan.midpoint = false;
        plan.modified = false;
        plan.petrov_galerkin.clear();
    }
    let reference = reference(&scene, &plan).map_err(|e| scene_error(py, &e))?;
    let rows = work_precision(&scene, &plan, &reference, &mut |_| {});
    let h_min = plan.dts.iter().copied().fold(f64::INFINITY, f64::min);
    let (floor, ceiling) = fitting_window(&reference, h_min);
    let slopes = fitted_slopes(&rows, floor, ceiling);
    let out = PyDict::new(py);
    out.set_item("reference", from_json(py, &json(&reference))?)?;
    out.set_item("rows", from_json(py, &json(&rows))?)?;
    let fitted = PyDict::new(py);
    for (method, slope) in slopes {
        fitted.set_item(method, slope)?;
    }
    out.set_item("fitted_orders", fitted)?;
    Ok(out)
}

/// Runs the sweep file at `path` (as `lieflow sweep`) on `threads` threads (0: one per core)
/// and returns one dict per member, in member order: its `parameters` (`path → value`), the run's outputs
/// (`t`, `steps`, `max_abs_g`, `dissipated`, …), its `error` (`None`, or `[kind, message]`) and
/// `seconds`. The rows do not depend on `threads`.
#[pyfunction]
#[pyo3(signature = (path, threads = 0))]
pub fn sweep<'py>(py: Python<'py>, path: PathBuf, threads: usize) -> PyResult<Bound<'py, PyList>> {
    let sweep = Sweep::from_path(&path).map_err(|e| scene_error(py, &e))?;
    let members: Vec<_> = sweep.members().collect();
    let rows = run_all(&sweep, &members, threads, &|| {}).map_err(PyValueError::new_err)?;
    let out = PyList::empty(py);
    for (row, seconds) in rows {
        let dict = from_json(py, &json(&row))?;
        // `path → value` as a dict, as the command's JSONL writes it.
        let parameters = PyDict::new(py);
        for (path, value) in &row.parameters {
            parameters.set_item(path, value)?;
        }
        dict.set_item("parameters", parameters)?;
        dict.set_item("seconds", seconds)?;
        out.append(dict)?;
    }
    Ok(out)
}

/// A row (or rows) of the lab as JSON text.
fn json<T: serde::Serialize + ?Sized>(v: &T) -> String {
    serde_json::to_string(v).expect("the lab's rows serialize")
}
