//! `lieflow check`: validate a scene and print what it assembles.

use crate::number::count;
use crate::{bad_scene, load};
use lieflow::scene::Assembly;
use std::path::Path;
use std::process::ExitCode;

/// Compiles the scene at `path` and prints its assembly (as one JSON line with `json`).
pub(crate) fn check(path: &Path, json: bool) -> ExitCode {
    match load(Some(path)).and_then(|s| s.compile()) {
        Ok(compiled) => {
            if json {
                println!(
                    "{}",
                    serde_json::to_string(&compiled.assembly).expect("serializable")
                );
            } else {
                print_assembly(&compiled.assembly);
            }
            ExitCode::SUCCESS
        }
        Err(e) => bad_scene(&e),
    }
}

/// `3 bodies` or `3 bodies (2 rigid)`.
pub(crate) fn bodies(a: &Assembly) -> String {
    let n = count(a.bodies, "body", "bodies");
    if a.rigid_bodies == 0 {
        n
    } else {
        format!("{n} ({} rigid)", a.rigid_bodies)
    }
}

pub(crate) fn print_assembly(a: &Assembly) {
    println!("scene        {}", a.name);
    if let Some(d) = a.dim {
        println!("space        {d}D, {}, state of {}", bodies(a), a.state_len);
    } else {
        println!("model        built-in, state of {}", a.state_len);
    }
    if a.constraints.is_empty() {
        println!("constraints  none");
    } else {
        let list: Vec<String> = a
            .constraints
            .iter()
            .map(|(k, n)| format!("{n} {k}"))
            .collect();
        println!(
            "constraints  {}: {}",
            count(a.constraint_rows, "row", "rows"),
            list.join(", ")
        );
    }
    for (i, (label, kind)) in a.effects.iter().enumerate() {
        let head = if i == 0 { "effects" } else { "" };
        println!("{head:<12} {label} ({kind})");
    }
    for d in &a.disabled {
        println!("switched off {d}");
    }
    for (i, (name, what)) in a.inputs.iter().enumerate() {
        let head = if i == 0 { "inputs" } else { "" };
        println!("{head:<12} {name} ({what})");
    }
    if !a.outputs.is_empty() {
        println!("outputs      {}", a.outputs.join(", "));
    }
    for (i, (name, action)) in a.events.iter().enumerate() {
        let head = if i == 0 { "events" } else { "" };
        println!("{head:<12} {name} ({action})");
    }
    println!(
        "structure    {}, {}",
        a.structure,
        if a.dissipative {
            "dissipative (M = J - R)"
        } else {
            "conservative"
        }
    );
    if let Some(case) = &a.case {
        println!("case         {case} (Zhang & Deng 2004)");
    }
    if let Some(p) = &a.projection {
        println!("projection   {p}");
    }
    println!("scheme       {}, order {}", a.scheme, a.order);
    println!("why          {}", a.reason);
    if let Some(s) = &a.solver {
        println!("solver       {s}");
    }
    println!("steps        {}", a.steps);
    if let Some((dq, dp)) = a.initial_projection {
        println!("projected    initial state moved by max |dq| = {dq:.3e}, max |dp| = {dp:.3e}");
    }
    if !a.dropped_constraints.is_empty() {
        println!(
            "dropped      redundant: {}",
            a.dropped_constraints.join(", ")
        );
    }
    for note in &a.notes {
        println!("note         {note}");
    }
}
