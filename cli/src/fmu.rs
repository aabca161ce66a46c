//! `lieflow fmu`: exports a scene as an FMI 3.0 co-simulation FMU — `modelDescription.xml` with
//! the scene's held inputs and declared outputs, the library `lieflow_fmu` (built by
//! `cargo build --release -p lieflow-fmu`, found next to this executable) as
//! `binaries/<platform>/`, and the scene itself as `resources/scene.toml`.

use crate::zip::write_zip;
use crate::{bad_scene, load};
use lieflow_fmu::{Variables, default_outputs, variables};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Debug, clap::Args)]
pub(crate) struct FmuArgs {
    /// The scene file.
    scene: PathBuf,
    /// The FMU to write (`NAME.fmu`).
    #[arg(short, long, value_name = "NAME.fmu")]
    output: PathBuf,
}

/// The FMI platform tuple and shared-library file name of this build.
fn platform() -> Option<(&'static str, &'static str, &'static str)> {
    match (std::env::consts::ARCH, std::env::consts::OS) {
        ("x86_64", "linux") => Some(("x86_64-linux", "liblieflow_fmu.so", ".so")),
        ("aarch64", "linux") => Some(("aarch64-linux", "liblieflow_fmu.so", ".so")),
        ("x86_64", "macos") => Some(("x86_64-darwin", "liblieflow_fmu.dylib", ".dylib")),
        ("aarch64", "macos") => Some(("aarch64-darwin", "liblieflow_fmu.dylib", ".dylib")),
        ("x86_64", "windows") => Some(("x86_64-windows", "lieflow_fmu.dll", ".dll")),
        _ => None,
    }
}

/// Escapes `s` for an XML attribute.
fn attr(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('"', "&quot;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// `modelDescription.xml` of a scene named `name` with step (or, under a tolerance, report
/// interval) `dt` to `t_end`; `fixed`: whether `dt` is the internal step (a scene without a
/// tolerance) — under a tolerance the steps inside a communication step are the controller's.
pub(crate) fn model_description(
    name: &str,
    token: &str,
    (dt, fixed): (f64, bool),
    t_end: f64,
    vars: &Variables,
) -> String {
    let mut x = String::new();
    x += "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n";
    x += &format!(
        "<fmiModelDescription fmiVersion=\"3.0\" modelName=\"{}\" instantiationToken=\"{token}\" description=\"a lieflow scene: projection integrators for constrained Hamiltonian systems\" generationTool=\"lieflow {}\">\n",
        attr(name),
        env!("CARGO_PKG_VERSION")
    );
    let internal = if fixed {
        format!(" fixedInternalStepSize=\"{dt:?}\"")
    } else {
        String::new()
    };
    x += &format!(
        "  <CoSimulation modelIdentifier=\"lieflow_fmu\" canHandleVariableCommunicationStepSize=\"true\"{internal} canGetAndSetFMUState=\"true\" hasEventMode=\"false\"/>\n"
    );
    x += &format!(
        "  <DefaultExperiment startTime=\"0\" stopTime=\"{t_end:?}\" stepSize=\"{dt:?}\"/>\n"
    );
    x += "  <ModelVariables>\n";
    x += "    <Float64 name=\"time\" valueReference=\"0\" causality=\"independent\" variability=\"continuous\" description=\"simulation time\"/>\n";
    for (i, (name, path, start)) in vars.parameters.iter().enumerate() {
        x += &format!(
            "    <Float64 name=\"{}\" valueReference=\"{}\" causality=\"parameter\" variability=\"fixed\" start=\"{start:?}\" description=\"the scene's {}\"/>\n",
            attr(name),
            vars.parameter_vr(i),
            attr(path)
        );
    }
    for (i, (input, start)) in vars.inputs.iter().zip(&vars.input_starts).enumerate() {
        x += &format!(
            "    <Float64 name=\"{}\" valueReference=\"{}\" causality=\"input\" variability=\"continuous\" start=\"{start:?}\" description=\"held input (zero-order hold over a communication step)\"/>\n",
            attr(input),
            vars.input_vr(i)
        );
    }
    for (i, output) in vars.outputs.iter().enumerate() {
        x += &format!(
            "    <Float64 name=\"{}\" valueReference=\"{}\" causality=\"output\" variability=\"continuous\" initial=\"calculated\"/>\n",
            attr(output),
            vars.output_vr(i)
        );
    }
    x += "  </ModelVariables>\n  <ModelStructure>\n";
    for i in 0..vars.outputs.len() {
        x += &format!("    <Output valueReference=\"{}\"/>\n", vars.output_vr(i));
    }
    for i in 0..vars.outputs.len() {
        x += &format!(
            "    <InitialUnknown valueReference=\"{}\"/>\n",
            vars.output_vr(i)
        );
    }
    x += "  </ModelStructure>\n</fmiModelDescription>\n";
    x
}

/// A token that changes with the scene's text (FNV-1a 64, as a GUID-shaped string).
fn token(text: &str) -> String {
    let h = text.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    });
    let g = h ^ h.rotate_left(29);
    format!(
        "{{{:08x}-{:04x}-{:04x}-{:04x}-{:012x}}}",
        (h >> 32) as u32,
        (h >> 16) as u16,
        h as u16,
        (g >> 48) as u16,
        g & 0xffff_ffff_ffff
    )
}

