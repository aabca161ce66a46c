//! The hard-case suite: every fast case of `lieflow_lab::stress` passes its
//! checks — stable with residuals at their rounding level and the energy behaving as theory
//! says, or a typed error where the case allows one. The long cases (10⁷ steps) run with
//! `cargo test --release --test stress -- --ignored` and `lieflow stress --long`.

use lieflow_lab::stress::{cases, run_case};

fn run(long: bool) {
    let mut failed = Vec::new();
    for case in cases().into_iter().filter(|c| c.long == long) {
        let row = run_case(&case);
        eprintln!("{row:?}");
        if !row.passed {
            failed.push(format!("{}: {} {:?}", row.case, row.outcome, row.checks));
        }
    }
    assert!(failed.is_empty(), "failed cases:\n{}", failed.join("\n"));
}

#[test]
fn the_fast_hard_cases_pass() {
    run(false);
}

#[test]
#[ignore = "10^7 steps each: run by `lieflow stress --long` and CI's long case"]
fn the_long_hard_cases_pass() {
    run(true);
}
