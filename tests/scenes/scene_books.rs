//! A run that reads no energy books: the flows skip the books' work (the damping's account on
//! the motion the constraints allow, the dashpots' account on the consistent momentum), the
//! motion is the same to the bit, and the simulation says it has no total rather than a wrong
//! one. A scene whose outputs read the books keeps them.

use crate::scene_ports::parse;
use lieflow::scene::{Simulation, advance_plan};

/// A double pendulum released from horizontal with ground damping on both bodies and a dashpot
/// between them (both accounts), at a fixed `dt` or under a tolerance; `outputs`: extra
/// `[[outputs]]` tables.
fn scene(integrator: &str, outputs: &str) -> String {
    format!(
        r#"
version = 1
dim = 2
[[bodies]]
name = "a"
mass = 1.0
position = [1.0, 1.0]
[[bodies]]
name = "b"
mass = 3.0
position = [1.0, 0.0]
[[constraints]]
type = "rod"
bodies = ["a"]
point = [0.0, 1.0]
[[constraints]]
type = "rod"
bodies = ["a", "b"]
[[effects]]
type = "gravity"
g = [0.0, -9.81]
[[effects]]
type = "damping"
coefficient = 0.5
[[effects]]
type = "dashpot"
bodies = ["a", "b"]
coefficient = 2.0
{outputs}
[integrator]
{integrator}
t_end = 2.0
"#
    )
}

/// The state and the dissipated total after the scene's plan, nothing observed; `read` passed
/// to `read_books` first (`None`: not called).
fn after(text: &str, read: Option<bool>) -> (Vec<f64>, Option<f64>) {
    let mut c = parse(text).compile().unwrap_or_else(|e| panic!("{e}"));
    if let Some(read) = read {
        c.simulation.read_books(read);
    }
    let done = advance_plan(c.simulation.as_mut(), &c.plan, &mut ());
    assert!(done.error.is_none(), "{:?}", done.error);
    let sim: &dyn Simulation = c.simulation.as_ref();
    (sim.state().to_vec(), sim.dissipated())
}

#[test]
fn a_run_that_reads_no_books_moves_the_same_and_reports_no_total() {
    for integrator in ["dt = 0.01", "tol = 1e-8\ndt = 0.5"] {
        let text = scene(integrator, "");
        let (x, booked) = after(&text, None);
        let booked = booked.expect("a damped splitting books its dissipation");
        assert!(booked > 0.1, "{integrator}: dissipated {booked}");
        // Read: the same books.
        assert_eq!(after(&text, Some(true)), (x.clone(), Some(booked)));
        // Not read: the same motion to the bit, and no total.
        let (y, none) = after(&text, Some(false));
        assert_eq!(
            y.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
            x.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
            "{integrator}"
        );
        assert_eq!(none, None, "{integrator}: a total with steps unbooked");
        // Read again after a run without: still no total (steps are missing from it).
        let mut c = parse(&text).compile().unwrap();
        c.simulation.read_books(false);
        c.simulation.step().unwrap();
        c.simulation.read_books(true);
        c.simulation.step().unwrap();
        assert_eq!(c.simulation.dissipated(), None, "{integrator}");
        // Nor in a checkpoint's continuation, in a freshly compiled simulation.
        let checkpoint = c.simulation.save();
        let mut fresh = parse(&text).compile().unwrap();
        fresh.simulation.restore(&checkpoint).unwrap();
        fresh.simulation.step().unwrap();
        assert_eq!(fresh.simulation.dissipated(), None, "{integrator}");
    }
}

#[test]
fn outputs_that_read_the_books_keep_them() {
    let text = scene("dt = 0.01", "[[outputs]]\nquantity = \"dissipated\"\n");
    let (x, booked) = after(&text, None);
    let kept = after(&text, Some(false));
    assert_eq!(kept, (x, booked));
    assert!(booked.is_some_and(|d| d > 0.1), "{booked:?}");
}
