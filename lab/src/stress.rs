//! The hard-case suite: problems engineers fear — a public DAE test problem,
//! stiff damping and springs, extreme lengths and mass ratios, a nearly singular multiplier
//! system, redundant constraints, very long runs, hostile input — each run as a scene and
//! judged by what theory says it must do: stay stable with its residuals at their rounding
//! level and its energy behaving, or stop with a typed error. `lieflow stress` prints the rows;
//! `tests/stress.rs` asserts them.
//!
//! Every case is a [`Case`]; [`run_case`] runs it and returns a [`Row`] whose
//! [`passed`](Row::passed) says whether every check held. The long cases (10⁷ steps) are
//! marked [`Case::long`].

use lieflow::StepError;
use lieflow::scene::{Compiled, Scene};
use serde::Serialize;
use std::time::Instant;

/// What a case must do to pass.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Expect {
    /// Run to the end with `max |g| ≤ g_bound`, and the energy rule.
    Stable {
        /// Bound on `max |g|` over the run (absolute).
        g_bound: f64,
        /// What the energy must do.
        energy: EnergyRule,
    },
    /// Either [`Expect::Stable`] with this bound, or stop with a typed step error; never a
    /// panic or a non-finite state.
    StableOrTyped {
        /// Bound on `max |g|` when it runs.
        g_bound: f64,
    },
    /// An explicit scheme past its stability limit: it must stop with a typed error or report
    /// an energy error larger than the initial energy — with a finite last state.
    Unstable,
    /// Refused when the scene is built, with an error whose text contains this.
    Refused(&'static str),
}

/// The energy behaviour a stable case must show.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum EnergyRule {
    /// Never rises from one step to the next by more than `slack` (with `R ⪰ 0`).
    NonIncreasing {
        /// Allowed rise per step (absolute), from the scheme's own analysis.
        slack: f64,
    },
    /// `max |H − H₀| ≤ rel · |H₀|` over the run.
    Bounded {
        /// Relative bound.
        rel: f64,
    },
    /// No drift: the largest `|H − H₀|` over the last tenth of the run is at most 1.1 times that
    /// over the first tenth plus the round-off random walk `4 ε √N |H₀|`. A symmetric method's
    /// error oscillates with a bounded amplitude (GNI §XI), whose maximum sampled over a window
    /// of a quasi-periodic motion varies by a small fraction between windows; a secular drift
    /// `c t` would add ten times more to the last tenth than to the first.
    NoDrift,
}

/// One case of the suite.
#[derive(Debug, Clone)]
pub struct Case {
    /// Short name (the command's `--case` filter).
    pub name: &'static str,
    /// What it exercises.
    pub about: &'static str,
    /// Where the problem comes from.
    pub source: &'static str,
    /// `true` for the long runs (10⁷ steps), run with `lieflow stress --long`.
    pub long: bool,
    kind: Kind,
}

#[derive(Debug, Clone)]
enum Kind {
    Scene { text: String, expect: Expect },
    Fekete,
    Andrews,
    FourBar,
    Bricard,
    Hostile,
}

/// One check of a row: a measured value against its bound.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Check {
    /// What was measured.
    pub what: String,
    /// The measured value.
    pub value: f64,
    /// The bound it must not exceed.
    pub bound: f64,
    /// `value ≤ bound` (and finite).
    pub passed: bool,
}

impl Check {
    fn new(what: impl Into<String>, value: f64, bound: f64) -> Self {
        Self {
            what: what.into(),
            value,
            bound,
            passed: value.is_finite() && value <= bound,
        }
    }
}

/// The result of one case.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Row {
    /// The case.
    pub case: String,
    /// The scheme that ran (`"-"` when refused at build).
    pub scheme: String,
    /// Steps taken.
    pub steps: usize,
    /// `max |g|` over the run.
    pub max_g: Option<f64>,
    /// `max |φ|` over the run (degenerate case).
    pub max_phi: Option<f64>,
    /// The energy's behaviour, in words and numbers.
    pub energy: String,
    /// The most Newton iterations one step took.
    pub newton_max: u64,
    /// The largest condition estimate of `G W⁻¹ Gᵀ` (initial and final state).
    pub condition: Option<f64>,
    /// `ok`, `typed error: <kind>: <message>`, `refused: <message>`.
    pub outcome: String,
    /// The checks (empty when only the outcome is judged).
    pub checks: Vec<Check>,
    /// Every check held and the outcome is one the case allows.
    pub passed: bool,
    /// Wall-clock seconds.
    pub seconds: f64,
}

/// What a run measured.
struct Measured {
    steps: usize,
    max_g: Option<f64>,
    max_phi: Option<f64>,
    e0: f64,
    max_rise: f64,
    /// The step of the largest rise and the energy there.
    rise_at: (usize, f64),
    max_de: f64,
    first_tenth: f64,
    last_tenth: f64,
    newton_max: u64,
    condition: Option<f64>,
    error: Option<StepError>,
    x: Vec<f64>,
    multipliers: Option<Vec<f64>>,
    finite: bool,
}

