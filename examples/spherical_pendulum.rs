//! A spherical pendulum in Cartesian coordinates: a unit mass on a rod under gravity, the rod
//! length as a holonomic constraint, canonical structure. The scheme is the projected Strang
//! splitting kick–drift–kick, i.e. RATTLE, or one of its symmetric compositions.
//!
//! ```text
//! cargo run --release --example spherical_pendulum -- --scheme triple-jump --dt 0.01 --t-end 100
//! ```

mod common;

use common::{Args, Json, fatal, scheme_table, time_steps};
use lieflow::flow::CompositionTable;
use lieflow::models::SphericalPendulum;
use lieflow::prelude::*;
use nalgebra::SVector;

type V = SVector<f64, 6>;

fn build(
    model: &SphericalPendulum<f64>,
    table: Option<&'static CompositionTable>,
    x0: &V,
) -> Result<Box<dyn Flow<V>>, SetupError> {
    let rattle = model.kick().strang(model.drift()).projected(
        model.system(),
        x0,
        ProjectionOptions::default(),
    )?;
    Ok(match table {
        None => Box::new(rattle),
        Some(t) => Box::new(rattle.composed(t)),
    })
}

fn main() {
    let args = Args::parse(
        "Spherical pendulum (Cartesian, constrained): RATTLE as a projected kick-drift-kick.",
        &[
            (
                "scheme",
                "NAME",
                "rattle (default), triple-jump, suzuki4, yoshida6, kahan-li6, suzuki-umeno8, kahan-li8",
            ),
            ("dt", "H", "step size (default 0.01)"),
            ("t-end", "T", "final time (default 100)"),
            (
                "theta0",
                "RAD",
                "initial angle from the downward vertical (default 1.0)",
            ),
            ("speed", "V", "initial horizontal speed (default 1.0)"),
            ("mass", "M", "mass (default 1)"),
            ("length", "L", "rod length (default 1)"),
            ("gravity", "G", "gravitational acceleration (default 9.81)"),
        ],
    );
    let scheme = args.get("scheme", "rattle".to_string());
    let table = scheme_table(&args, &scheme, "rattle");
    let dt = args.positive("dt", 0.01);
    let t_end = args.positive("t-end", 100.0);
    let theta0: f64 = args.get("theta0", 1.0);
    let speed: f64 = args.get("speed", 1.0);
    let model = SphericalPendulum::try_new(
        args.positive("mass", 1.0),
        args.positive("length", 1.0),
        args.get("gravity", 9.81),
    )
    .unwrap_or_else(|e| args.fail(&e.to_string()));
    if !(theta0.is_finite() && speed.is_finite()) {
        args.fail("--theta0 and --speed must be finite");
    }
    let steps = common::steps(&args, dt, t_end);

    let x0: V = model.state(theta0, speed);
    let e0 = model.energy(&x0);
    let l0 = model.vertical_angular_momentum(&x0);
    let sys = model.system();

    let mut flow = build(&model, table, &x0).unwrap_or_else(|e| fatal(&e));
    let ns_per_step = time_steps(&mut *flow, &x0, dt, steps);

    let mut flow = build(&model, table, &x0).unwrap_or_else(|e| fatal(&e));
    let mut x = x0;
    let (mut max_g, mut max_phi, mut max_de, mut max_dl) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    let report = integrate(
        &mut flow,
        &mut x,
        0.0,
        dt,
        steps,
        &mut |_k: usize, _t: f64, x: &V| {
            let (mut g, mut p) = ([0.0], [0.0]);
            sys.constraint.residual(x, &mut g);
            // φ = q·p/m: the velocity is tangent to the sphere.
            p[0] = (x[0] * x[3] + x[1] * x[4] + x[2] * x[5]) / model.mass;
            max_g = max_g.max(g[0].abs());
            max_phi = max_phi.max(p[0].abs());
            max_de = max_de.max((model.energy(x) - e0).abs());
            max_dl = max_dl.max((model.vertical_angular_momentum(x) - l0).abs());
        },
    )
    .unwrap_or_else(|e| fatal(&e));

    let stats = report.stats;
    println!(
        "Spherical pendulum, scheme '{scheme}', order {}, h = {dt}, T = {}, m = {}, L = {}, g = {}",
        flow.order(),
        report.t,
        model.mass,
        model.length,
        model.gravity
    );
    println!(
        "  final q          = [{:.9}, {:.9}, {:.9}]",
        x[0], x[1], x[2]
    );
    println!("  max |g|          = {max_g:.3e}   (|q|^2 - L^2)/2");
    println!("  max |phi|        = {max_phi:.3e}   (q.p/m)");
    println!("  max |E - E0|     = {max_de:.3e}   (E0 = {e0:.6})");
    println!("  max |Lz - Lz0|   = {max_dl:.3e}   (vertical angular momentum)");
    println!(
        "  Newton           = {} iterations, {:.2} residual evaluations per step",
        stats.newton_iterations,
        stats.residual_evaluations as f64 / steps as f64
    );
    println!("  time             = {ns_per_step:.0} ns/step");
    Json::default()
        .str("example", "spherical_pendulum")
        .str("scheme", &scheme)
        .num("dt", dt)
        .num("t", report.t)
        .arr("x", x.as_slice())
        .int("steps", steps as u64)
        .num("max_abs_g", max_g)
        .num("max_abs_phi", max_phi)
        .num("energy_max_err", max_de)
        .num("angular_momentum_max_err", max_dl)
        .int("newton_iterations", stats.newton_iterations)
        .num("ns_per_step", ns_per_step)
        .print();
}
