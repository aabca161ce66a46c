//! Stiff damping: a chain of `N` masses and springs with viscous friction `c` up to 1e6, stepped
//! at h = 0.1 by several schemes, to show which stay stable with monotone energy decay.
//!
//! - `strang-exact-damping`: Strang splitting of the exact damping flow `p ← e^{−ch} p` around
//!   Störmer–Verlet (kick–drift–kick) — positive weights only;
//! - `discrete-gradient`, `implicit-midpoint`: the general implicit flows of `M = J − R`;
//! - `exact`: the exact linear flow `e^{h(J−R)Q}` (also the reference);
//! - `triple-jump`: the triple jump of the Strang scheme — refused, since its negative sub-step
//!   would run the damping backwards (`e^{+1.7·10⁵}` at c = 1e6);
//! - `explicit-damping`: Strang with the damping by explicit Euler, `p ← (1 − ch) p` — what not
//!   to do: unstable once `ch > 2`.
//!
//! `--scheme all` (default) runs every scheme and prints a table. The JSON lists the schemes that
//! are `stable` (finite, energy never above 1.01 E0), `monotone` (stable and H never grew from one
//! step to the next), `refused` (typed error before stepping) and `unstable` (the rest).
//!
//! ```text
//! cargo run --release --example stiff_chain -- --damping 1e6 --dt 0.1
//! ```

mod common;

use common::{Args, Json, fatal};
use faer::Col;
use lieflow::flow::{DiscreteGradient, ImplicitMidpoint, from_fn_with_order};
use lieflow::models::SpringChain;
use lieflow::nonlinear::NewtonOptions;
use lieflow::prelude::*;

type V = Col<f64>;

const SCHEMES: [&str; 6] = [
    "strang-exact-damping",
    "discrete-gradient",
    "implicit-midpoint",
    "exact",
    "triple-jump",
    "explicit-damping",
];

fn build(model: &SpringChain<f64>, scheme: &str, x0: &V) -> Result<Box<dyn Flow<V>>, SetupError> {
    let verlet = || model.kick::<V>().strang(model.drift());
    Ok(match scheme {
        "strang-exact-damping" => Box::new(model.damping_flow().strang(verlet())),
        "triple-jump" => Box::new(model.damping_flow().strang(verlet()).triple_jump()),
        "explicit-damping" => {
            let (n, c) = (model.masses, model.damping);
            let euler = from_fn_with_order(
                move |h: f64, x: &mut V| {
                    for p in &mut x.as_mut_slice()[n..] {
                        *p *= 1.0 - c * h;
                    }
                },
                1,
                false,
            )
            .dissipative();
            Box::new(euler.strang(verlet()))
        }
        "discrete-gradient" => Box::new(DiscreteGradient::<V, _, _>::try_new(
            model.structure(),
            *model,
            x0,
            NewtonOptions::default(),
        )?),
        "implicit-midpoint" => Box::new(ImplicitMidpoint::<V, _, _>::try_new(
            model.structure(),
            *model,
            x0,
            NewtonOptions::default(),
        )?),
        "exact" => Box::new(model.exact_flow()?),
        _ => unreachable!("scheme names are checked in main"),
    })
}

struct Outcome {
    status: String,
    energy: f64,
    max_energy_ratio: f64,
    increases: u64,
    err_vs_exact: f64,
    x: V,
}

impl Outcome {
    /// Finished with a finite state whose energy never exceeded E0 by more than 1%.
    fn stable(&self) -> bool {
        self.status == "ok" && self.energy.is_finite() && self.max_energy_ratio <= 1.01
    }
    /// Stable, and H never grew from one step to the next.
    fn monotone(&self) -> bool {
        self.stable() && self.increases == 0
    }
}

