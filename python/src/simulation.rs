//! `Simulation`: a compiled scene that Python runs or steps, and `Checkpoint`, a saved state.

use crate::errors::{scene_error, step_error};
use lieflow::scene::{Assembly, RunPlan, Scene};
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray1};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;

/// A scene compiled into its model and scheme, ready to run or to step.
///
/// Load one with `lieflow.load(path)` or `lieflow.loads(text)`. `run()` takes the scene's own
/// steps to its `t_end`, as `lieflow run` does, and returns the summary with the trajectory as
/// numpy arrays; `step()`, `advance_to(t)`, `set_input`, `outputs()`, `multipliers()`, `save()`
/// and `restore()` drive it from a larger simulation.
#[pyclass(unsendable, module = "lieflow")]
pub struct Simulation {
    sim: Box<dyn lieflow::scene::Simulation>,
    plan: RunPlan,
    assembly: Assembly,
    /// What the animation page draws (`None` for a built-in model).
    sketch: Option<lieflow::scene::sketch::Sketch>,
}

/// A saved state of a `Simulation` (see `Simulation.save`): restoring it makes the continuation
/// equal, bit for bit, to the run that went on from the save.
#[pyclass(unsendable, module = "lieflow")]
pub struct Checkpoint(lieflow::scene::SimulationCheckpoint);

impl Simulation {
    fn compile(py: Python<'_>, scene: Result<Scene, lieflow::scene::SceneError>) -> PyResult<Self> {
        let compiled = scene
            .and_then(|s| s.compile())
            .map_err(|e| scene_error(py, &e))?;
        Ok(Self {
            sim: compiled.simulation,
            plan: compiled.plan,
            assembly: compiled.assembly,
            sketch: compiled.sketch,
        })
    }
}

