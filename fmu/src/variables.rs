//! The FMU's variables and their value references, derived from a compiled scene the same way
//! in the library (at instantiation) and in `lieflow fmu` (for `modelDescription.xml`).

use lieflow::scene::ports::{OutputSpec, Quantity};
use lieflow::scene::{Scene, SceneError, Simulation};

/// A scene of bodies that declares no `[[outputs]]` gets, in an FMU, the positions and
/// velocities of its bodies as outputs (`<body>.x`, `<body>.vx`, …): an FMU whose only output
/// were the time would show an importer nothing. Returns whether it added any (then the scene
/// is compiled again with them). `sim` is the scene compiled as it is.
pub fn default_outputs(scene: &mut Scene, sim: &dyn Simulation) -> bool {
    if !scene.file.outputs.is_empty() || scene.file.builtin.is_some() {
        return false;
    }
    // `q.<body>.<axis>`, in body order: the bodies (generated ones too) and their axes.
    let mut positions = Vec::new();
    for name in sim.state_names() {
        let Some(rest) = name.strip_prefix("q.") else {
            continue;
        };
        let Some((body, axis)) = rest.rsplit_once('.') else {
            continue;
        };
        // A rigid body's directors (`<body>#dᵢ`) are slots of its state, not bodies: its
        // centre's position and velocity are its outputs.
        if body.contains('#') {
            continue;
        }
        let Some(k) = ["x", "y", "z"].iter().position(|a| *a == axis) else {
            continue;
        };
        positions.push((body.to_owned(), k));
    }
    for quantity in [Quantity::Position, Quantity::Velocity] {
        for (body, k) in &positions {
            scene.file.outputs.push(OutputSpec {
                name: None,
                quantity,
                body: Some(body.clone()),
                component: Some(*k),
                input: None,
                constraint: None,
            });
        }
    }
    !positions.is_empty()
}

/// Value reference 0 is the time; the parameters follow from 1, then the inputs, then the
/// outputs.
#[derive(Debug, Clone, PartialEq)]
pub struct Variables {
    /// The scene's `[[parameters]]`: `(name, path, value in the scene)`.
    pub parameters: Vec<(String, String, f64)>,
    /// The held inputs (the ones an importer sets), in declaration order.
    pub inputs: Vec<String>,
    /// Their values at the start.
    pub input_starts: Vec<f64>,
    /// The declared outputs, in declaration order.
    pub outputs: Vec<String>,
}

/// The variables of `scene` compiled into `sim`: its parameters, its held inputs (an input whose
/// value can be set — a signal that is a function of time stays inside the scene) and its
/// outputs.
///
/// # Errors
/// A parameter whose path names no number of the scene.
pub fn variables(scene: &Scene, sim: &mut dyn Simulation) -> Result<Variables, SceneError> {
    let mut inputs = Vec::new();
    let mut input_starts = Vec::new();
    for name in sim.input_names() {
        let value = sim.input(&name).unwrap_or(0.0);
        // Setting the value it has changes nothing and tells a held input from a signal.
        if sim.set_input(&name, value).is_ok() {
            inputs.push(name);
            input_starts.push(value);
        }
    }
    Ok(Variables {
        parameters: scene.parameter_values()?,
        inputs,
        input_starts,
        outputs: sim.output_names(),
    })
}

impl Variables {
    /// The value reference of parameter `i`.
    pub fn parameter_vr(&self, i: usize) -> u32 {
        1 + i as u32
    }
    /// The value reference of input `i`.
    pub fn input_vr(&self, i: usize) -> u32 {
        1 + (self.parameters.len() + i) as u32
    }
    /// The value reference of output `i`.
    pub fn output_vr(&self, i: usize) -> u32 {
        1 + (self.parameters.len() + self.inputs.len() + i) as u32
    }
    /// The index of the parameter behind `vr`.
    pub fn parameter(&self, vr: u32) -> Option<usize> {
        let i = (vr as usize).checked_sub(1)?;
        (i < self.parameters.len()).then_some(i)
    }
    /// The input behind `vr`.
    pub fn input(&self, vr: u32) -> Option<&str> {
        let i = (vr as usize).checked_sub(1 + self.parameters.len())?;
        self.inputs.get(i).map(String::as_str)
    }
    /// The Float64 value of `vr`: the time, a parameter (`parameters`, as set), an input, or an
    /// output (`outputs` evaluated now).
    pub fn value(
        &self,
        vr: u32,
        sim: &dyn Simulation,
        parameters: &[f64],
        outputs: &[f64],
    ) -> Option<f64> {
        if vr == 0 {
            return Some(sim.time());
        }
        if let Some(i) = self.parameter(vr) {
            return parameters.get(i).copied();
        }
        if let Some(name) = self.input(vr) {
            return sim.input(name);
        }
        let i = (vr as usize).checked_sub(1 + self.parameters.len() + self.inputs.len())?;
        outputs.get(i).copied()
    }
}
