//! The damping's account on constrained bodies in a splitting: the flight's damping and the
//! dashpots book what their flows take from the motion the constraints allow, not from the
//! projection's impulse — nothing at rest, and a budget error that falls at the scheme's order
//! 2 in motion, also when the constraints join bodies of different damping rates.

use crate::scene_ports::parse;
use lieflow::scene::{RunSummary, run};

/// A double pendulum released from horizontal: body `a` on a rod to `(0, 1)`, `b` on a rod to
/// `a`; `effect` its damping (a `[[effects]]` table).
fn double_pendulum(mass_b: f64, effect: &str, dt: f64) -> RunSummary {
    let text = format!(
        r#"
version = 1
dim = 2
[[bodies]]
name = "a"
mass = 1.0
position = [1.0, 1.0]
[[bodies]]
name = "b"
mass = {mass_b}
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
{effect}
[integrator]
dt = {dt}
t_end = 10.0
"#
    );
    let mut c = parse(&text).compile().unwrap_or_else(|e| panic!("{e}"));
    let s = run(c.simulation.as_mut(), &c.plan, &mut |_| {});
    assert!(s.error.is_none(), "{:?}", s.error);
    s
}

#[test]
fn the_budget_of_damped_coupled_bodies_closes_at_order_two() {
    // Ground damping on bodies of masses 1 and 3 (rates c/m differ, so the rod between them
    // changes how the consistent motion decays), and a dashpot between two equal bodies. The
    // budget error H − H₀ + D is the splitting's O(h²) energy error plus the account's: it
    // must fall fourfold when h halves (an account of the consistent momentum alone fell as
    // h: 0.175, 0.057, 0.021 here).
    for (mass_b, effect) in [
        (3.0, "[[effects]]\ntype = \"damping\"\ncoefficient = 0.5"),
        (
            1.0,
            "[[effects]]\ntype = \"dashpot\"\nbodies = [\"a\", \"b\"]\ncoefficient = 5.0",
        ),
    ] {
        let errors: Vec<f64> = [0.01, 0.005, 0.0025]
            .iter()
            .map(|&dt| {
                let s = double_pendulum(mass_b, effect, dt);
                let d = s.dissipated.unwrap();
                // Released from rest at H₀, the pendulum dissipates most of what it can.
                assert!(d > 10.0, "{effect}: dissipated {d}");
                s.max_energy_balance_error.unwrap()
            })
            .collect();
        let orders: Vec<f64> = errors.windows(2).map(|e| (e[0] / e[1]).log2()).collect();
        eprintln!("{effect:?}: budget errors {errors:?}, orders {orders:?}");
        for p in orders {
            assert!((p - 2.0).abs() < 0.25, "{effect}: order {p}");
        }
    }
}

#[test]
fn a_dashpot_to_a_body_held_at_rest_books_almost_nothing() {
    // Body b held at rest on a rod against a spring (the rod's tension balances it), body a free
    // and at rest, a dashpot between them: nothing moves, so nothing is dissipated. The
    // projection's impulse on b crossed the dashpot inside every step, and its energy was booked:
    // 0.62 over 100 s at h = 0.01 (0.16 at 0.005, as h²). What is left is the cross term of the
    // impulse with the momentum the dashpot hands to a within the step, O(h³) over the run.
    let text = |dt: f64| {
        format!(
            r#"
version = 1
dim = 2
[[bodies]]
name = "a"
mass = 1.0
position = [0.0, 5.0]
[[bodies]]
name = "b"
mass = 1.0
position = [1.0, 0.0]
[[constraints]]
type = "rod"
bodies = ["b"]
point = [0.0, 0.0]
[[effects]]
type = "spring"
bodies = ["b"]
point = [3.0, 0.0]
stiffness = 10.0
rest_length = 1.0
[[effects]]
type = "dashpot"
bodies = ["a", "b"]
coefficient = 5.0
[integrator]
dt = {dt}
t_end = 100.0
"#
        )
    };
    let booked: Vec<f64> = [0.01, 0.005]
        .iter()
        .map(|&dt| {
            let mut c = parse(&text(dt)).compile().unwrap();
            let s = run(c.simulation.as_mut(), &c.plan, &mut |_| {});
            assert!(s.error.is_none(), "{:?}", s.error);
            // H stays at its initial value to the splitting's error of a state at rest.
            assert!(s.max_abs_energy_error.unwrap() < 1e-6);
            s.dissipated.unwrap()
        })
        .collect();
    let order = (booked[0] / booked[1]).log2();
    eprintln!("dashpot at rest: booked {booked:?}, order {order:.2}");
    assert!(booked[0] < 0.02 * 0.62, "{booked:?}");
    assert!(order > 2.7, "{order}");
}

#[test]
fn a_chain_of_dashpots_runs_at_its_order() {
    // Dashpots between neighbouring links: their exact flows, pair after pair, couple every
    // link's momentum within a step, so the projection's multiplier systems couple every rod
    // (they were declared with the rods' own neighbours only, and the first step failed with
    // "a non-zero outside the declared sparsity pattern"). Twelve links: the sparse path.
    let mut text = String::from(
        "version = 1\ndim = 2\n[[chains]]\nname = \"c\"\nlinks = 12\nanchor = [0.0, 0.0]\n\
         direction = [1.0, -1.0]\nlength = 0.1\nmass = 0.1\n\
         [[effects]]\ntype = \"gravity\"\ng = [0.0, -9.81]\n",
    );
    for i in 0..11 {
        text += &format!(
            "[[effects]]\ntype = \"dashpot\"\nbodies = [\"c.{i}\", \"c.{}\"]\ncoefficient = 0.05\n",
            i + 1
        );
    }
    let with = |scheme: &str, dt: f64| {
        let text = format!("{text}[integrator]\ndt = {dt}\nt_end = 0.5\n{scheme}\n");
        let mut c = parse(&text).compile().unwrap_or_else(|e| panic!("{e}"));
        let s = run(c.simulation.as_mut(), &c.plan, &mut |_| {});
        assert!(s.error.is_none(), "{scheme}: {:?}", s.error);
        assert!(s.max_abs_g.unwrap() < 1e-14, "{scheme}");
        s
    };
    let reference = with("scheme = \"petrov-galerkin\"\norder = 6", 1e-3);
    for (scheme, order) in [("", 2.0), ("scheme = \"discrete-gradient\"", 2.0)] {
        let errs: Vec<f64> = [2e-3, 1e-3]
            .iter()
            .map(|&dt| {
                let s = with(scheme, dt);
                s.x.iter()
                    .zip(&reference.x)
                    .map(|(a, b)| (a - b).abs())
                    .fold(0.0, f64::max)
            })
            .collect();
        let p = (errs[0] / errs[1]).log2();
        eprintln!("dashpot chain {scheme:?}: errors {errs:?}, order {p:.2}");
        assert!((p - order).abs() < 0.3, "{scheme}: {p}");
    }
}