/// The table files `scene`'s inputs read, as `(resources/<file>, contents)`: each a relative
/// path inside the scene's directory (an FMU carries its files with it).
fn referenced_files(scene: &lieflow::scene::Scene) -> Result<Vec<(String, Vec<u8>)>, String> {
    use lieflow::scene::ports::SignalSpec;
    let mut out: Vec<(String, Vec<u8>)> = Vec::new();
    for (i, input) in scene.file.inputs.iter().enumerate() {
        let SignalSpec::Table {
            file: Some(file), ..
        } = input.signal()
        else {
            continue;
        };
        let path = std::path::Path::new(file.as_str());
        let inside = path.is_relative()
            && path
                .components()
                .all(|c| matches!(c, std::path::Component::Normal(_)));
        if !inside {
            return Err(format!(
                "inputs[{i}].signal.file = '{file}': an FMU packs the files its scene reads, so a table file is a relative path inside the scene's directory"
            ));
        }
        let at = format!("resources/{}", path.display());
        if out.iter().any(|(a, _)| *a == at) {
            continue;
        }
        let on_disk = scene
            .file
            .base_dir
            .as_deref()
            .map_or(path.to_path_buf(), |d| d.join(path));
        let bytes = lieflow::scene::read_scene_file(&on_disk)
            .map_err(|e| format!("inputs[{i}].signal.file: {e}"))?;
        out.push((at, bytes.into_bytes()));
    }
    Ok(out)
}

pub(crate) fn fmu(args: &FmuArgs) -> ExitCode {
    let mut scene = match load(Some(&args.scene)) {
        Ok(s) => s,
        Err(e) => return bad_scene(&e),
    };
    let mut compiled = match scene.compile() {
        Ok(c) => c,
        Err(e) => return bad_scene(&e),
    };
    // The same outputs the FMU will compile at instantiation.
    if default_outputs(&mut scene, compiled.simulation.as_ref()) {
        compiled = match scene.compile() {
            Ok(c) => c,
            Err(e) => return bad_scene(&e),
        };
    }
    if args.output.extension().is_none_or(|e| e != "fmu") {
        eprintln!(
            "error: -o {}: an FMU's file name ends in .fmu",
            args.output.display()
        );
        return ExitCode::from(2);
    }
    let Some((tuple, library, ext)) = platform() else {
        eprintln!(
            "error: no FMI platform tuple for this build's {} {}",
            std::env::consts::ARCH,
            std::env::consts::OS
        );
        return ExitCode::from(2);
    };
    let lib_path = std::env::current_exe()
        .ok()
        .and_then(|e| e.parent().map(|d| d.join(library)))
        .filter(|p| p.exists());
    let Some(lib_path) = lib_path else {
        eprintln!(
            "error: the FMU library {library} is not next to this executable: build it with `cargo build --release -p lieflow-fmu`"
        );
        return ExitCode::from(2);
    };
    let text = match lieflow::scene::read_scene_file(&args.scene) {
        Ok(t) => t,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    let vars = match variables(&scene, compiled.simulation.as_mut()) {
        Ok(v) => v,
        Err(e) => return bad_scene(&e),
    };
    let integ = &scene.file.integrator;
    let (dt, t_end) = (integ.step(), integ.t_end);
    let fixed = !integ.has_tolerance();
    let name = compiled.assembly.name.clone();
    let xml = model_description(&name, &token(&text), (dt, fixed), t_end, &vars);
    let binary = match std::fs::read(&lib_path) {
        Ok(b) => b,
        Err(e) => {
            eprintln!("error: cannot read {}: {e}", lib_path.display());
            return ExitCode::from(1);
        }
    };
    let binary_path = format!("binaries/{tuple}/lieflow_fmu{ext}");
    // The files the scene refers to (a table signal's `file`), packed beside it under
    // `resources/` at their relative paths: the FMU reads its scene from there.
    let tables = match referenced_files(&scene) {
        Ok(t) => t,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    let mut entries: Vec<(&str, &[u8])> = vec![
        ("modelDescription.xml", xml.as_bytes()),
        (&binary_path, &binary),
        ("resources/scene.toml", text.as_bytes()),
    ];
    for (at, bytes) in &tables {
        entries.push((at, bytes));
    }
    let written = std::fs::File::create(&args.output).and_then(|f| {
        let mut w = std::io::BufWriter::new(f);
        write_zip(&mut w, &entries)?;
        std::io::Write::flush(&mut w)
    });
    if let Err(e) = written {
        eprintln!("error: writing {}: {e}", args.output.display());
        return ExitCode::from(1);
    }
    println!(
        "{name}: FMI 3.0 co-simulation FMU {} (parameters: {}; inputs: {}; outputs: {}; fixed internal step {dt})",
        args.output.display(),
        if vars.parameters.is_empty() {
            "none".to_owned()
        } else {
            vars.parameters
                .iter()
                .map(|p| p.0.clone())
                .collect::<Vec<_>>()
                .join(", ")
        },
        if vars.inputs.is_empty() {
            "none".to_owned()
        } else {
            vars.inputs.join(", ")
        },
        if vars.outputs.is_empty() {
            "none".to_owned()
        } else {
            vars.outputs.join(", ")
        },
    );
    println!(
        "{}",
        serde_json::json!({
            "command": "fmu",
            "fmu": args.output.display().to_string(),
            "scene": name,
            "fmi_version": "3.0",
            "parameters": vars.parameters.iter().map(|p| &p.0).collect::<Vec<_>>(),
            "inputs": vars.inputs,
            "outputs": vars.outputs,
            "fixed_internal_step": dt,
            "platform": tuple,
        })
    );
    ExitCode::SUCCESS
}
