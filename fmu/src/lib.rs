//! The FMI 3.0 co-simulation API over a compiled scene: the shared library inside the FMUs
//! `lieflow fmu` exports (modelIdentifier `lieflow_fmu`).
//!
//! An instance reads `resources/scene.toml` from the FMU's resource path and compiles it. Value
//! references: 0 is the time, then the scene's `[[parameters]]` (set before initialization
//! ends: the scene is recompiled with them), then its held inputs in declaration order, then its
//! declared outputs ([`variables`], the same list `lieflow fmu` writes into
//! `modelDescription.xml`). `fmi3DoStep` advances the scene to the communication point exactly
//! (`Simulation::advance_to`: steps of the scene's `dt`, the fixed internal step, and a shorter
//! last one when the communication step is not a multiple of it; under a tolerance each of those
//! is the controller's own steps, and the model description declares no fixed internal step),
//! with the inputs held over the communication step. FMU states are the simulation's checkpoints.
//!
//! Only the functions a co-simulation master calls are exported; Model Exchange and Scheduled
//! Execution instantiation return null (the model description declares co-simulation only).

// The FMI C API passes raw pointers from the importer; every exported function checks for null
// and lengths before touching them.
#![allow(clippy::missing_safety_doc)]

mod variables;

use lieflow::scene::{Scene, Simulation, SimulationCheckpoint};
use std::ffi::{CStr, CString, c_char, c_void};
use std::path::PathBuf;
pub use variables::{Variables, default_outputs, variables};

/// `fmi3Status`.
pub type Status = i32;
const OK: Status = 0;
const DISCARD: Status = 2;
const ERROR: Status = 3;

/// `fmi3LogMessageCallback`.
pub type LogMessage = Option<
    unsafe extern "C" fn(
        env: *mut c_void,
        status: Status,
        category: *const c_char,
        message: *const c_char,
    ),
>;

/// One FMU instance: the scene, its compiled simulation and what the importer gave it.
pub struct Instance {
    scene: Scene,
    sim: Box<dyn Simulation>,
    /// The parameters' values as set (the scene's until the importer sets them).
    parameters: Vec<f64>,
    /// A parameter was set: the scene is recompiled when initialization ends.
    rebuild: bool,
    /// Initialization mode ended: parameters are fixed.
    initialized: bool,
    initial: SimulationCheckpoint,
    vars: Variables,
    outputs: Vec<f64>,
    env: *mut c_void,
    log: LogMessage,
}

impl Instance {
    /// Reports `message` with `status` through the importer's logger, if it gave one.
    fn log(&self, status: Status, message: &str) {
        if let Some(log) = self.log {
            let text = CString::new(message.replace('\0', " ")).unwrap_or_default();
            // SAFETY: the importer's callback with its own environment and valid C strings.
            unsafe { log(self.env, status, c"lieflow".as_ptr(), text.as_ptr()) };
        }
    }
}

