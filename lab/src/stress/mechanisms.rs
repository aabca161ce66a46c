//! Rust models run as cases: Andrews' squeezing mechanism (the IVP test set) and the IFToMM
//! benchmark problems N-four-bar (A02) and Bricard (A04).

use super::{Check, Row, refused_row};

pub(super) fn andrews() -> Row {
    use lieflow::models::andrews::{REFERENCE, run};
    let name = "andrews";
    let (coarse, fine) = match (run(3000), run(6000)) {
        (Ok(a), Ok(b)) => (a, b),
        (Err(e), _) | (_, Err(e)) => return refused_row(name, e, false),
    };
    // Relative to each component's scale (angles to 16 rad, velocities to 1.4e3 rad/s);
    // Richardson for order 2: x_{h/2} − x ≈ (x_{h/2} − x_h)/3.
    let (mut err, mut est) = (0.0f64, 0.0f64);
    for ((r, f), c) in REFERENCE.iter().zip(&fine.end).zip(&coarse.end) {
        let scale = r.abs().max(1.0);
        err = err.max((f - r).abs() / scale);
        est = est.max((f - c).abs() / 3.0 / scale);
    }
    let checks = vec![
        Check::new("max |g| (absolute; lengths ~0.03 m)", fine.max_g, 1e-14),
        Check::new(
            "max relative error of (q, q') at t = 0.03 against the test set",
            err,
            2.0 * est + 1e-12,
        ),
        Check::new("Richardson error estimate (h = 5e-6)", est, 1e-3),
    ];
    let passed = fine.end.iter().all(|v| v.is_finite()) && checks.iter().all(|c| c.passed);
    let (e0, e1) = fine.energy;
    Row {
        case: name.into(),
        scheme: "projection around the implicit midpoint rule (autodiff model) order 2".into(),
        steps: 6000,
        max_g: Some(fine.max_g),
        max_phi: None,
        energy: format!(
            "H (with the torque's potential -mom beta) {e0:.6e}, |H - H0| at t = 0.03: {:.1e}",
            (e1 - e0).abs()
        ),
        newton_max: fine.newton_max,
        condition: None,
        outcome: "ok".into(),
        checks,
        passed,
        seconds: 0.0,
    }
}

// ---------------------------------------------------------------------------------------------
// The N-four-bar mechanism (IFToMM A02).

pub(super) fn four_bar() -> Row {
    use lieflow::models::four_bar::NFourBar;
    let name = "n-four-bar";
    let model = NFourBar::new(40);
    let r = match model.benchmark_run(1e-3, 10_000) {
        Ok(r) => r,
        Err(e) => return refused_row(name, e.to_string(), false),
    };
    let walk = 4.0 * f64::EPSILON * (r.steps as f64).sqrt() * r.energy.abs();
    let checks = if r.error.is_none() {
        vec![
            Check::new(
                "crossings of the singular position (at least 2)",
                2.0 - r.crossings as f64,
                0.0,
            ),
            // The Newton tolerance 16 ε (N + 1) plus the rounding of g at coordinates to N + 1.
            Check::new("max |g|", r.max_g, 20.0 * f64::EPSILON * 41.0),
            Check::new(
                "max |H - H0| over the last tenth",
                r.last_tenth,
                1.1 * r.first_tenth + walk,
            ),
        ]
    } else {
        Vec::new()
    };
    let passed = r.finite && checks.iter().all(|c| c.passed);
    Row {
        case: name.into(),
        scheme: "RATTLE with the bars' constant non-diagonal mass matrix, order 2".into(),
        steps: r.steps,
        max_g: Some(r.max_g),
        max_phi: None,
        energy: format!(
            "H0 {:.6e}; max |H - H0| first tenth {:.2e}, last tenth {:.2e}; {} crossings of the singular position",
            r.energy, r.first_tenth, r.last_tenth, r.crossings
        ),
        newton_max: r.newton_max,
        condition: None,
        outcome: match &r.error {
            None => "ok".into(),
            Some(e) => format!("typed error: {e}"),
        },
        checks,
        passed,
        seconds: 0.0,
    }
}

// ---------------------------------------------------------------------------------------------
// Bricard's mechanism (IFToMM A04).

pub(super) fn bricard() -> Row {
    use lieflow::models::bricard::Bricard;
    let name = "bricard";
    let h = 1e-3;
    let (r, half) = match (Bricard::run(h, 10_000), Bricard::run(h / 2.0, 20_000)) {
        (Ok(r), Ok(half)) => (r, half),
        (Err(e), _) | (_, Err(e)) => return refused_row(name, e.to_string(), false),
    };
    let walk = 4.0 * f64::EPSILON * (r.steps as f64).sqrt() * r.energy.abs();
    // Enforced rows: the Newton tolerance 16 ε plus the rounding of g at unit coordinates.
    let g_bound = 32.0 * f64::EPSILON;
    let checks = if r.error.is_none() && half.error.is_none() {
        vec![
            Check::new(
                "rows dropped other than one (rank 23 of 24)",
                (r.dropped.len() as f64 - 1.0).abs(),
                0.0,
            ),
            Check::new("max |g| (enforced rows)", r.max_g, g_bound),
            // Near the manifold the dropped row is a combination Σ cᵢ gᵢ of the enforced ones
            // (‖c‖₁ = 19 at the initial position) plus its own rounding.
            Check::new("max |g| (dropped row)", r.max_dropped, 20.0 * g_bound),
            Check::new(
                "P3 moved less than 1 m (the mobility Grubler's count denies)",
                1.0 - r.p3_travel,
                0.0,
            ),
            Check::new(
                "max |H - H0| over the last tenth",
                r.last_tenth,
                1.1 * r.first_tenth + walk,
            ),
            // RATTLE's energy error is O(h²) uniformly in time (GNI §IX.8, §XI).
            Check::new(
                "|order of the energy error from h, h/2 - 2|",
                ((r.first_tenth / half.first_tenth).log2() - 2.0).abs(),
                0.1,
            ),
        ]
    } else {
        Vec::new()
    };
    let passed = r.finite && half.finite && checks.iter().all(|c| c.passed);
    let richardson: f64 = (0..3)
        .map(|d| (r.p3[d] - half.p3[d]).abs())
        .fold(0.0, f64::max)
        / 3.0;
    Row {
        case: name.into(),
        scheme: "RATTLE in natural coordinates, dependent row dropped (DropDependent), order 2"
            .into(),
        steps: r.steps,
        max_g: Some(r.max_g),
        max_phi: None,
        energy: format!(
            "H0 {:.6e}; max |H - H0| first tenth {:.2e}, last tenth {:.2e} (h/2: {:.2e}); dropped rows {:?} at {:.1e}; P3(10 s) = ({:.6}, {:.6}, {:.6}) +- {:.1e} (Richardson)",
            r.energy,
            r.first_tenth,
            r.last_tenth,
            half.first_tenth,
            r.dropped,
            r.max_dropped,
            half.p3[0],
            half.p3[1],
            half.p3[2],
            richardson
        ),
        newton_max: r.newton_max,
        condition: None,
        outcome: match r.error.as_ref().or(half.error.as_ref()) {
            None => "ok".into(),
            Some(e) => format!("typed error: {e}"),
        },
        checks,
        passed,
        seconds: 0.0,
    }
}

// ---------------------------------------------------------------------------------------------
// Scenes of the other cases.
