//! `lieflow stress`: the hard-case suite, one row per case and a final JSON summary.

use std::process::ExitCode;

#[derive(Debug, clap::Args)]
pub(crate) struct StressArgs {
    /// Also run the long cases (10^7 steps each).
    #[arg(long)]
    long: bool,
    /// Run only the cases whose name contains this (repeatable).
    #[arg(long, value_name = "NAME")]
    case: Vec<String>,
    /// List the cases and exit.
    #[arg(long)]
    list: bool,
    /// Print every row as a JSON line (with its checks) instead of the table.
    #[arg(long)]
    json: bool,
}

pub(crate) fn stress(args: &StressArgs) -> ExitCode {
    use lieflow_lab::stress::{cases, run_case};
    let selected: Vec<_> = cases()
        .into_iter()
        .filter(|c| args.long || !c.long)
        .filter(|c| args.case.is_empty() || args.case.iter().any(|n| c.name.contains(n.as_str())))
        .collect();
    if selected.is_empty() {
        eprintln!(
            "error: no case matches {:?} (see lieflow stress --list)",
            args.case
        );
        return ExitCode::from(2);
    }
    if args.list {
        for c in &selected {
            let long = if c.long { " (long)" } else { "" };
            println!(
                "{:<24} {}{long}\n{:<24} source: {}",
                c.name, c.about, "", c.source
            );
        }
        return ExitCode::SUCCESS;
    }
    let sci = |v: Option<f64>| v.map_or_else(|| "-".to_owned(), |v| format!("{v:.1e}"));
    if !args.json {
        println!(
            "{:<24} {:>9} {:>8} {:>8} {:>6} {:>8} {:>7}  {:<5} outcome / energy",
            "case", "steps", "max|g|", "max|phi|", "newton", "cond", "time s", "pass"
        );
    }
    let (mut passed, mut failed) = (0, Vec::new());
    let start = std::time::Instant::now();
    for case in &selected {
        let row = run_case(case);
        if row.passed {
            passed += 1;
        } else {
            failed.push(row.case.clone());
        }
        if args.json {
            println!("{}", serde_json::to_string(&row).expect("serializable"));
            continue;
        }
        println!(
            "{:<24} {:>9} {:>8} {:>8} {:>6} {:>8} {:>7.2}  {:<5} {}",
            row.case,
            row.steps,
            sci(row.max_g),
            sci(row.max_phi),
            row.newton_max,
            sci(row.condition),
            row.seconds,
            if row.passed { "yes" } else { "NO" },
            row.outcome
        );
        println!("{:<24} scheme: {}", "", row.scheme);
        if row.energy != "-" {
            println!("{:<24} energy: {}", "", row.energy);
        }
        for c in &row.checks {
            println!(
                "{:<24} {} {:.3e} <= {:.3e}{}",
                "",
                c.what,
                c.value,
                c.bound,
                if c.passed { "" } else { "  FAILED" }
            );
        }
    }
    println!(
        "{}",
        serde_json::json!({
            "command": "stress",
            "cases": selected.len(),
            "passed": passed,
            "failed": failed,
            "long": args.long,
            "seconds": start.elapsed().as_secs_f64(),
        })
    );
    if failed.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    }
}