fn simulate(c: &mut Compiled) -> Measured {
    let sim = c.simulation.as_mut();
    sim.reset_counters();
    let steps = c.plan.steps;
    let cond0 = sim.multiplier_condition();
    let e0 = sim.energy();
    let (mut max_g, mut max_phi) = (None::<f64>, None::<f64>);
    let (mut e_prev, mut max_rise, mut max_de) = (e0, f64::NEG_INFINITY, 0.0f64);
    let mut rise_at = (0, e0);
    let (mut first_tenth, mut last_tenth) = (0.0f64, 0.0f64);
    let mut newton_prev = sim.stats().newton_iterations;
    let mut newton_max = 0;
    let mut error = None;
    let mut taken = 0;
    for k in 0..steps {
        if let Err(e) = sim.step() {
            error = Some(e);
            break;
        }
        taken += 1;
        let n = sim.stats().newton_iterations;
        newton_max = newton_max.max(n - newton_prev);
        newton_prev = n;
        if let Some((g, phi)) = sim.residuals() {
            max_g = Some(max_g.unwrap_or(0.0).max(g));
            max_phi = Some(max_phi.unwrap_or(0.0).max(phi));
        }
        let e = sim.energy();
        if e - e_prev > max_rise {
            max_rise = e - e_prev;
            rise_at = (k + 1, e);
        }
        e_prev = e;
        let de = (e - e0).abs();
        max_de = max_de.max(de);
        if k < steps / 10 {
            first_tenth = first_tenth.max(de);
        } else if k >= steps - steps / 10 {
            last_tenth = last_tenth.max(de);
        }
    }
    let cond1 = sim.multiplier_condition();
    let condition = match (cond0, cond1) {
        (Some(a), Some(b)) => Some(a.max(b)),
        (a, b) => a.or(b),
    };
    let x = sim.state().to_vec();
    Measured {
        steps: taken,
        max_g,
        max_phi,
        e0,
        max_rise,
        rise_at,
        max_de,
        first_tenth,
        last_tenth,
        newton_max,
        condition,
        error,
        finite: x.iter().all(|v| v.is_finite()),
        multipliers: sim.multipliers(),
        x,
    }
}

fn energy_text(m: &Measured) -> String {
    if m.steps == 0 {
        return "-".into();
    }
    if m.max_rise <= 0.0 {
        format!(
            "never rose (H0 {:.4e}, final change {:.2e})",
            m.e0, m.max_de
        )
    } else {
        format!(
            "max rise/step {:.2e} (step {}, H {:.4e}); max |H-H0| {:.2e} (first tenth {:.2e}, last {:.2e})",
            m.max_rise, m.rise_at.0, m.rise_at.1, m.max_de, m.first_tenth, m.last_tenth
        )
    }
}

fn outcome_text(m: &Measured) -> String {
    match &m.error {
        None => "ok".into(),
        Some(e) => format!("typed error: {e}"),
    }
}

fn energy_check(rule: EnergyRule, m: &Measured) -> Check {
    match rule {
        EnergyRule::NonIncreasing { slack } => {
            Check::new("energy rise per step", m.max_rise, slack)
        }
        EnergyRule::Bounded { rel } => Check::new(
            "max |H - H0|",
            m.max_de,
            rel * m.e0.abs().max(f64::MIN_POSITIVE),
        ),
        EnergyRule::NoDrift => Check::new(
            "max |H - H0| over the last tenth",
            m.last_tenth,
            1.1 * m.first_tenth + 4.0 * f64::EPSILON * (m.steps as f64).sqrt() * m.e0.abs(),
        ),
    }
}

/// Runs one case.
pub fn run_case(case: &Case) -> Row {
    let start = Instant::now();
    let mut row = match &case.kind {
        Kind::Scene { text, expect } => run_scene_case(case.name, text, *expect),
        Kind::Fekete => fekete(),
        Kind::Andrews => andrews(),
        Kind::FourBar => four_bar(),
        Kind::Bricard => bricard(),
        Kind::Hostile => hostile(),
    };
    row.seconds = start.elapsed().as_secs_f64();
    row
}

fn refused_row(name: &str, message: String, passed: bool) -> Row {
    Row {
        case: name.into(),
        scheme: "-".into(),
        steps: 0,
        max_g: None,
        max_phi: None,
        energy: "-".into(),
        newton_max: 0,
        condition: None,
        outcome: format!("refused: {message}"),
        checks: Vec::new(),
        passed,
        seconds: 0.0,
    }
}

