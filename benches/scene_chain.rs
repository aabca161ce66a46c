//! What a step of each implicit scheme costs per link of a damped hanging chain (1 g, 1 mm
//! links, damping 0.01, h = 10⁻⁴, released at 30°), from 300 to 10⁴ links, against the
//! projected Strang splitting of the same scene in the same process; nothing observed.
//!
//! Two families separate the chain's length from its stiffness:
//! - **one tension**: gravity scaled by `1000/N`, so that every fraction of the chain carries
//!   the tension of the same fraction of the 1000-link chain, and its top links' transverse
//!   waves the same `ωh` (`ω² = 2T/(mℓ)`); the work of a step should then be linear in `N`;
//! - **full gravity** (`g = 9.81`): the top tension grows as `N`, the top links' `ωh` as
//!   `√N` (0.14, 0.44, 0.77, 1.4 at 100, 1000, 3000, 10⁴ links): a stiffer problem, on which
//!   the iterations of a step may grow.
//!
//! Each configuration runs 100 steps (`lieflow::scene::run`, its `ns_per_step` timing the
//! steps alone), best of 3; the table gives ns per link and step, the iterations a step, and
//! the ratio to Strang's step on the same chain.
//!
//! ```text
//! cargo bench --bench scene_chain
//! ```

#[path = "../tests/common/scene_text.rs"]
mod scene_text;

use lieflow::scene::{Scene, run};
use scene_text::damped_chain;

const SCHEMES: [(&str, &str); 4] = [
    ("strang", "scheme = \"strang\""),
    ("midpoint", "scheme = \"midpoint\""),
    ("discrete-gradient", "scheme = \"discrete-gradient\""),
    (
        "petrov-galerkin 4",
        "scheme = \"petrov-galerkin\"\norder = 4",
    ),
];

/// The fastest of `repeats` runs: ns per step and Newton iterations per step.
fn measure(scene: &Scene, repeats: usize) -> (f64, f64) {
    let mut best = (f64::INFINITY, 0.0);
    for _ in 0..repeats {
        let mut c = scene.compile().unwrap_or_else(|e| panic!("{e}"));
        let s = run(c.simulation.as_mut(), &c.plan, &mut |_| {});
        assert_eq!(s.error, None, "the run completes");
        let iterations = s.newton_iterations as f64 / s.steps as f64;
        if s.ns_per_step < best.0 {
            best = (s.ns_per_step, iterations);
        }
    }
    best
}

fn main() {
    // `cargo test --benches` runs benches once as tests: one small configuration then.
    let quick = std::env::args().any(|a| a == "--test" || a == "--list");
    let lengths: &[usize] = if quick {
        &[30]
    } else {
        &[300, 1000, 3000, 10_000]
    };
    let repeats = if quick { 1 } else { 3 };
    for (family, tension) in [
        ("one tension (g = 9.81·1000/N)", true),
        ("full gravity (g = 9.81)", false),
    ] {
        println!("\n{family}: ns per link and step (iterations a step), ratio to Strang");
        println!(
            "{:>7} | {:>16} | {:>22} | {:>22} | {:>22}",
            "links", SCHEMES[0].0, SCHEMES[1].0, SCHEMES[2].0, SCHEMES[3].0
        );
        for &n in lengths {
            let g = if tension {
                9.81 * 1000.0 / n as f64
            } else {
                9.81
            };
            let mut row = format!("{n:>7}");
            let mut strang = 0.0;
            for (i, (_, spec)) in SCHEMES.iter().enumerate() {
                let (ns, it) = measure(&damped_chain(n, g, spec, 100), repeats);
                let per_link = ns / n as f64;
                if i == 0 {
                    strang = ns;
                    row += &format!(" | {per_link:>9.0} ({it:>4.1})");
                } else {
                    row += &format!(" | {per_link:>7.0} ({it:>4.1}) {:>5.1}×", ns / strang);
                }
            }
            println!("{row}");
        }
    }
}
