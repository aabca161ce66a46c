//! One member's run and its row; all members on a thread pool, rows in id order; JSONL.

use super::{Member, Sweep};
use lieflow::scene::run;
use serde::Serialize;
use std::sync::atomic::{AtomicBool, Ordering};

/// The result of one member: its parameters and its run's summary, or why it failed.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MemberRow {
    /// The member id.
    pub id: usize,
    /// `path → value`, in the file's order.
    pub parameters: Vec<(String, f64)>,
    /// Final time reached.
    pub t: f64,
    /// Steps taken.
    pub steps: usize,
    /// `max |g|` over the run.
    pub max_abs_g: Option<f64>,
    /// `H` at the start and at the end.
    pub energy_initial: Option<f64>,
    /// See `energy_initial`.
    pub energy_final: Option<f64>,
    /// `max |H − H₀|`.
    pub max_abs_energy_error: Option<f64>,
    /// Energy dissipated (with damping).
    pub dissipated: Option<f64>,
    /// `max |x|` of the final state.
    pub final_state_max_abs: f64,
    /// The error kind (`Setup` for a scene the parameters made invalid, else the step
    /// error's kind) and message, if the member failed; its row then holds what it reached.
    pub error: Option<(String, String)>,
}

impl MemberRow {
    /// The named output ([`OUTPUTS`]).
    pub fn output(&self, name: &str) -> Option<f64> {
        match name {
            "t" => Some(self.t),
            "steps" => Some(self.steps as f64),
            "max_abs_g" => self.max_abs_g,
            "energy_initial" => self.energy_initial,
            "energy_final" => self.energy_final,
            "max_abs_energy_error" => self.max_abs_energy_error,
            "dissipated" => self.dissipated,
            "final_state_max_abs" => Some(self.final_state_max_abs),
            _ => None,
        }
    }
    /// The value of parameter `path`.
    pub fn parameter(&self, path: &str) -> Option<f64> {
        self.parameters
            .iter()
            .find(|(p, _)| p == path)
            .map(|&(_, v)| v)
    }
}

/// Runs one member (single-threaded): its scene compiled and run to the end, no observer.
pub fn run_member(sweep: &Sweep, m: &Member) -> MemberRow {
    let mut row = MemberRow {
        id: m.id,
        parameters: m.parameters.clone(),
        t: 0.0,
        steps: 0,
        max_abs_g: None,
        energy_initial: None,
        energy_final: None,
        max_abs_energy_error: None,
        dissipated: None,
        final_state_max_abs: f64::NAN,
        error: None,
    };
    let compiled = sweep.scene(m).and_then(|s| s.compile());
    let mut c = match compiled {
        Ok(c) => c,
        Err(e) => {
            row.error = Some(("Setup".into(), e.to_string()));
            return row;
        }
    };
    // The row's `dissipated` comes from the energy diagnostic, the books' only reader here.
    c.simulation.read_books(c.plan.energy);
    let s = run(c.simulation.as_mut(), &c.plan, &mut |_| {});
    row.t = s.t;
    row.steps = s.steps;
    row.max_abs_g = s.max_abs_g;
    row.energy_initial = s.energy_initial;
    row.energy_final = s.energy_final;
    row.max_abs_energy_error = s.max_abs_energy_error;
    row.dissipated = s.dissipated;
    row.final_state_max_abs = s.x.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    row.error = s.error.map(|f| (f.kind, f.message));
    row
}

/// Runs `members` on a pool of `threads` threads (0: rayon's default, one per core), calling
/// `progress` after each member, and returns the rows in id order with each member's wall time
/// in seconds beside it. Rows do not depend on `threads`.
pub fn run_all(
    sweep: &Sweep,
    members: &[Member],
    threads: usize,
    progress: &(dyn Fn() + Sync),
) -> Result<Vec<(MemberRow, f64)>, String> {
    run_all_until(sweep, members, threads, progress, &AtomicBool::new(false))
}

/// [`run_all`] that starts no member once `stop` is raised (by a Ctrl-C handler, say): the rows
/// of the members that ran, by id. Members in progress complete.
pub fn run_all_until(
    sweep: &Sweep,
    members: &[Member],
    threads: usize,
    progress: &(dyn Fn() + Sync),
    stop: &AtomicBool,
) -> Result<Vec<(MemberRow, f64)>, String> {
    use rayon::prelude::*;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| format!("cannot start {threads} threads: {e}"))?;
    let mut rows: Vec<(MemberRow, f64)> = pool.install(|| {
        members
            .par_iter()
            .filter_map(|m| {
                if stop.load(Ordering::Relaxed) {
                    return None;
                }
                let start = std::time::Instant::now();
                let row = run_member(sweep, m);
                progress();
                Some((row, start.elapsed().as_secs_f64()))
            })
            .collect()
    });
    rows.sort_by_key(|(r, _)| r.id);
    Ok(rows)
}

/// One JSON line per row (the deterministic part: no times), in the given order.
pub fn to_jsonl(rows: &[MemberRow]) -> String {
    let mut out = String::new();
    for r in rows {
        out.push_str(&serde_json_line(r));
        out.push('\n');
    }
    out
}

fn serde_json_line(r: &MemberRow) -> String {
    // A small writer (serde_json is the command's dependency, not the library's): numbers in
    // Rust's shortest round-trip form, so equal rows give equal bytes.
    fn num(v: f64) -> String {
        if v.is_finite() {
            format!("{v:?}")
        } else {
            "null".into()
        }
    }
    fn opt(v: Option<f64>) -> String {
        v.map_or_else(|| "null".into(), num)
    }
    fn text(s: &str) -> String {
        let mut o = String::from('"');
        for c in s.chars() {
            match c {
                '"' => o.push_str("\\\""),
                '\\' => o.push_str("\\\\"),
                '\n' => o.push_str("\\n"),
                c if (c as u32) < 0x20 => o.push_str(&format!("\\u{:04x}", c as u32)),
                c => o.push(c),
            }
        }
        o.push('"');
        o
    }
    let params: Vec<String> = r
        .parameters
        .iter()
        .map(|(p, v)| format!("{}:{}", text(p), num(*v)))
        .collect();
    let error = match &r.error {
        None => "null".into(),
        Some((k, m)) => format!("{{\"kind\":{},\"message\":{}}}", text(k), text(m)),
    };
    format!(
        "{{\"id\":{},\"parameters\":{{{}}},\"t\":{},\"steps\":{},\"max_abs_g\":{},\"energy_initial\":{},\"energy_final\":{},\"max_abs_energy_error\":{},\"dissipated\":{},\"final_state_max_abs\":{},\"error\":{}}}",
        r.id,
        params.join(","),
        num(r.t),
        r.steps,
        opt(r.max_abs_g),
        opt(r.energy_initial),
        opt(r.energy_final),
        opt(r.max_abs_energy_error),
        opt(r.dissipated),
        num(r.final_state_max_abs),
        error
    )
}