fn measured_row(name: &str, c: &Compiled, m: &Measured, checks: Vec<Check>, ok: bool) -> Row {
    let scheme = match &c.assembly.projection {
        Some(p) => format!("{} order {}, {p}", c.assembly.scheme, c.assembly.order),
        None => format!("{} order {}", c.assembly.scheme, c.assembly.order),
    };
    let passed = ok && m.finite && checks.iter().all(|c| c.passed);
    Row {
        case: name.into(),
        scheme,
        steps: m.steps,
        max_g: m.max_g,
        max_phi: m.max_phi,
        energy: energy_text(m),
        newton_max: m.newton_max,
        condition: m.condition,
        outcome: outcome_text(m),
        checks,
        passed,
        seconds: 0.0,
    }
}

fn run_scene_case(name: &str, text: &str, expect: Expect) -> Row {
    let compiled = Scene::from_toml(text, &format!("{name}.toml")).and_then(|s| s.compile());
    let mut c = match (compiled, expect) {
        (Err(e), Expect::Refused(what)) => {
            let msg = e.to_string();
            let ok = msg.contains(what);
            return refused_row(name, msg, ok);
        }
        (Err(e), _) => return refused_row(name, e.to_string(), false),
        (Ok(_), Expect::Refused(what)) => {
            return refused_row(name, format!("built, but '{what}' was expected"), false);
        }
        (Ok(c), _) => c,
    };
    let m = simulate(&mut c);
    let (checks, ok) = match expect {
        Expect::Stable { g_bound, energy } => {
            let mut checks = vec![energy_check(energy, &m)];
            if let Some(g) = m.max_g {
                checks.push(Check::new("max |g|", g, g_bound));
            }
            (checks, m.error.is_none())
        }
        Expect::StableOrTyped { g_bound } => {
            let checks = match (m.error.is_none(), m.max_g) {
                (true, Some(g)) => vec![Check::new("max |g|", g, g_bound)],
                _ => Vec::new(),
            };
            (checks, true)
        }
        Expect::Unstable => {
            let blown = m.error.is_some() || m.max_de > m.e0.abs();
            (Vec::new(), blown)
        }
        Expect::Refused(_) => unreachable!("handled above"),
    };
    measured_row(name, &c, &m, checks, ok)
}

// ---------------------------------------------------------------------------------------------
// The Fekete problem (IVP test set).

/// Particles of the Fekete problem.
const FEKETE_N: usize = 20;

/// The test set's initial positions (`fekinit` in `fekete.f`): four rings at latitudes `β`,
/// particle `i` of a ring of `n` at longitude `2π i/n + offset`.
pub fn fekete_initial_positions() -> Vec<[f64; 3]> {
    use std::f64::consts::PI;
    let rings: [(std::ops::RangeInclusive<usize>, usize, f64, f64, f64); 4] = [
        (1..=3, 0, 3.0, PI / 13.0, 3.0 * PI / 8.0),
        (4..=10, 3, 7.0, PI / 29.0, PI / 8.0),
        (11..=16, 10, 6.0, PI / 7.0, -2.0 * PI / 15.0),
        (17..=20, 17, 4.0, PI / 17.0, -3.0 * PI / 10.0),
    ];
    let mut p = Vec::with_capacity(FEKETE_N);
    for (range, first, n, offset, beta) in rings {
        for i in range {
            let alpha = 2.0 * PI * (i - first) as f64 / n + offset;
            p.push([
                alpha.cos() * beta.cos(),
                alpha.sin() * beta.cos(),
                beta.sin(),
            ]);
        }
    }
    p
}

/// The test set's reference positions at `t = 1000` (`feksoln` in `fekete.f`, computed there
/// with RADAU5 at tolerance 1e-12): `p_i`, `i = 1 … 20`, digit for digit as published.
#[allow(clippy::excessive_precision)]
pub const FEKETE_REFERENCE: [[f64; 3]; FEKETE_N] = [
    [-0.4070263380333202, 0.3463758772791802, 0.8451942450030429],
    [
        0.7752934752521549e-1,
        -0.2628662719972299,
        0.9617122871829146,
    ],
    [0.7100577833343567, 0.1212948055586120, 0.6936177005172217],
    [0.2348267744557627, 0.7449277976923311, 0.6244509285956391],
    [-0.4341114738782885, 0.8785430442262876, 0.1992720444237660],
    [-0.9515059600312596, 0.2203508762787005, 0.2146669498274008],
    [-0.6385191643609878, -0.4310833259390688, 0.6375425027722121],
    [-0.1464175087914336, -0.9380871635228862, 0.3139337298744690],
    [0.5666974065069942, -0.6739221885076542, 0.4740073135462156],
    [
        0.9843259538440293,
        -0.1696995357819996,
        -0.4800504290609090e-1,
    ],
    [0.1464175087914331, 0.9380871635228875, -0.3139337298744656],
    [-0.7092757549979014, 0.5264062637139616, -0.4688542938854929],
    [
        -0.8665731819284478,
        -0.4813878059756024,
        -0.1315929352982178,
    ],
    [
        -0.2347897778700538,
        -0.8594340408013130,
        -0.4541441287957579,
    ],
    [0.5530976940074118, -0.7674370265615124, -0.3242273140037833],
    [
        0.7711050969896927,
        0.6357041816577034,
        0.3573685519777001e-1,
    ],
    [0.7103951209379591, 0.2403570431280519, -0.6614886725910596],
    [
        -0.3038208738735660e-1,
        0.4501923293640461,
        -0.8924145871442046,
    ],
    [
        -0.5772996158107093,
        -0.1766763414971813,
        -0.7971892020969544,
    ],
    [0.2414481766969039, -0.3416456818373135, -0.9082846503446250],
];

