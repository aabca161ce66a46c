//! `lieflow`: run, check, print, sweep and stress-test scene files (see `lieflow --help`).
//!
//! The command is thin, one file per subcommand: it parses flags, calls `lieflow::scene` (run,
//! check) or `lieflow_lab` (precision, stress, sweep), prints, writes CSV and plots.
//! Exit codes: 0 success, 1 a run that stopped early (what it computed is still written), 2 bad
//! input (flags or scene).

mod animate;
mod check;
mod csv_rows;
mod distributed;
mod fmu;
mod interrupt;
mod number;
mod plot;
mod plot_axes;
mod precision;
mod precision_plot;
mod progress;
mod run;
mod stress;
mod sweep;
mod sweep_plot;
mod zip;

use clap::{Parser, Subcommand};
use lieflow::scene::{DEFAULT_SCENE, Scene, SceneError};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// Simulate constrained generalized Hamiltonian systems with dissipation, described as scene
/// files (Zhang & Deng 2004 projection integrators).
#[derive(Debug, Parser)]
#[command(name = "lieflow", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Run a scene (the embedded default scene without an argument) and print a summary; the
    /// last line of stdout is a JSON summary.
    Run(run::RunArgs),
    /// Validate a scene and print what is assembled: bodies, constraints, effects, structure,
    /// the paper's case, the scheme and its order, the solver.
    Check {
        /// The scene file.
        scene: PathBuf,
        /// Print the assembly as one JSON line instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Print the default scene, a starting point for your own.
    Scene,
    /// Work–precision: run a scene with every scheme over a grid of step sizes, and the peer
    /// solvers (DOP853 on the index-1 ODE, Radau5 on the index-3 DAE) over tolerances; print a
    /// table, write a CSV and SVG figures; the last line of stdout is a JSON summary.
    Precision(precision::PrecisionArgs),
    /// The hard-case suite: public test problems (Fekete, Andrews' squeezer, the N-four-bar),
    /// stiff damping and springs, extreme lengths and mass ratios, a nearly singular chain,
    /// redundant constraints, hostile input (and with --long, 10^7-step runs); one row per case,
    /// a JSON line per case with --json, and a final JSON summary. Exit code 1 if a case fails
    /// its checks.
    Stress(stress::StressArgs),
    /// Run a parameter sweep of a scene (a sweep file: the base scene and the fields to vary),
    /// members in parallel; write one row per member (JSONL and CSV, in member order), their
    /// times, and an SVG of an output against a parameter; the last line of stdout is a JSON
    /// summary. A failing member is a row.
    Sweep(sweep::SweepArgs),
    /// Export a scene as an FMI 3.0 co-simulation FMU (its held inputs and declared outputs as
    /// variables, the scene's dt as the fixed internal step); the last line of stdout is a JSON
    /// summary.
    Fmu(fmu::FmuArgs),
}

fn main() -> ExitCode {
    interrupt::default_pipe();
    let cli = Cli::parse();
    match cli.command {
        Command::Scene => {
            print!("{DEFAULT_SCENE}");
            ExitCode::SUCCESS
        }
        Command::Check { scene, json } => check::check(&scene, json),
        Command::Run(args) => run::run_scene(&args),
        Command::Precision(args) => precision::precision(&args),
        Command::Stress(args) => stress::stress(&args),
        Command::Sweep(args) => sweep::sweep(&args),
        Command::Fmu(args) => fmu::fmu(&args),
    }
}

pub(crate) fn load(path: Option<&Path>) -> Result<Scene, SceneError> {
    match path {
        Some(p) => Scene::from_path(p),
        None => Ok(Scene::default_scene()),
    }
}

pub(crate) fn bad_scene(e: &SceneError) -> ExitCode {
    eprintln!("error: {e}");
    ExitCode::from(2)
}