#[pymethods]
impl Simulation {
    /// Loads and compiles the scene file at `path`.
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        Self::compile(py, Scene::from_path(&path))
    }

    /// Compiles a scene given as TOML text; `name` is the file name its errors cite.
    #[staticmethod]
    #[pyo3(signature = (text, name = "scene.toml"))]
    fn loads(py: Python<'_>, text: &str, name: &str) -> PyResult<Self> {
        Self::compile(py, Scene::from_toml(text, name))
    }

    /// The scene's name.
    #[getter]
    fn name(&self) -> String {
        self.assembly.name.clone()
    }
    /// The scheme the scene compiled into, in words.
    #[getter]
    fn scheme(&self) -> String {
        self.assembly.scheme.clone()
    }
    /// The scheme's order.
    #[getter]
    fn order(&self) -> u32 {
        self.assembly.order
    }
    /// The time of the state.
    #[getter]
    fn t(&self) -> f64 {
        self.sim.time()
    }
    /// The step size.
    #[getter]
    fn dt(&self) -> f64 {
        self.sim.dt()
    }
    /// The state `x = (q, p)` (a copy).
    #[getter]
    fn state<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, self.sim.state())
    }
    /// The names of the state's components: `q.<body>.<axis>`, then `p.<body>.<axis>`.
    #[getter]
    fn state_names(&self) -> Vec<String> {
        self.sim.state_names()
    }
    /// `H(x)`.
    #[getter]
    fn energy(&self) -> f64 {
        self.sim.energy()
    }
    /// The energy dissipated so far as the scheme books it (`None` without dissipation).
    #[getter]
    fn dissipated(&self) -> Option<f64> {
        self.sim.dissipated()
    }
    /// The energy supplied through the inputs so far (`None` without inputs).
    #[getter]
    fn supplied(&self) -> Option<f64> {
        self.sim.supplied()
    }
    /// The names of the declared inputs.
    #[getter]
    fn input_names(&self) -> Vec<String> {
        self.sim.input_names()
    }
    /// The names of the declared outputs.
    #[getter]
    fn output_names(&self) -> Vec<String> {
        self.sim.output_names()
    }
    /// One name per constraint row.
    #[getter]
    fn multiplier_names(&self) -> Vec<String> {
        self.sim.multiplier_names()
    }

    /// One step of `dt`. Raises `StepError` if it fails (the state stays the last good one).
    fn step(&mut self) -> PyResult<()> {
        self.sim.step().map_err(|e| step_error(&e))
    }

    /// Steps until the time is `t` (steps of `dt`, then one shorter step that lands on `t`),
    /// stopping early at a `stop` event; returns the steps taken.
    fn advance_to(&mut self, t: f64) -> PyResult<usize> {
        if !t.is_finite() {
            return Err(PyValueError::new_err(format!("t must be finite, not {t}")));
        }
        let now = self.sim.time();
        // A time behind the current one is refused, as an FMU refuses it (to go back, restore
        // a checkpoint); the rounding of the step times is not "behind".
        if t < now - 8.0 * f64::EPSILON * (now.abs() + self.sim.dt()) {
            return Err(PyValueError::new_err(format!(
                "advance_to({t}) is behind the current time {now}: a run goes forward (restore a checkpoint to go back)"
            )));
        }
        self.sim.advance_to(t).map_err(|e| step_error(&e))
    }

    /// Sets the held input `name` to `value` from now on (zero-order hold).
    fn set_input(&mut self, name: &str, value: &Bound<'_, PyAny>) -> PyResult<()> {
        // A bool is an int to Python, and so a float to a plain conversion: `True` is refused
        // rather than read as 1.0.
        if value.is_instance_of::<pyo3::types::PyBool>() {
            return Err(PyValueError::new_err(format!(
                "input '{name}' = {value}: a number, not a bool"
            )));
        }
        let value: f64 = value.extract()?;
        self.sim
            .set_input(name, value)
            .map_err(PyValueError::new_err)
    }

    /// The value of input `name` at the current time; `ValueError` if there is no such input
    /// (as `set_input`).
    fn input(&self, name: &str) -> PyResult<f64> {
        self.sim.input(name).ok_or_else(|| {
            let names = self.sim.input_names();
            PyValueError::new_err(if names.is_empty() {
                format!("no input '{name}': the scene declares no inputs")
            } else {
                format!("no input '{name}' (inputs: {})", names.join(", "))
            })
        })
    }

    /// The declared outputs at the current state, by name.
    fn outputs<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let mut values = Vec::new();
        self.sim.outputs(&mut values);
        let out = PyDict::new(py);
        for (name, v) in self.sim.output_names().into_iter().zip(values) {
            out.set_item(name, v)?;
        }
        Ok(out)
    }

    /// The multipliers `(λ_k + λ_{k+1})/2` of the last step, one per constraint row (zeros
    /// before the first step; `None` when the scheme is not a projection).
    fn multipliers<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<f64>>> {
        self.sim.multipliers().map(|l| PyArray1::from_vec(py, l))
    }

    /// `(max |g|, max |φ|)` at the current state (`None` without constraints).
    fn residuals(&mut self) -> Option<(f64, f64)> {
        self.sim.residuals()
    }

    /// The events so far: `(name, t, step)` each.
    fn events(&self) -> Vec<(String, f64, usize)> {
        self.sim
            .events()
            .iter()
            .map(|e| (e.name.clone(), e.t, e.step))
            .collect()
    }

    /// Replaces the state (an impulse, a reset); with `reproject`, projects it onto `g = 0`,
    /// `φ = 0` first. Raises `ValueError` for a state of the wrong length or not finite.
    #[pyo3(signature = (x, reproject = false))]
    fn set_state<'py>(
        &mut self,
        py: Python<'py>,
        x: PyReadonlyArray1<'_, f64>,
        reproject: bool,
    ) -> PyResult<Option<Bound<'py, PyDict>>> {
        let x = x.as_slice()?;
        let report = self
            .sim
            .set_state(x, reproject)
            .map_err(PyValueError::new_err)?;
        report
            .map(|r| {
                let out = PyDict::new(py);
                out.set_item("moved", r.moved)?;
                out.set_item("g_before", r.g_before)?;
                out.set_item("g_after", r.g_after)?;
                out.set_item("phi_before", r.phi_before)?;
                out.set_item("phi_after", r.phi_after)?;
                out.set_item("iterations", r.iterations)?;
                Ok(out)
            })
            .transpose()
    }

    /// A checkpoint of everything the continuation depends on.
    fn save(&mut self) -> Checkpoint {
        Checkpoint(self.sim.save())
    }

    /// Restores a checkpoint of this simulation.
    fn restore(&mut self, checkpoint: &Checkpoint) -> PyResult<()> {
        self.sim
            .restore(&checkpoint.0)
            .map_err(PyValueError::new_err)
    }

    /// Runs the scene's steps to its `t_end` (as `lieflow run`: the planned diagnostics, a
    /// shorter last step when `dt` does not divide `t_end`) and returns the summary as a dict,
    /// the command's JSON fields, with the trajectory: `"times"` (rows,) and `"states"`
    /// (rows, len(state)) as numpy arrays holding the initial state, every `every`-th step and
    /// the last. A failed step ends the run; the summary's `"error"` says why (the arrays hold
    /// the run up to the last good state). With `accepted_steps` (a scene with a tolerance),
    /// the run takes the steps its controller chooses instead of stepping to every `dt`, and
    /// the rows are its accepted steps (`lieflow run --accepted-steps`); a scene of fixed steps
    /// raises `ValueError`.
    #[pyo3(signature = (every = 1, accepted_steps = false))]
    fn run<'py>(
        &mut self,
        py: Python<'py>,
        every: usize,
        accepted_steps: bool,
    ) -> PyResult<Bound<'py, PyDict>> {
        if accepted_steps && self.sim.adaptive_stats().is_none() {
            return Err(PyValueError::new_err(format!(
                "accepted_steps: the scheme takes fixed steps of dt = {}; give the scene a tolerance (`[integrator] tol`) to have its steps chosen",
                self.sim.dt()
            )));
        }
        let reports = self.plan.own_steps;
        self.plan.own_steps = accepted_steps;
        let dict = self.run_observed(py, every, &mut |_| {});
        self.plan.own_steps = reports;
        dict
    }

    /// Runs as `run()` does and writes the run's animation to `path`: one self-contained HTML
    /// page (three.js inlined, opens offline) that plays the motion, with the outputs plotted
    /// and the events on the time line; `frames` caps its frames (default 1000, fewer for large
    /// scenes: the page stays under 20 MB), `trace` names the bodies whose paths it draws. The
    /// summary's `"animation"` gives the page's path, frames and bytes.
    #[pyo3(signature = (path, every = 1, frames = None, trace = None))]
    fn animate<'py>(
        &mut self,
        py: Python<'py>,
        path: PathBuf,
        every: usize,
        frames: Option<usize>,
        trace: Option<Vec<String>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let mut recorder = crate::animate::recorder(
            self.sketch.as_ref(),
            self.sim.as_ref(),
            self.plan.t_end,
            frames,
            &trace.unwrap_or_default(),
        )?;
        let dict = self.run_observed(py, every, &mut |s| recorder.observe(s))?;
        let info = crate::animate::info(&self.assembly, self.sim.as_ref(), &dict)?;
        let page = crate::animate::write(py, &mut recorder, &path, &info)?;
        dict.set_item("animation", page)?;
        Ok(dict)
    }

    fn __repr__(&self) -> String {
        format!(
            "Simulation({:?}, t = {}, dt = {}, scheme = {:?}, order {})",
            self.assembly.name,
            self.sim.time(),
            self.sim.dt(),
            self.assembly.scheme,
            self.assembly.order
        )
    }
}