/// The Fekete scene: 20 unit masses on the unit sphere, `U = −Σ_{i<j} ln |p_i − p_j|`,
/// damping `α = 0.5` on the momenta, from the test set's rings at rest, to `t = 1000`.
pub fn fekete_scene(dt: f64) -> String {
    let positions: Vec<String> = fekete_initial_positions()
        .iter()
        .map(|p| format!("[{:e}, {:e}, {:e}]", p[0], p[1], p[2]))
        .collect();
    format!(
        "version = 1\nname = \"Fekete problem (IVP test set)\"\ndim = 3\n\
         [[shells]]\nname = \"p\"\nradius = 1.0\nmass = 1.0\npositions = [{}]\n\
         [[effects]]\ntype = \"pair\"\nlaw = \"log\"\nstrength = 1.0\n\
         [[effects]]\ntype = \"damping\"\ncoefficient = 0.5\n\
         [integrator]\ndt = {dt:e}\nt_end = 1000.0\n",
        positions.join(", ")
    )
}

/// The equilibrium multiplier of every particle: at rest, `0 = −∇_i U − p_i λ_i` (lieflow's
/// `x' = M(∇H + Gᵀλ)` with `g_i = (|p_i|² − 1)/2`), and with `|p_i| = 1`
/// `p_i · (p_i − p_j)/|p_i − p_j|² = (1 − p_i·p_j)/(2 − 2 p_i·p_j) = 1/2` for every `j ≠ i`, so
/// `λ_i = p_i · Σ_j (p_i − p_j)/|p_i − p_j|² = (N − 1)/2` whatever the configuration. (The test
/// set writes `q' = f + 2 λ p` with `φ = |p|² − 1`: its `λ = −λ_i/2 = −(N − 1)/4 = −4.75`, the
/// value `feksoln` lists.)
pub const FEKETE_MULTIPLIER: f64 = (FEKETE_N as f64 - 1.0) / 2.0;

fn fekete() -> Row {
    let name = "fekete";
    let run = |dt: f64| -> Result<(Compiled, Measured), String> {
        let scene =
            Scene::from_toml(&fekete_scene(dt), "fekete.toml").map_err(|e| e.to_string())?;
        let mut c = scene.compile().map_err(|e| e.to_string())?;
        let m = simulate(&mut c);
        Ok((c, m))
    };
    let h = 0.01;
    let (c, m) = match run(h) {
        Ok(r) => r,
        Err(e) => return refused_row(name, e, false),
    };
    let (_, half) = match run(h / 2.0) {
        Ok(r) => r,
        Err(e) => return refused_row(name, e, false),
    };
    let n = FEKETE_N * 3;
    let dist = |a: &[f64], b: &[f64]| {
        a.iter()
            .zip(b)
            .fold(0.0f64, |s, (x, y)| s.max((x - y).abs()))
    };
    let reference: Vec<f64> = FEKETE_REFERENCE.iter().flatten().copied().collect();
    // Richardson: for an order-2 method x_h − x ≈ (4/3)(x_h − x_{h/2}); allow twice that, plus
    // the reference's own tolerance (1e-12, RADAU5 in the test set).
    let estimate = 4.0 / 3.0 * dist(&m.x[..n], &half.x[..n]);
    let p_max = m.x[n..].iter().fold(0.0f64, |s, v| s.max(v.abs()));
    let lambda_err = m.multipliers.as_ref().map_or(f64::INFINITY, |l| {
        l.iter()
            .fold(0.0f64, |s, v| s.max((v - FEKETE_MULTIPLIER).abs()))
    });
    let mut checks = vec![
        // Near rest the true decrease per step, h α |p|², falls below the rounding of H itself:
        // a sum of 190 logarithms and 20 kinetic terms, rounding within γ_n Σ|terms| ≲
        // n ε |H| (Higham, Accuracy and Stability of Numerical Algorithms, §4.2), n = 210.
        energy_check(
            EnergyRule::NonIncreasing {
                slack: 210.0 * f64::EPSILON * m.e0.abs(),
            },
            &m,
        ),
        // The scene's Newton tolerance is 16 ε ℓ L (ℓ = L = 1), plus the rounding of g itself.
        Check::new(
            "max |g|",
            m.max_g.unwrap_or(f64::INFINITY),
            20.0 * f64::EPSILON,
        ),
        Check::new("max |p| at t = 1000", p_max, 1e-12),
        // At the fixed point λ solves g = 0 to the Newton tolerance (a few ε) through the
        // factor h²/2 of the half-steps: δλ ≲ 64 ε / (h²/2).
        Check::new(
            "max |lambda - (N-1)/2| at t = 1000",
            lambda_err,
            64.0 * f64::EPSILON / (h * h / 2.0),
        ),
        Check::new(
            "max |p(1000) - test set reference|",
            dist(&m.x[..n], &reference),
            2.0 * estimate + 1e-12,
        ),
    ];
    checks.push(Check::new(
        "Richardson error estimate (h = 0.01)",
        estimate,
        1e-6,
    ));
    measured_row(name, &c, &m, checks, m.error.is_none())
}

