//! `Simulation.animate`: the run's animation page (`lieflow_view`), as `lieflow run --animate`
//! writes it.

use lieflow::scene::sketch::Sketch;
use lieflow::scene::{Assembly, Simulation};
use lieflow_view::{FrameBudget, PageInfo, Recorder, write_page};
use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyDictMethods};
use std::path::Path;

/// The recorder of a run of `sim` to `t_end`.
pub(crate) fn recorder(
    sketch: Option<&Sketch>,
    sim: &dyn Simulation,
    t_end: f64,
    frames: Option<usize>,
    trace: &[String],
) -> PyResult<Recorder> {
    let mut budget = FrameBudget::default();
    if let Some(f) = frames {
        if f < 2 {
            return Err(PyValueError::new_err("frames must be at least 2"));
        }
        budget.max_frames = f;
    }
    Recorder::new(
        sketch,
        sim.state().len(),
        sim.output_names(),
        (sim.time(), t_end),
        trace,
        budget,
    )
    .map_err(|e| PyValueError::new_err(e.to_string()))
}

/// The page's title, subtitle and events, from the run's summary `dict`.
pub(crate) fn info(
    a: &Assembly,
    sim: &dyn Simulation,
    dict: &Bound<'_, PyDict>,
) -> PyResult<PageInfo> {
    let mut events = Vec::new();
    if let Some(list) = dict.get_item("events")? {
        for e in list.try_iter()? {
            let e = e?;
            events.push((e.get_item("name")?.extract()?, e.get_item("t")?.extract()?));
        }
    }
    let steps: usize = dict.get_item("steps")?.map_or(Ok(0), |v| v.extract())?;
    Ok(PageInfo {
        title: a.name.clone(),
        subtitle: format!(
            "{}, order {}, dt = {}; {steps} steps to t = {}",
            a.scheme,
            a.order,
            sim.dt(),
            sim.time()
        ),
        events,
    })
}

/// Ends the frames with the run's last state and writes the page; returns
/// `{"path", "frames", "bytes"}`.
pub(crate) fn write<'py>(
    py: Python<'py>,
    recorder: &mut Recorder,
    path: &Path,
    info: &PageInfo,
) -> PyResult<Bound<'py, PyDict>> {
    recorder.finish();
    let bytes = write_page(path, recorder, info)
        .map_err(|e| PyOSError::new_err(format!("writing {}: {e}", path.display())))?;
    let out = PyDict::new(py);
    out.set_item("path", path.display().to_string())?;
    out.set_item("frames", recorder.frames())?;
    out.set_item("bytes", bytes)?;
    Ok(out)
}
