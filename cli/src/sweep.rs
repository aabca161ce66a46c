//! `lieflow sweep`: a parameter sweep of a scene, members in parallel (or over MPI ranks), one
//! row per member in JSONL and CSV, an SVG; the last line of stdout is a JSON summary.

use crate::{bad_scene, distributed, sweep_plot};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Debug, clap::Args)]
pub(crate) struct SweepArgs {
    /// The sweep file.
    sweep: PathBuf,
    /// Write members.jsonl, members.csv, timing.csv and sweep.svg into this directory.
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    /// Threads (default: one per core); each member runs on one.
    #[arg(long, value_name = "N", default_value_t = 0)]
    threads: usize,
    /// Run only the members with these ids (`0..N` ranges or single ids, comma-separated): a
    /// slice of a larger sweep, e.g. one job of a batch array.
    #[arg(long, value_name = "A..B,…", value_delimiter = ',')]
    members: Vec<String>,
    #[command(flatten)]
    animate: crate::animate::AnimateArgs,
    /// The member whose run `--animate` shows (its id; default 0), run again after the sweep.
    #[arg(long, value_name = "ID", requires = "animate")]
    animate_member: Option<usize>,
}

/// Parses `--members` (`a..b` or `i`) against the sweep's size.
pub(crate) fn member_ids(specs: &[String], len: usize) -> Result<Vec<usize>, String> {
    if specs.is_empty() {
        return Ok((0..len).collect());
    }
    let mut ids = Vec::new();
    for s in specs {
        let (a, b) = match s.split_once("..") {
            Some((a, b)) => (a.trim().parse::<usize>(), b.trim().parse::<usize>()),
            None => (
                s.trim().parse::<usize>(),
                s.trim().parse::<usize>().map(|v| v + 1),
            ),
        };
        let (Ok(a), Ok(b)) = (a, b) else {
            return Err(format!("--members: '{s}' is not an id or a range a..b"));
        };
        if a >= b || b > len {
            return Err(format!(
                "--members: '{s}' is empty or beyond the sweep's {len} members"
            ));
        }
        ids.extend(a..b);
    }
    ids.sort_unstable();
    ids.dedup();
    Ok(ids)
}