// ---------------------------------------------------------------------------------------------
// Andrews' squeezing mechanism (IVP test set), a model with automatic derivatives.

fn andrews() -> Row {
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

fn four_bar() -> Row {
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

fn bricard() -> Row {
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

/// A planar chain of `masses.len()` bodies on rods of length `l`, hanging from the origin at
/// 30° from the vertical, under gravity; optionally its last body tied by a rod to `end`.
pub fn chain_scene(
    masses: &[f64],
    l: f64,
    end: Option<([f64; 2], f64)>,
    dt: f64,
    steps: usize,
) -> String {
    let (s, c) = (0.5f64, -(0.75f64).sqrt());
    let mut text = String::from("version = 1\ndim = 2\n");
    for (i, m) in masses.iter().enumerate() {
        let k = (i + 1) as f64 * l;
        text += &format!(
            "[[bodies]]\nname = \"b{i}\"\nmass = {m:e}\nposition = [{:e}, {:e}]\n",
            k * s,
            k * c
        );
    }
    text += "[[constraints]]\ntype = \"rod\"\nbodies = [\"b0\"]\npoint = [0.0, 0.0]\n";
    for i in 1..masses.len() {
        text += &format!(
            "[[constraints]]\ntype = \"rod\"\nbodies = [\"b{}\", \"b{i}\"]\n",
            i - 1
        );
    }
    if let Some((p, len)) = end {
        text += &format!(
            "[[constraints]]\ntype = \"rod\"\nbodies = [\"b{}\"]\npoint = [{:e}, {:e}]\nlength = {len:e}\n",
            masses.len() - 1,
            p[0],
            p[1]
        );
    }
    text += &format!(
        "[[effects]]\ntype = \"gravity\"\ng = [0.0, -9.81]\n[integrator]\ndt = {dt:e}\nt_end = {:e}\n",
        dt * steps as f64
    );
    text
}

/// A 3-link pendulum chain with damping `c` on every body, `h = 0.01`, `T = 1`.
pub fn damped_chain_scene(c: f64, scheme: &str) -> String {
    format!(
        "version = 1\ndim = 2\n[[chains]]\nname = \"c\"\nlinks = 3\ndirection = [1.0, -0.2]\n\
         length = 0.5\nmass = 1.0\n[[effects]]\ntype = \"gravity\"\ng = [0.0, -9.81]\n\
         [[effects]]\ntype = \"damping\"\ncoefficient = {c:e}\n\
         [integrator]\nscheme = \"{scheme}\"\ndt = 0.01\nt_end = 1.0\n"
    )
}

/// Two unit masses joined by a spring of stiffness `k`, one pinned: an oscillator of frequency
/// `√k`; at `h = 0.01` and `k = 1e8`, `ω h = 100`.
pub fn stiff_spring_scene(k: f64, scheme: &str) -> String {
    format!(
        "version = 1\ndim = 2\n[[bodies]]\nname = \"a\"\nmass = 1.0\nposition = [0.0, 0.0]\n\
         [[bodies]]\nname = \"b\"\nmass = 1.0\nposition = [1.001, 0.0]\n\
         [[constraints]]\ntype = \"pin\"\nbodies = [\"a\"]\n\
         [[effects]]\ntype = \"spring\"\nbodies = [\"a\", \"b\"]\nstiffness = {k:e}\nrest_length = 1.0\n\
         [integrator]\nscheme = \"{scheme}\"\ndt = 0.01\nt_end = 1.0\n"
    )
}

/// The stiff spring of [`stiff_spring_scene`] with three more pinned bodies: 8 constraints
/// (the projected midpoint rule's general path) and still a quadratic energy, which the
/// midpoint rule conserves to its solve's tolerance.
pub fn stiff_spring_among_pins_scene(k: f64, scheme: &str) -> String {
    let spring = stiff_spring_scene(k, scheme);
    let (bodies, integrator) = spring
        .split_once("[integrator]")
        .unwrap_or((spring.as_str(), ""));
    let mut text = bodies.to_owned();
    for i in 0..3 {
        text += &format!(
            "[[bodies]]\nname = \"p{i}\"\nmass = 1.0\nposition = [0.0, {}]\n\
             [[constraints]]\ntype = \"pin\"\nbodies = [\"p{i}\"]\n",
            2.0 + i as f64
        );
    }
    text + "[integrator]" + integrator
}

/// A chain of `links` (even) links of length 0.1 pinned at both ends, the anchors on a
/// horizontal line `slack` (relatively) closer than the chain's length: it starts as a shallow
/// "V" (each half at angle `θ`, `cos θ = 1 − slack`, on the constraints exactly) and hangs
/// nearly straight, so `G W⁻¹ Gᵀ` is nearly singular (`κ ~ 1/θ²`). Under gravity, 100 steps of
/// `h = 1e-4`.
pub fn taut_chain_scene(links: usize, slack: f64) -> String {
    let l = 0.1;
    let cos = 1.0 - slack;
    let sin = (slack * (2.0 - slack)).sqrt();
    let mut text = String::from("version = 1\ndim = 2\n");
    let (mut x, mut y) = (0.0f64, 0.0f64);
    for i in 0..links - 1 {
        let down = if i < links / 2 { -1.0 } else { 1.0 };
        x += l * cos;
        y += down * l * sin;
        text += &format!("[[bodies]]\nname = \"b{i}\"\nmass = 1.0\nposition = [{x:e}, {y:e}]\n");
    }
    text += "[[constraints]]\ntype = \"rod\"\nbodies = [\"b0\"]\npoint = [0.0, 0.0]\n";
    for i in 1..links - 1 {
        text += &format!(
            "[[constraints]]\ntype = \"rod\"\nbodies = [\"b{}\", \"b{i}\"]\n",
            i - 1
        );
    }
    text += &format!(
        "[[constraints]]\ntype = \"rod\"\nbodies = [\"b{}\"]\npoint = [{:e}, 0.0]\nlength = {l:e}\n",
        links - 2,
        links as f64 * l * cos
    );
    text += "[[effects]]\ntype = \"gravity\"\ng = [0.0, -9.81]\n[integrator]\ndt = 1e-4\nt_end = 1e-2\n";
    text
}

fn alternating(ratio: f64) -> Vec<f64> {
    (0..12)
        .map(|i| if i % 2 == 0 { 1.0 } else { ratio })
        .collect()
}

/// `max |g|` of a chain of links `ℓ` reaching `L` from the origin rounds at a few `ε ℓ L`.
fn chain_g_bound(l: f64, extent: f64) -> f64 {
    64.0 * f64::EPSILON * l * extent
}

fn scene_case(
    name: &'static str,
    about: &'static str,
    source: &'static str,
    text: String,
    expect: Expect,
) -> Case {
    Case {
        name,
        about,
        source,
        long: false,
        kind: Kind::Scene { text, expect },
    }
}

/// The suite: the fast cases, then (marked `long`) the 10⁷-step runs.
pub fn cases() -> Vec<Case> {
    let kick = 3.0 * (9.81f64 * 0.01 / 2.0).powi(2) / 2.0;
    let mut v = vec![
        Case {
            name: "fekete",
            about: "20 particles on the unit sphere, log repulsion, damping 0.5, t in [0, 1000]",
            source: "IVP test set (Bari), Fekete problem",
            long: false,
            kind: Kind::Fekete,
        },
        Case {
            name: "andrews",
            about: "7 bodies, 6 loop closures, position-dependent mass matrix, t in [0, 0.03]",
            source: "IVP test set (Bari), Andrews' squeezing mechanism",
            long: false,
            kind: Kind::Andrews,
        },
        Case {
            name: "n-four-bar",
            about: "40 four-bar windows (81 bars) through the horizontal, rank-deficient position, 10 s",
            source: "IFToMM multibody benchmark A02",
            long: false,
            kind: Kind::FourBar,
        },
        Case {
            name: "bricard",
            about: "Bricard's over-constrained linkage (24 equations of rank 23, one degree of freedom Grubler's count denies) from rest under gravity, the dependent row dropped, 10 s",
            source: "IFToMM multibody benchmark A04",
            long: false,
            kind: Kind::Bricard,
        },
        scene_case(
            "damping-1e6-strang",
            "3-link chain, damping c h / m = 1e6 (c = 1e8, h = 0.01), exact damping flow in Strang",
            "issue 12, case 5",
            damped_chain_scene(1e8, "auto"),
            // Overdamped, the closing half kick adds at most N m (g h/2)²/2 per step.
            Expect::Stable {
                g_bound: 1e-12,
                energy: EnergyRule::NonIncreasing { slack: kick },
            },
        ),
        scene_case(
            "damping-1e6-dg",
            "the same chain, constrained discrete gradient",
            "issue 12, case 5",
            damped_chain_scene(1e8, "discrete-gradient"),
            // Dissipative by construction; a few ulps of |H| ≈ 20 of rounding.
            Expect::Stable {
                g_bound: 1e-12,
                energy: EnergyRule::NonIncreasing {
                    slack: 64.0 * f64::EPSILON * 20.0,
                },
            },
        ),
        scene_case(
            "spring-1e8-midpoint",
            "spring k / m = 1e8 at h = 0.01 (omega h = 100), implicit midpoint rule",
            "issue 12, case 5",
            stiff_spring_scene(1e8, "midpoint"),
            Expect::Stable {
                g_bound: 1e-12,
                energy: EnergyRule::Bounded { rel: 1e-6 },
            },
        ),
        scene_case(
            "spring-1e8-midpoint-8c",
            "the same spring among three pinned bodies (8 constraints), implicit midpoint rule",
            "issue 12, case 5",
            stiff_spring_among_pins_scene(1e8, "midpoint"),
            Expect::Stable {
                g_bound: 1e-12,
                energy: EnergyRule::Bounded { rel: 1e-6 },
            },
        ),
        scene_case(
            "spring-1e8-dg",
            "the same spring, discrete gradient (energy-preserving)",
            "issue 12, case 5",
            stiff_spring_scene(1e8, "discrete-gradient"),
            Expect::Stable {
                g_bound: 1e-12,
                energy: EnergyRule::Bounded { rel: 1e-6 },
            },
        ),
        scene_case(
            "spring-1e8-explicit",
            "the same spring, Stormer-Verlet (stable only for omega h < 2): must fail visibly",
            "issue 12, case 5",
            stiff_spring_scene(1e8, "auto"),
            Expect::Unstable,
        ),
        scene_case(
            "damping-order-4",
            "damping with a 4th-order composition (backward sub-steps): refused",
            "issue 12, case 5",
            damped_chain_scene(1.0, "auto").replace("[integrator]", "[integrator]\norder = 4"),
            Expect::Refused("integrator.order"),
        ),
        scene_case(
            "links-1e-6",
            "8-link chain of micrometre links",
            "issue 12, case 6",
            chain_scene(&[1.0; 8], 1e-6, None, (1e-6f64 / 9.81).sqrt() / 10.0, 200),
            Expect::Stable {
                g_bound: chain_g_bound(1e-6, 8e-6),
                energy: EnergyRule::Bounded { rel: 1e-2 },
            },
        ),
        scene_case(
            "links-1e3",
            "8-link chain of kilometre links",
            "issue 12, case 6",
            chain_scene(&[1.0; 8], 1e3, None, (1e3f64 / 9.81).sqrt() / 10.0, 200),
            Expect::Stable {
                g_bound: chain_g_bound(1e3, 8e3),
                energy: EnergyRule::Bounded { rel: 1e-2 },
            },
        ),
        scene_case(
            "mass-ratio-1e6",
            "12-link chain, masses alternating 1 and 1e6",
            "issue 12, case 6",
            chain_scene(&alternating(1e6), 0.1, None, 1e-3, 200),
            Expect::StableOrTyped {
                g_bound: chain_g_bound(0.1, 1.2),
            },
        ),
        scene_case(
            "mass-ratio-1e-6",
            "12-link chain, masses alternating 1 and 1e-6",
            "issue 12, case 6",
            chain_scene(&alternating(1e-6), 0.1, None, 1e-3, 200),
            Expect::StableOrTyped {
                g_bound: chain_g_bound(0.1, 1.2),
            },
        ),
        scene_case(
            "taut-chain",
            "10-link chain pinned at both ends, 1e-6 slack: nearly singular G W^-1 G^T",
            "issue 12, case 6",
            taut_chain_scene(10, 1e-6),
            Expect::StableOrTyped {
                g_bound: 1e4 * f64::EPSILON * 0.1,
            },
        ),
        scene_case(
            "duplicated-rod",
            "a rod listed twice: redundant constraints are refused by default",
            "issue 12, case 4",
            chain_scene(&[1.0; 3], 0.5, None, 0.01, 10).replace(
                "[[effects]]",
                "[[constraints]]\ntype = \"rod\"\nbodies = [\"b0\", \"b1\"]\n[[effects]]",
            ),
            Expect::Refused("redundant"),
        ),
        scene_case(
            "redundant-dropped",
            "parallel cranks with a rigid 3-point coupler (one redundant rod), redundant = \"drop-dependent\"",
            "issue 12, case 4",
            include_str!("../../scenes/parallel_cranks.toml").to_owned(),
            // The Newton tolerance 16 ε ℓ L (ℓ = 1, L ≈ 2.2) plus rounding; RATTLE's energy
            // error O(h²) at h = 1e-3.
            Expect::Stable {
                g_bound: 64.0 * f64::EPSILON * 2.3,
                energy: EnergyRule::Bounded { rel: 1e-5 },
            },
        ),
        Case {
            name: "hostile-input",
            about: "NaN, infinite, zero and negative parameters, steps and states: typed, located errors",
            source: "issue 12, case 8",
            long: false,
            kind: Kind::Hostile,
        },
    ];
    v.push(Case {
        name: "paper-1e7",
        about: "the paper's example, 1e7 steps of h = 0.1",
        source: "Zhang & Deng (2004), section 4; issue 12, case 7",
        long: true,
        kind: Kind::Scene {
            text:
                "version = 1\n[builtin]\nmodel = \"paper\"\n[integrator]\ndt = 0.1\nt_end = 1e6\n"
                    .into(),
            expect: Expect::Stable {
                g_bound: 4.0 * f64::EPSILON,
                energy: EnergyRule::NoDrift,
            },
        },
    });
    v.push(Case {
        name: "spherical-pendulum-1e7",
        about: "the spherical pendulum, 1e7 steps of h = 0.01",
        source: "issue 12, case 7",
        long: true,
        kind: Kind::Scene {
            text: "version = 1\n[builtin]\nmodel = \"spherical-pendulum\"\n[integrator]\ndt = 0.01\nt_end = 1e5\n"
                .into(),
            expect: Expect::Stable {
                g_bound: 8.0 * f64::EPSILON,
                energy: EnergyRule::NoDrift,
            },
        },
    });
    v
}

/// Hostile scene files: each must be refused with an error that names where.
fn hostile_scenes() -> Vec<(&'static str, String, &'static str)> {
    let base = chain_scene(&[1.0; 3], 0.5, None, 0.01, 10);
    vec![
        (
            "NaN mass",
            base.replacen("mass = 1e0", "mass = nan", 1),
            "mass",
        ),
        (
            "infinite mass",
            base.replacen("mass = 1e0", "mass = inf", 1),
            "mass",
        ),
        (
            "negative mass",
            base.replacen("mass = 1e0", "mass = -1.0", 1),
            "mass",
        ),
        ("zero step", base.replace("dt = 1e-2", "dt = 0.0"), "dt"),
        ("NaN step", base.replace("dt = 1e-2", "dt = nan"), "dt"),
        ("infinite step", base.replace("dt = 1e-2", "dt = inf"), "dt"),
        (
            "NaN position",
            base.replacen("position = [2.5e-1", "position = [nan", 1),
            "position",
        ),
        (
            "wrong dimension",
            base.replacen("position = [", "position = [0.0, ", 1),
            "position",
        ),
        (
            "unknown body",
            base.replace("bodies = [\"b0\", \"b1\"]", "bodies = [\"b0\", \"b9\"]"),
            "b9",
        ),
        (
            "unknown key",
            base.replace("[integrator]", "[integrator]\nstep = 0.1"),
            "step",
        ),
        (
            "off the constraints",
            base.replacen(
                "rod\"\nbodies = [\"b0\"]\npoint = [0.0, 0.0]\n",
                "rod\"\nbodies = [\"b0\"]\npoint = [0.0, 0.0]\nlength = 0.7\n",
                1,
            ),
            "constraint",
        ),
        (
            "NaN gravity",
            base.replace("g = [0.0, -9.81]", "g = [0.0, nan]"),
            "g",
        ),
        (
            "absurd step count",
            base.replace("t_end = 1e-1", "t_end = 1e300"),
            "steps",
        ),
    ]
}

fn hostile() -> Row {
    let name = "hostile-input";
    let mut checks = Vec::new();
    let mut failures = Vec::new();
    for (what, text, mentions) in hostile_scenes() {
        let result = Scene::from_toml(&text, "hostile.toml").and_then(|s| s.compile());
        match result {
            Ok(_) => failures.push(format!("{what}: accepted")),
            Err(e) => {
                let msg = e.to_string();
                let located = msg.contains("hostile.toml");
                let named = msg.to_lowercase().contains(&mentions.to_lowercase());
                if !(located && named) {
                    failures.push(format!("{what}: {msg}"));
                }
            }
        }
    }
    let total = hostile_scenes().len();
    checks.push(Check::new(
        "scene files not refused with a located error naming the field",
        failures.len() as f64,
        0.0,
    ));
    let outcome = if failures.is_empty() {
        format!("{total}/{total} refused with located errors")
    } else {
        format!("not refused as expected: {}", failures.join("; "))
    };
    Row {
        case: name.into(),
        scheme: "-".into(),
        steps: 0,
        max_g: None,
        max_phi: None,
        energy: "-".into(),
        newton_max: 0,
        condition: None,
        outcome,
        passed: failures.is_empty(),
        checks,
        seconds: 0.0,
    }
}