impl Simulation {
    /// `run(every)`, each sample also passed to `observe`.
    fn run_observed<'py>(
        &mut self,
        py: Python<'py>,
        every: usize,
        observe: &mut dyn FnMut(&lieflow::scene::Sample<'_>),
    ) -> PyResult<Bound<'py, PyDict>> {
        if every == 0 {
            return Err(PyValueError::new_err("every must be at least 1"));
        }
        let n = self.sim.state().len();
        let mut times = Vec::new();
        let mut states = Vec::new();
        let mut last = (usize::MAX, 0.0);
        let summary = lieflow::scene::run(self.sim.as_mut(), &self.plan, &mut |s| {
            observe(s);
            if s.step.is_multiple_of(every) {
                times.push(s.t);
                states.extend_from_slice(s.x);
                last = (s.step, s.t);
            }
        });
        // The last state, when it was not an `every`-th step.
        if summary.steps != last.0 || times.is_empty() {
            times.push(self.sim.time());
            states.extend_from_slice(self.sim.state());
        }
        let json = serde_json::to_string(&summary).expect("a summary serializes");
        let dict: Bound<'py, PyDict> = py
            .import("json")?
            .call_method1("loads", (json,))?
            .cast_into()?;
        dict.set_item("scene", &self.assembly.name)?;
        dict.set_item("scheme", &self.assembly.scheme)?;
        dict.set_item("order", self.assembly.order)?;
        let rows = times.len();
        dict.set_item("times", PyArray1::from_vec(py, times))?;
        dict.set_item("states", PyArray1::from_vec(py, states).reshape([rows, n])?)?;
        Ok(dict)
    }
}

/// Loads the scene file at `path` and runs it to its end (`Simulation.run`).
#[pyfunction]
#[pyo3(signature = (path, every = 1, accepted_steps = false))]
pub fn run<'py>(
    py: Python<'py>,
    path: PathBuf,
    every: usize,
    accepted_steps: bool,
) -> PyResult<Bound<'py, PyDict>> {
    Simulation::load(py, path)?.run(py, every, accepted_steps)
}

/// The text of the default scene (`lieflow scene`), a starting point for one's own.
#[pyfunction]
pub fn default_scene() -> &'static str {
    lieflow::scene::DEFAULT_SCENE
}