pub(crate) fn sweep(args: &SweepArgs) -> ExitCode {
    use lieflow_lab::sweep::{OUTPUTS, Sweep, run_all_until, to_jsonl};
    let sweep = match Sweep::from_path(&args.sweep) {
        Ok(s) => s,
        Err(e) => return bad_scene(&e),
    };
    let ids = match member_ids(&args.members, sweep.len()) {
        Ok(ids) => ids,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    let animate_member = args.animate_member.unwrap_or(0);
    if args.animate.animate.is_some() {
        if animate_member >= sweep.len() {
            eprintln!(
                "error: --animate-member {animate_member}: the sweep has {} members (ids 0..{})",
                sweep.len(),
                sweep.len()
            );
            return ExitCode::from(2);
        }
        if let Err(e) = args.animate.check() {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    }
    // Under mpirun (feature `mpi`), rank r of n runs every n-th member; rank 0 gathers.
    let ranks = distributed::Ranks::init();
    let members: Vec<_> = ids
        .iter()
        .enumerate()
        .filter(|(k, _)| k % ranks.size == ranks.rank)
        .map(|(_, &i)| sweep.member(i))
        .collect();
    // Only rank 0 writes; every rank reaches the gather (a rank that left early would block it).
    if ranks.rank == 0
        && let Err(e) = std::fs::create_dir_all(&args.out)
    {
        eprintln!("error: cannot create {}: {e}", args.out.display());
        return ExitCode::from(2);
    }
    let bar = if ranks.size == 1 && std::io::IsTerminal::is_terminal(&std::io::stderr()) {
        let b = ProgressBar::new(members.len() as u64);
        b.set_style(
            ProgressStyle::with_template("{bar:40} {pos}/{len} members, {per_sec}, eta {eta}")
                .expect("valid template"),
        );
        Some(b)
    } else {
        None
    };
    let start = std::time::Instant::now();
    // The first Ctrl-C starts no further member; the members that ran are written and
    // summarized (exit 130).
    crate::interrupt::catch_interrupt();
    let interrupted = &crate::interrupt::INTERRUPTED;
    let planned = members.len();
    let rows = match run_all_until(
        &sweep,
        &members,
        args.threads,
        &|| {
            if let Some(b) = &bar {
                b.inc(1);
            }
        },
        interrupted,
    ) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(1);
        }
    };
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    let stopped = interrupted.load(std::sync::atomic::Ordering::SeqCst);
    if stopped {
        eprintln!(
            "interrupted: {} of {planned} members ran; writing them",
            rows.len()
        );
    }
    let rows = match ranks.gather(rows) {
        Ok(Some(rows)) => rows,
        Ok(None) => return ExitCode::SUCCESS, // not rank 0: its rows went there
        Err(e) => {
            eprintln!("error: gathering the rows: {e}");
            return ExitCode::from(1);
        }
    };
    let seconds = start.elapsed().as_secs_f64();
    let threads = if args.threads == 0 {
        std::thread::available_parallelism().map_or(1, |n| n.get())
    } else {
        args.threads
    };
    let member_rows: Vec<_> = rows.iter().map(|(r, _)| r.clone()).collect();
    let failed = member_rows.iter().filter(|r| r.error.is_some()).count();
    // Files: the deterministic rows (JSONL, CSV), the times apart.
    let mut csv = String::from("id");
    for p in &sweep.file.parameters {
        csv.push_str(&format!(",{}", p.path));
    }
    for o in OUTPUTS {
        csv.push_str(&format!(",{o}"));
    }
    csv.push_str(",error\n");
    for r in &member_rows {
        csv.push_str(&r.id.to_string());
        for (_, v) in &r.parameters {
            csv.push_str(&format!(",{v:?}"));
        }
        for o in OUTPUTS {
            csv.push_str(&r.output(o).map_or_else(String::new, |v| format!(",{v:?}")));
            if r.output(o).is_none() {
                csv.push(',');
            }
        }
        csv.push_str(&format!(
            ",{}\n",
            r.error.as_ref().map_or("", |e| e.0.as_str())
        ));
    }
    let timing: String = std::iter::once("id,seconds\n".to_owned())
        .chain(rows.iter().map(|(r, t)| format!("{},{t:e}\n", r.id)))
        .collect();
    let write = |name: &str, text: &str| {
        std::fs::write(args.out.join(name), text).map_err(|e| format!("writing {name}: {e}"))
    };
    if let Err(e) = write("members.jsonl", &to_jsonl(&member_rows))
        .and_then(|_| write("members.csv", &csv))
        .and_then(|_| write("timing.csv", &timing))
    {
        eprintln!("error: {e}");
        return ExitCode::from(1);
    }
    let mut plot = None;
    if let Some(p) = &sweep.file.plot {
        let path = args.out.join("sweep.svg");
        match sweep_plot::scatter(
            &path,
            &format!("{} against {}", p.y, p.x),
            &p.x,
            &p.y,
            &member_rows,
        ) {
            Ok(()) => plot = Some(path.display().to_string()),
            Err(e) => eprintln!("warning: plot not written: {e}"),
        }
    }
    // The table: each output's range over the members that report it.
    println!(
        "{} members ({} failed) on {} x {threads} threads in {seconds:.2} s: {:.1} members/s",
        member_rows.len(),
        failed,
        ranks.size,
        member_rows.len() as f64 / seconds
    );
    println!("{:<22} {:>13} {:>13}", "output", "min", "max");
    for o in OUTPUTS {
        let v: Vec<f64> = member_rows
            .iter()
            .filter_map(|r| r.output(o))
            .filter(|v| v.is_finite())
            .collect();
        if v.is_empty() {
            continue;
        }
        let (lo, hi) = v
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
                (a.min(x), b.max(x))
            });
        println!("{o:<22} {lo:>13.6e} {hi:>13.6e}");
    }
    for r in member_rows.iter().filter(|r| r.error.is_some()).take(5) {
        let (k, m) = r.error.as_ref().expect("filtered");
        println!("member {} failed ({k}): {m}", r.id);
    }
    let mut animation = None;
    let mut code = ExitCode::SUCCESS;
    if args.animate.animate.is_some() {
        let compiled = sweep
            .scene(&sweep.member(animate_member))
            .and_then(|scene| scene.compile())
            .map_err(|e| e.to_string());
        match compiled.and_then(|c| crate::animate::run_animated(c, &args.animate)) {
            Ok(a) => animation = Some(a),
            Err(e) => {
                eprintln!("error: --animate (member {animate_member}): {e}");
                code = ExitCode::from(1);
            }
        }
    }
    println!(
        "{}",
        serde_json::json!({
            "command": "sweep",
            "members": member_rows.len(),
            "failed": failed,
            "ranks": ranks.size,
            "threads": threads,
            "seconds": seconds,
            "members_per_second": member_rows.len() as f64 / seconds,
            "out": args.out.display().to_string(),
            "plot": plot,
            "interrupted": stopped,
            "animation": animation,
        })
    );
    if stopped {
        return ExitCode::from(crate::interrupt::EXIT_INTERRUPTED);
    }
    if failed > 0 && failed == member_rows.len() {
        // Every member failed: the rows say why, but nothing was swept.
        eprintln!("error: every member failed (the first failures are listed above)");
        return ExitCode::from(1);
    }
    code
}