/// The instance behind `instance`, or `None` for null.
unsafe fn instance<'a>(instance: *mut Instance) -> Option<&'a mut Instance> {
    // SAFETY: a non-null instance is one this library returned and the importer has not freed.
    unsafe { instance.as_mut() }
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3GetVersion() -> *const c_char {
    c"3.0".as_ptr()
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3SetDebugLogging(
    _instance: *mut Instance,
    _logging_on: bool,
    _n_categories: usize,
    _categories: *const *const c_char,
) -> Status {
    OK
}

/// Reads and compiles `resources/scene.toml` under `resource_path`.
fn compile(resource_path: &str) -> Result<(Scene, Box<dyn Simulation>), String> {
    let path = PathBuf::from(resource_path).join("scene.toml");
    let mut scene = Scene::from_path(&path).map_err(|e| e.to_string())?;
    let mut sim = scene.compile().map_err(|e| e.to_string())?.simulation;
    if default_outputs(&mut scene, sim.as_ref()) {
        sim = scene.compile().map_err(|e| e.to_string())?.simulation;
    }
    Ok((scene, sim))
}

impl Instance {
    /// Recompiles the scene with the parameters as set, keeping the inputs' values.
    fn apply_parameters(&mut self) -> Result<(), String> {
        let mut scene = self.scene.clone();
        for ((_, path, _), &v) in self.vars.parameters.iter().zip(&self.parameters) {
            scene = scene.with_value(path, v).map_err(|e| e.to_string())?;
        }
        let mut sim = scene.compile().map_err(|e| e.to_string())?.simulation;
        if default_outputs(&mut scene, sim.as_ref()) {
            sim = scene.compile().map_err(|e| e.to_string())?.simulation;
        }
        for name in &self.vars.inputs {
            if let Some(v) = self.sim.input(name) {
                sim.set_input(name, v)?;
            }
        }
        self.sim = sim;
        self.initial = self.sim.save();
        Ok(())
    }
}

#[unsafe(no_mangle)]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn fmi3InstantiateCoSimulation(
    _instance_name: *const c_char,
    _instantiation_token: *const c_char,
    resource_path: *const c_char,
    _visible: bool,
    _logging_on: bool,
    _event_mode_used: bool,
    _early_return_allowed: bool,
    _required_intermediate_variables: *const u32,
    _n_required_intermediate_variables: usize,
    instance_environment: *mut c_void,
    log_message: LogMessage,
    _intermediate_update: *const c_void,
) -> *mut Instance {
    let say = |message: &str| {
        if let Some(log) = log_message {
            let text = CString::new(message.replace('\0', " ")).unwrap_or_default();
            // SAFETY: the importer's callback with its own environment and valid C strings.
            unsafe {
                log(
                    instance_environment,
                    ERROR,
                    c"lieflow".as_ptr(),
                    text.as_ptr(),
                )
            };
        }
    };
    if resource_path.is_null() {
        say("no resource path: the scene is resources/scene.toml");
        return std::ptr::null_mut();
    }
    // SAFETY: a non-null C string from the importer.
    let path = unsafe { CStr::from_ptr(resource_path) }
        .to_string_lossy()
        .into_owned();
    let (scene, mut sim) = match compile(&path) {
        Ok(s) => s,
        Err(e) => {
            say(&format!("the scene does not compile: {e}"));
            return std::ptr::null_mut();
        }
    };
    let vars = match variables(&scene, sim.as_mut()) {
        Ok(v) => v,
        Err(e) => {
            say(&format!("the scene's parameters: {e}"));
            return std::ptr::null_mut();
        }
    };
    let initial = sim.save();
    Box::into_raw(Box::new(Instance {
        parameters: vars.parameters.iter().map(|p| p.2).collect(),
        rebuild: false,
        initialized: false,
        scene,
        sim,
        initial,
        vars,
        outputs: Vec::new(),
        env: instance_environment,
        log: log_message,
    }))
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3InstantiateModelExchange() -> *mut Instance {
    std::ptr::null_mut()
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3InstantiateScheduledExecution() -> *mut Instance {
    std::ptr::null_mut()
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi3FreeInstance(instance: *mut Instance) {
    if !instance.is_null() {
        // SAFETY: an instance this library returned, freed once by the importer.
        drop(unsafe { Box::from_raw(instance) });
    }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi3EnterInitializationMode(
    instance: *mut Instance,
    _tolerance_defined: bool,
    _tolerance: f64,
    start_time: f64,
    _stop_time_defined: bool,
    _stop_time: f64,
) -> Status {
    // SAFETY: see `instance`.
    let Some(inst) = (unsafe { self::instance(instance) }) else {
        return ERROR;
    };
    if start_time != inst.sim.time() {
        inst.log(
            ERROR,
            &format!(
                "the scene starts at t = {}, not {start_time}",
                inst.sim.time()
            ),
        );
        return ERROR;
    }
    OK
}

/// The modes without work here: the scene is ready after instantiation.
macro_rules! nothing_to_do {
    ($($name:ident),+) => {$(
        #[unsafe(no_mangle)]
        pub extern "C" fn $name(instance: *mut Instance) -> Status {
            if instance.is_null() { ERROR } else { OK }
        }
    )+};
}
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi3ExitInitializationMode(instance: *mut Instance) -> Status {
    // SAFETY: see `instance`.
    let Some(inst) = (unsafe { self::instance(instance) }) else {
        return ERROR;
    };
    inst.initialized = true;
    if std::mem::take(&mut inst.rebuild)
        && let Err(e) = inst.apply_parameters()
    {
        inst.log(ERROR, &format!("the scene with the parameters set: {e}"));
        return ERROR;
    }
    OK
}

nothing_to_do!(
    fmi3EnterEventMode,
    fmi3EnterStepMode,
    fmi3EnterConfigurationMode,
    fmi3ExitConfigurationMode,
    fmi3Terminate
);

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi3Reset(instance: *mut Instance) -> Status {
    // SAFETY: see `instance`.
    let Some(inst) = (unsafe { self::instance(instance) }) else {
        return ERROR;
    };
    inst.initialized = false;
    match inst.sim.restore(&inst.initial) {
        Ok(()) => OK,
        Err(e) => {
            inst.log(ERROR, &e);
            ERROR
        }
    }
}

/// The importer's value references as a slice, after checking the call: as many values as
/// references, neither array null unless both are empty (a null pointer is no slice, even of
/// length zero). `None` for a call that breaks that.
unsafe fn references<'a>(
    value_references: *const u32,
    n_value_references: usize,
    values_null: bool,
    n_values: usize,
) -> Option<&'a [u32]> {
    if n_values != n_value_references {
        return None;
    }
    if n_values == 0 {
        return Some(&[]);
    }
    if value_references.is_null() || values_null {
        return None;
    }
    // SAFETY: a non-null array of `n_value_references` references from the importer.
    Some(unsafe { std::slice::from_raw_parts(value_references, n_value_references) })
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi3GetFloat64(
    instance: *mut Instance,
    value_references: *const u32,
    n_value_references: usize,
    values: *mut f64,
    n_values: usize,
) -> Status {
    // SAFETY: see `instance`.
    let Some(inst) = (unsafe { self::instance(instance) }) else {
        return ERROR;
    };
    // SAFETY: the importer's arrays of the lengths it gave.
    let Some(vrs) = (unsafe {
        references(
            value_references,
            n_value_references,
            values.is_null(),
            n_values,
        )
    }) else {
        return ERROR;
    };
    inst.sim.outputs(&mut inst.outputs);
    for (k, vr) in vrs.iter().enumerate() {
        match inst
            .vars
            .value(*vr, inst.sim.as_ref(), &inst.parameters, &inst.outputs)
        {
            // SAFETY: `values` holds `n_values = vrs.len()` numbers (checked by `references`).
            Some(v) => unsafe { *values.add(k) = v },
            None => {
                inst.log(
                    ERROR,
                    &format!("no Float64 variable with value reference {vr}"),
                );
                return ERROR;
            }
        }
    }
    OK
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi3SetFloat64(
    instance: *mut Instance,
    value_references: *const u32,
    n_value_references: usize,
    values: *const f64,
    n_values: usize,
) -> Status {
    // SAFETY: see `instance`.
    let Some(inst) = (unsafe { self::instance(instance) }) else {
        return ERROR;
    };
    // SAFETY: the importer's arrays of the lengths it gave.
    let Some(vrs) = (unsafe {
        references(
            value_references,
            n_value_references,
            values.is_null(),
            n_values,
        )
    }) else {
        return ERROR;
    };
    for (k, vr) in vrs.iter().enumerate() {
        // SAFETY: `values` holds `n_values = vrs.len()` numbers (checked by `references`).
        let v = unsafe { *values.add(k) };
        if let Some(i) = inst.vars.parameter(*vr) {
            if inst.initialized {
                inst.log(
                    ERROR,
                    &format!(
                        "parameter '{}' is fixed after initialization",
                        inst.vars.parameters[i].0
                    ),
                );
                return ERROR;
            }
            if inst.parameters[i] != v {
                inst.parameters[i] = v;
                inst.rebuild = true;
            }
            continue;
        }
        let Some(name) = inst.vars.input(*vr) else {
            inst.log(ERROR, &format!("value reference {vr} is not an input"));
            return ERROR;
        };
        if let Err(e) = inst.sim.set_input(name, v) {
            inst.log(ERROR, &e);
            return ERROR;
        }
    }
    OK
}

#[unsafe(no_mangle)]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn fmi3DoStep(
    instance: *mut Instance,
    current_communication_point: f64,
    communication_step_size: f64,
    _no_set_fmu_state_prior_to_current_point: bool,
    event_handling_needed: *mut bool,
    terminate_simulation: *mut bool,
    early_return: *mut bool,
    last_successful_time: *mut f64,
) -> Status {
    // SAFETY: see `instance`.
    let Some(inst) = (unsafe { self::instance(instance) }) else {
        return ERROR;
    };
    let set = |p: *mut bool, v: bool| {
        if !p.is_null() {
            // SAFETY: the importer's output argument.
            unsafe { *p = v };
        }
    };
    set(event_handling_needed, false);
    set(early_return, false);
    set(terminate_simulation, false);
    let t = inst.sim.time();
    // A step that is not finite or not positive is an importer's error (a NaN one stepped
    // forever); one that takes more steps than the scene's whole run is refused as the scene
    // file's `t_end` is (the importer splits it).
    if !communication_step_size.is_finite() || communication_step_size <= 0.0 {
        inst.log(
            ERROR,
            &format!(
                "communication step size {communication_step_size}: a step is finite and positive"
            ),
        );
        return ERROR;
    }
    let steps = communication_step_size / inst.sim.dt();
    let budget = (inst.scene.file.integrator.t_end / inst.sim.dt())
        .ceil()
        .max(1.0);
    if steps > budget {
        inst.log(
            ERROR,
            &format!(
                "communication step size {communication_step_size} takes {steps:.3e} steps of dt = {}, more than the scene's whole run (t_end = {}, {budget:.3e} steps): split it",
                inst.sim.dt(),
                inst.scene.file.integrator.t_end
            ),
        );
        return ERROR;
    }
    let slack = 8.0 * f64::EPSILON * (t.abs() + communication_step_size.abs());
    if (current_communication_point - t).abs() > slack.max(1e-12 * t.abs()) {
        inst.log(ERROR, &format!("the FMU is at t = {t}, not at the communication point {current_communication_point}"));
        return ERROR;
    }
    let status = match inst
        .sim
        .advance_to(current_communication_point + communication_step_size)
    {
        Ok(_) => OK,
        Err(e) => {
            inst.log(
                ERROR,
                &format!("step failed at t = {}: {e}", inst.sim.time()),
            );
            ERROR
        }
    };
    if inst.sim.stopped().is_some() {
        set(terminate_simulation, true);
    }
    if !last_successful_time.is_null() {
        // SAFETY: the importer's output argument.
        unsafe { *last_successful_time = inst.sim.time() };
    }
    if status == OK && inst.sim.stopped().is_some() {
        DISCARD
    } else {
        status
    }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi3GetFMUState(
    instance: *mut Instance,
    state: *mut *mut c_void,
) -> Status {
    // SAFETY: see `instance`.
    let Some(inst) = (unsafe { self::instance(instance) }) else {
        return ERROR;
    };
    if state.is_null() {
        return ERROR;
    }
    // SAFETY: the importer's slot: a state it passed back is freed here and replaced.
    unsafe {
        if !(*state).is_null() {
            drop(Box::from_raw((*state).cast::<SimulationCheckpoint>()));
        }
        *state = Box::into_raw(Box::new(inst.sim.save())).cast();
    }
    OK
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi3SetFMUState(instance: *mut Instance, state: *mut c_void) -> Status {
    // SAFETY: see `instance`.
    let Some(inst) = (unsafe { self::instance(instance) }) else {
        return ERROR;
    };
    if state.is_null() {
        return ERROR;
    }
    // SAFETY: a state `fmi3GetFMUState` made and the importer has not freed.
    let checkpoint = unsafe { &*state.cast::<SimulationCheckpoint>() };
    match inst.sim.restore(checkpoint) {
        Ok(()) => OK,
        Err(e) => {
            inst.log(ERROR, &e);
            ERROR
        }
    }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi3FreeFMUState(
    _instance: *mut Instance,
    state: *mut *mut c_void,
) -> Status {
    if !state.is_null() {
        // SAFETY: the importer's slot holding a state `fmi3GetFMUState` made, freed once.
        unsafe {
            if !(*state).is_null() {
                drop(Box::from_raw((*state).cast::<SimulationCheckpoint>()));
                *state = std::ptr::null_mut();
            }
        }
    }
    OK
}

/// The rest of the FMI 3.0 API, which a co-simulation FMU of Float64 variables without clocks,
/// continuous-state access or serialized states does not support: each returns `fmi3Error`.
/// Importers bind the whole API by name, so every function must exist.
macro_rules! unsupported {
    ($($name:ident),+ $(,)?) => {$(
        #[unsafe(no_mangle)]
        pub extern "C" fn $name() -> Status {
            ERROR
        }
    )+};
}
unsupported!(
    fmi3ActivateModelPartition,
    fmi3CompletedIntegratorStep,
    fmi3DeserializeFMUState,
    fmi3EnterContinuousTimeMode,
    fmi3EvaluateDiscreteStates,
    fmi3GetAdjointDerivative,
    fmi3GetBinary,
    fmi3GetBoolean,
    fmi3GetClock,
    fmi3GetContinuousStateDerivatives,
    fmi3GetContinuousStates,
    fmi3GetDirectionalDerivative,
    fmi3GetEventIndicators,
    fmi3GetFloat32,
    fmi3GetInt16,
    fmi3GetInt32,
    fmi3GetInt64,
    fmi3GetInt8,
    fmi3GetIntervalDecimal,
    fmi3GetIntervalFraction,
    fmi3GetNominalsOfContinuousStates,
    fmi3GetNumberOfContinuousStates,
    fmi3GetNumberOfEventIndicators,
    fmi3GetNumberOfVariableDependencies,
    fmi3GetOutputDerivatives,
    fmi3GetShiftDecimal,
    fmi3GetShiftFraction,
    fmi3GetString,
    fmi3GetUInt16,
    fmi3GetUInt32,
    fmi3GetUInt64,
    fmi3GetUInt8,
    fmi3GetVariableDependencies,
    fmi3SerializeFMUState,
    fmi3SerializedFMUStateSize,
    fmi3SetBinary,
    fmi3SetBoolean,
    fmi3SetClock,
    fmi3SetContinuousStates,
    fmi3SetFloat32,
    fmi3SetInt16,
    fmi3SetInt32,
    fmi3SetInt64,
    fmi3SetInt8,
    fmi3SetIntervalDecimal,
    fmi3SetIntervalFraction,
    fmi3SetShiftDecimal,
    fmi3SetShiftFraction,
    fmi3SetString,
    fmi3SetTime,
    fmi3SetUInt16,
    fmi3SetUInt32,
    fmi3SetUInt64,
    fmi3SetUInt8,
    fmi3UpdateDiscreteStates,
);
