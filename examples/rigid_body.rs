//! The free rigid body as a Lie–Poisson system (`M(y) = ŷ`, state-dependent), integrated by the
//! implicit midpoint rule or its symmetric compositions. I = (2, 1, 2/3), y(0) = (cos 1.1, 0, sin 1.1)
//! (GNI §IV.1). Both the energy and the Casimir |y|² are quadratic, so both are conserved.
//!
//! ```text
//! cargo run --release --example rigid_body -- --scheme triple-jump --dt 0.1 --t-end 1000
//! ```

mod common;

use common::{Args, Json, fatal, scheme_table, time_steps};
use lieflow::flow::{CompositionTable, ImplicitMidpoint};
use lieflow::models::RigidBody;
use lieflow::nonlinear::NewtonOptions;
use lieflow::prelude::*;
use nalgebra::SVector;

type V = SVector<f64, 3>;

fn build(
    body: RigidBody<f64>,
    table: Option<&'static CompositionTable>,
    y0: &V,
) -> Result<Box<dyn Flow<V>>, SetupError> {
    let midpoint =
        ImplicitMidpoint::<V, _, _>::try_new(body.structure(), body, y0, NewtonOptions::default())?;
    Ok(match table {
        None => Box::new(midpoint),
        Some(t) => Box::new(midpoint.composed(t)),
    })
}

fn main() {
    let args = Args::parse(
        "Free rigid body (Lie-Poisson): implicit midpoint and its compositions.",
        &[
            (
                "scheme",
                "NAME",
                "midpoint (default), triple-jump, suzuki4, yoshida6, kahan-li6, suzuki-umeno8, kahan-li8",
            ),
            ("dt", "H", "step size (default 0.1)"),
            ("t-end", "T", "final time (default 1000)"),
        ],
    );
    let scheme = args.get("scheme", "midpoint".to_string());
    let table = scheme_table(&args, &scheme, "midpoint");
    let dt = args.positive("dt", 0.1);
    let t_end = args.positive("t-end", 1000.0);
    let steps = common::steps(&args, dt, t_end);

    let body = RigidBody::gni();
    let y0: V = RigidBody::gni_initial_state();
    let (c0, e0) = (RigidBody::casimir(&y0), body.energy(&y0));

    let mut flow = build(body, table, &y0).unwrap_or_else(|e| fatal(&e));
    let ns_per_step = time_steps(&mut *flow, &y0, dt, steps);

    let mut flow = build(body, table, &y0).unwrap_or_else(|e| fatal(&e));
    let mut y = y0;
    let (mut dc, mut de) = (0.0f64, 0.0f64);
    let report = integrate(
        &mut flow,
        &mut y,
        0.0,
        dt,
        steps,
        &mut |_k: usize, _t: f64, y: &V| {
            dc = dc.max((RigidBody::casimir(y) - c0).abs() / c0);
            de = de.max((body.energy(y) - e0).abs() / e0);
        },
    )
    .unwrap_or_else(|e| fatal(&e));

    let stats = report.stats;
    println!(
        "Free rigid body, scheme '{scheme}', order {}, h = {dt}, T = {}, I = {:?}",
        flow.order(),
        report.t,
        body.inertia
    );
    println!(
        "  final y          = [{:.12}, {:.12}, {:.12}]",
        y[0], y[1], y[2]
    );
    println!("  max |C - C0|/C0  = {dc:.3e}   (Casimir |y|^2)");
    println!("  max |H - H0|/H0  = {de:.3e}   (energy)");
    println!(
        "  Newton           = {} iterations, {:.2} residual evaluations per step",
        stats.newton_iterations,
        stats.residual_evaluations as f64 / steps as f64
    );
    println!("  time             = {ns_per_step:.0} ns/step");
    Json::default()
        .str("example", "rigid_body")
        .str("scheme", &scheme)
        .num("dt", dt)
        .num("t", report.t)
        .arr("x", y.as_slice())
        .int("steps", steps as u64)
        .num("max_abs_g", 0.0)
        .num("casimir_max_err", dc)
        .num("energy_max_err", de)
        .int("newton_iterations", stats.newton_iterations)
        .num("ns_per_step", ns_per_step)
        .print();
}