fn run(model: &SpringChain<f64>, scheme: &str, x0: &V, dt: f64, steps: usize) -> Outcome {
    let mut flow = build(model, scheme, x0).unwrap_or_else(|e| fatal(&e));
    let mut exact = model.exact_flow().unwrap_or_else(|e| fatal(&e));
    let (mut x, mut xe) = (x0.clone(), x0.clone());
    let e0 = model.energy(x0);
    let mut out = Outcome {
        status: "ok".into(),
        energy: e0,
        max_energy_ratio: 1.0,
        increases: 0,
        err_vs_exact: 0.0,
        x: x0.clone(),
    };
    let mut stepper = Stepper::new(&mut flow, &mut x, 0.0, dt).unwrap_or_else(|e| fatal(&e));
    for k in 0..steps {
        // The stepper undoes a step that leaves the state non-finite (an explicit scheme past
        // its stability limit) and says so.
        if let Err(e) = stepper.step() {
            out.status = match e {
                StepError::BackwardDissipation { .. } => format!("refused at step {k}: {e}"),
                StepError::NonFinite { .. } => format!("blew up at step {k}: {e}"),
                _ => format!("failed at step {k}: {e}"),
            };
            break;
        }
        let x = stepper.state();
        exact.step(dt, &mut xe).unwrap_or_else(|e| fatal(&e));
        let e = model.energy(x);
        if !e.is_finite() {
            out.status = format!("blew up at step {k}: energy {e}");
            out.energy = e;
            out.max_energy_ratio = f64::INFINITY;
            break;
        }
        // An increase beyond the rounding error of evaluating H.
        if e - out.energy > 16.0 * f64::EPSILON * e0 {
            out.increases += 1;
        }
        out.energy = e;
        out.max_energy_ratio = out.max_energy_ratio.max(e / e0);
        out.err_vs_exact = out.err_vs_exact.max(
            (0..x.nrows())
                .map(|i| (x[i] - xe[i]).abs())
                .fold(0.0, f64::max),
        );
    }
    drop(stepper);
    out.x = x;
    out
}

fn main() {
    let args = Args::parse(
        "Stiff damped mass-spring chain: which schemes stay stable at h = 0.1 under damping up to 1e6.",
        &[
            (
                "scheme",
                "NAME",
                "all (default), strang-exact-damping, discrete-gradient, implicit-midpoint, exact, triple-jump, explicit-damping",
            ),
            ("damping", "C", "damping coefficient c >= 0 (default 1e6)"),
            ("masses", "N", "number of masses (default 10)"),
            ("stiffness", "K", "spring stiffness k > 0 (default 1)"),
            ("dt", "H", "step size (default 0.1)"),
            ("t-end", "T", "final time (default 10)"),
        ],
    );
    let scheme = args.get("scheme", "all".to_string());
    if scheme != "all" && !SCHEMES.contains(&scheme.as_str()) {
        args.fail(&format!("unknown scheme '{scheme}'"));
    }
    let masses: usize = args.get("masses", 10);
    let model = SpringChain::try_new(
        masses,
        args.positive("stiffness", 1.0),
        args.get("damping", 1e6),
    )
    .unwrap_or_else(|e| args.fail(&e.to_string()));
    let dt = args.positive("dt", 0.1);
    let t_end = args.positive("t-end", 10.0);
    let steps = common::steps(&args, dt, t_end);
    let x0: V = model.stretched(1.0);
    let e0 = model.energy(&x0);

    println!(
        "Stiff chain: N = {masses}, k = {}, c = {:e}, h = {dt}, T = {}, E0 = {e0:.6}",
        model.stiffness,
        model.damping,
        steps as f64 * dt
    );
    let names: Vec<&str> = if scheme == "all" {
        SCHEMES.to_vec()
    } else {
        vec![scheme.as_str()]
    };
    let mut outcomes = Vec::new();
    println!(
        "  {:<22} {:>12} {:>10} {:>10} {:>12}  status",
        "scheme", "E(T)/E0", "max E/E0", "increases", "err vs exact"
    );
    println!(
        "  (increases: steps where H grew; err vs exact: max-norm distance to the exact linear flow over all steps)"
    );
    for name in &names {
        let o = run(&model, name, &x0, dt, steps);
        println!(
            "  {:<22} {:>12.4e} {:>10.3e} {:>10} {:>12.3e}  {}",
            name,
            o.energy / e0,
            o.max_energy_ratio,
            o.increases,
            o.err_vs_exact,
            o.status
        );
        outcomes.push((*name, o));
    }
    let list = |f: &dyn Fn(&Outcome) -> bool| {
        outcomes
            .iter()
            .filter(|(_, o)| f(o))
            .map(|(n, _)| *n)
            .collect::<Vec<_>>()
            .join(",")
    };
    let json = Json::default()
        .str("example", "stiff_chain")
        .str("scheme", &scheme)
        .num("damping", model.damping)
        .int("masses", masses as u64)
        .num("dt", dt)
        .num("t", steps as f64 * dt)
        .int("steps", steps as u64)
        .str("stable", &list(&|o| o.stable()))
        .str("monotone", &list(&|o| o.monotone()))
        .str("refused", &list(&|o| o.status.starts_with("refused")))
        .str(
            "unstable",
            &list(&|o| !o.stable() && !o.status.starts_with("refused")),
        );
    let json = if let [(_, o)] = outcomes.as_slice() {
        json.arr("x", o.x.as_slice())
            .num("energy", o.energy)
            .int("energy_increase_steps", o.increases)
            .num("max_energy_ratio", o.max_energy_ratio)
            .num("err_vs_exact", o.err_vs_exact)
    } else {
        json
    };
    json.print();
}
