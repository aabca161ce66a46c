//! The hard-case suite: problems engineers fear — a public DAE test problem,
//! stiff damping and springs, extreme lengths and mass ratios, a nearly singular multiplier
//! system, redundant constraints, very long runs, hostile input — each run as a scene and
//! judged by what theory says it must do: stay stable with its residuals at their rounding
//! level and its energy behaving, or stop with a typed error. `lieflow stress` prints the rows;
//! `tests/stress.rs` asserts them.
//!
//! Every case is a [`StressCase`]; [`run_case`] runs it and returns a [`Row`] whose
//! [`passed`](Row::passed) says whether every check held. The long cases (10⁷ steps) are
//! marked [`StressCase::long`].

mod cases;
mod fekete;
mod mechanisms;
mod scenes;

pub use cases::cases;
use cases::hostile;
use fekete::fekete;
pub use fekete::{FEKETE_MULTIPLIER, FEKETE_REFERENCE, fekete_initial_positions, fekete_scene};
use lieflow::scene::observe::{EnergyDrift, NewtonMax, Residuals};
use lieflow::scene::{Compiled, Scene};
use lieflow::scene::{RunFailure, advance_plan};
use mechanisms::{andrews, bricard, four_bar};
pub use scenes::{
    chain_scene, damped_chain_scene, stiff_spring_among_pins_scene, stiff_spring_scene,
    taut_chain_scene,
};
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
    /// Run to the end with `max |g| ≤ g_bound` and exactly `count` events recorded.
    Events {
        /// Bound on `max |g|` (absolute; scenes without constraints have none).
        g_bound: f64,
        /// The number of events the theory predicts.
        count: usize,
    },
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
    /// The energy budget closes: `|H(T) − H₀ + dissipated − supplied| ≤ rel · max(|supplied|,
    /// dissipated)` at the end of the run.
    Budget {
        /// Relative bound.
        rel: f64,
    },
    /// An exact discrete energy balance `H(x_{n+1}) − H(x_n) = −D_n`, `D_n ≥ 0`: `H` never rises
    /// by more than `slack` from one step to the next (the balance's rounding), and the budget
    /// `|H(T) − H₀ + ΣD_n|` closes to `slack` plus the round-off random walk `4 ε √N |H₀|` of
    /// the running sum.
    Balanced {
        /// The rounding of one step's balance (absolute).
        slack: f64,
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
pub struct StressCase {
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
    error: Option<RunFailure>,
    x: Vec<f64>,
    multipliers: Option<Vec<f64>>,
    finite: bool,
    /// `(|H(T) − H₀ + dissipated − supplied|, max(|supplied|, dissipated))` when the flow
    /// books them.
    budget: Option<(f64, f64)>,
    events: usize,
}

fn simulate(c: &mut Compiled) -> Measured {
    let sim = c.simulation.as_mut();
    sim.reset_counters();
    let plan = c.plan;
    let steps = plan.total_steps();
    let cond0 = sim.multiplier_condition();
    let mut watch = (
        Residuals::default(),
        EnergyDrift::new(sim, steps),
        NewtonMax::new(sim),
    );
    let done = advance_plan(sim, &plan, &mut watch);
    let (residuals, drift, newton) = watch;
    let cond1 = sim.multiplier_condition();
    let condition = match (cond0, cond1) {
        (Some(a), Some(b)) => Some(a.max(b)),
        (a, b) => a.or(b),
    };
    let x = sim.state().to_vec();
    let budget = match (sim.supplied(), sim.dissipated()) {
        (None, None) => None,
        (s, d) => {
            let (s, d) = (s.unwrap_or(0.0), d.unwrap_or(0.0));
            let change = sim.energy() - drift.initial;
            Some(((change + d - s).abs(), s.abs().max(d.abs())))
        }
    };
    Measured {
        budget,
        events: sim.events().len(),
        steps: done.steps,
        max_g: residuals.max_g,
        max_phi: residuals.max_phi,
        e0: drift.initial,
        max_rise: drift.max_rise,
        rise_at: drift.rise_at,
        max_de: drift.max_abs_error,
        first_tenth: drift.first_tenth,
        last_tenth: drift.last_tenth,
        newton_max: newton.max,
        condition,
        error: done.error,
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
        Some(f) => format!("typed error: {}", f.message),
    }
}

fn energy_checks(rule: EnergyRule, m: &Measured) -> Vec<Check> {
    match rule {
        EnergyRule::Balanced { slack } => {
            let (err, _) = m.budget.unwrap_or((f64::INFINITY, 0.0));
            vec![
                Check::new("energy rise per step", m.max_rise, slack),
                Check::new(
                    "|H(T) - H0 + dissipated|",
                    err,
                    slack + 4.0 * f64::EPSILON * (m.steps as f64).sqrt() * m.e0.abs(),
                ),
            ]
        }
        other => vec![energy_check(other, m)],
    }
}

fn energy_check(rule: EnergyRule, m: &Measured) -> Check {
    match rule {
        EnergyRule::Balanced { .. } => unreachable!("split into two checks by energy_checks"),
        EnergyRule::NonIncreasing { slack } => {
            Check::new("energy rise per step", m.max_rise, slack)
        }
        EnergyRule::Bounded { rel } => Check::new(
            "max |H - H0|",
            m.max_de,
            rel * m.e0.abs().max(f64::MIN_POSITIVE),
        ),
        EnergyRule::Budget { rel } => {
            let (err, scale) = m.budget.unwrap_or((f64::INFINITY, 0.0));
            Check::new(
                "|H(T) - H0 + dissipated - supplied|",
                err,
                rel * scale.max(f64::MIN_POSITIVE),
            )
        }
        EnergyRule::NoDrift => Check::new(
            "max |H - H0| over the last tenth",
            m.last_tenth,
            1.1 * m.first_tenth + 4.0 * f64::EPSILON * (m.steps as f64).sqrt() * m.e0.abs(),
        ),
    }
}

/// Runs one case.
pub fn run_case(case: &StressCase) -> Row {
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
            let mut checks = energy_checks(energy, &m);
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
        Expect::Events { g_bound, count } => {
            let mut checks = vec![Check::new(
                "events recorded minus predicted",
                (m.events as f64 - count as f64).abs(),
                0.0,
            )];
            if let Some(g) = m.max_g {
                checks.push(Check::new("max |g|", g, g_bound));
            }
            (checks, m.error.is_none())
        }
        Expect::Refused(_) => unreachable!("handled above"),
    };
    measured_row(name, &c, &m, checks, ok)
}

// ---------------------------------------------------------------------------------------------
// The Fekete problem (IVP test set).
