//! The list of cases with the bounds each is judged by, and the hostile inputs.

use super::{
    Check, EnergyRule, Expect, Kind, Row, StressCase,
    scenes::{
        alternating, chain_scene, chattering_scene, damped_chain_scene, forced_resonance_scene,
        stiff_spring_among_pins_scene, stiff_spring_scene, taut_chain_scene,
    },
};
use lieflow::scene::Scene;

/// `max |g|` of a chain of links `ℓ` reaching `L` from the origin rounds at a few `ε ℓ L`.
pub(super) fn chain_g_bound(l: f64, extent: f64) -> f64 {
    64.0 * f64::EPSILON * l * extent
}

pub(super) fn scene_case(
    name: &'static str,
    about: &'static str,
    source: &'static str,
    text: String,
    expect: Expect,
) -> StressCase {
    StressCase {
        name,
        about,
        source,
        long: false,
        kind: Kind::Scene { text, expect },
    }
}

/// The suite: the fast cases, then (marked `long`) the 10⁷-step runs.
pub fn cases() -> Vec<StressCase> {
    let kick = 3.0 * (9.81f64 * 0.01 / 2.0).powi(2) / 2.0;
    let mut v = vec![
        StressCase {
            name: "fekete",
            about: "20 particles on the unit sphere, log repulsion, damping 0.5, t in [0, 1000]",
            source: "IVP test set (Bari), Fekete problem",
            long: false,
            kind: Kind::Fekete,
        },
        StressCase {
            name: "andrews",
            about: "7 bodies, 6 loop closures, position-dependent mass matrix, t in [0, 0.03]",
            source: "IVP test set (Bari), Andrews' squeezing mechanism",
            long: false,
            kind: Kind::Andrews,
        },
        StressCase {
            name: "n-four-bar",
            about: "40 four-bar windows (81 bars) through the horizontal, rank-deficient position, 10 s",
            source: "IFToMM multibody benchmark A02",
            long: false,
            kind: Kind::FourBar,
        },
        StressCase {
            name: "bricard",
            about: "Bricard's over-constrained linkage (24 equations of rank 23, one degree of freedom Grubler's count denies) from rest under gravity, the dependent row dropped, 10 s",
            source: "IFToMM multibody benchmark A04",
            long: false,
            kind: Kind::Bricard,
        },
        scene_case(
            "damping-1e6-strang",
            "3-link chain, damping c h / m = 1e6 (c = 1e8, h = 0.01), the order-2 base step: the projection around the exact damped fall",
            "stiff damping and springs",
            damped_chain_scene(1e8, "auto"),
            // The damped fall is dissipative for H and the closing projection removes kinetic
            // energy (it projects p in the kinetic metric), so H can rise only by the first
            // half-step impulse's kinetic energy less what the flight removes; overdamped, the
            // flight removes it all (measured: H never rises). The slack is the bound of the
            // splitting with gravity as a kick, N m (g h/2)²/2 per step.
            Expect::Stable {
                g_bound: 1e-12,
                energy: EnergyRule::NonIncreasing { slack: kick },
            },
        ),
        scene_case(
            "damping-1e6-dg",
            "the same chain, constrained discrete gradient",
            "stiff damping and springs",
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
            "stiff damping and springs",
            stiff_spring_scene(1e8, "midpoint"),
            Expect::Stable {
                g_bound: 1e-12,
                energy: EnergyRule::Bounded { rel: 1e-6 },
            },
        ),
        scene_case(
            "spring-1e8-midpoint-8c",
            "the same spring among three pinned bodies (8 constraints), implicit midpoint rule",
            "stiff damping and springs",
            stiff_spring_among_pins_scene(1e8, "midpoint"),
            Expect::Stable {
                g_bound: 1e-12,
                energy: EnergyRule::Bounded { rel: 1e-6 },
            },
        ),
        scene_case(
            "spring-1e8-dg",
            "the same spring, discrete gradient (energy-preserving)",
            "stiff damping and springs",
            stiff_spring_scene(1e8, "discrete-gradient"),
            Expect::Stable {
                g_bound: 1e-12,
                energy: EnergyRule::Bounded { rel: 1e-6 },
            },
        ),
        scene_case(
            "spring-1e8-explicit",
            "the same spring, Stormer-Verlet (stable only for omega h < 2): must fail visibly",
            "stiff damping and springs",
            stiff_spring_scene(1e8, "auto"),
            Expect::Unstable,
        ),
        scene_case(
            "damping-1e6-order-8",
            "the same chain, its base step extrapolated to order 8 (10 forward sub-steps per step)",
            "stiff damping and springs",
            damped_chain_scene(1e8, "auto").replace("[integrator]", "[integrator]\norder = 8"),
            // Every row is overdamped and does not raise H (see damping-1e6-strang); the
            // combination is held to the same slack.
            Expect::Stable {
                g_bound: 1e-12,
                energy: EnergyRule::NonIncreasing { slack: kick },
            },
        ),
        scene_case(
            "damping-1e6-petrov-galerkin",
            "the same three-link chain (c h / m = 1e6), the energy-consistent Petrov–Galerkin scheme of order 4",
            "stiff damping and springs",
            damped_chain_scene(1e8, "petrov-galerkin"),
            // H(x_{n+1}) − H(x_n) = −D_n, D_n ≥ 0: H never rises beyond the balance's rounding,
            // a few dozen ε of |H| ≈ 6. (Its stage system is equilibrated: the damped momentum
            // rows carry c h / m = 1e6 and would make the multipliers' pivots look singular.)
            Expect::Stable {
                g_bound: 1e-12,
                energy: EnergyRule::NonIncreasing {
                    slack: 64.0 * f64::EPSILON * 6.0,
                },
            },
        ),
        scene_case(
            "damping-1e4-chain-10",
            "ten links of mass 0.1 under damping 1e4 (c h / m = 1e3), the order-2 base step with more than four constraints (the general multiplier path, the damped fall's exact tangent)",
            "stiff damping and springs",
            include_str!("../../../scenes/stiff_chain.toml").to_owned(),
            // Overdamped: as damping-1e6-strang, H does not rise (measured); the slack is the
            // kick splitting's bound m (g h / 2)² / 2 per body, 10 bodies of 0.1.
            Expect::Stable {
                g_bound: 1e-12,
                energy: EnergyRule::NonIncreasing {
                    slack: 10.0 * 0.1 * (9.81f64 * 0.01 / 2.0).powi(2) / 2.0,
                },
            },
        ),
        scene_case(
            "damping-suzuki4",
            "damping with a named 4th-order composition (backward sub-steps): refused",
            "stiff damping and springs",
            damped_chain_scene(1.0, "suzuki4"),
            Expect::Refused("integrator.scheme"),
        ),
        scene_case(
            "links-1e-6",
            "8-link chain of micrometre links",
            "extreme lengths and mass ratios",
            chain_scene(&[1.0; 8], 1e-6, None, (1e-6f64 / 9.81).sqrt() / 10.0, 200),
            Expect::Stable {
                g_bound: chain_g_bound(1e-6, 8e-6),
                energy: EnergyRule::Bounded { rel: 1e-2 },
            },
        ),
        scene_case(
            "links-1e3",
            "8-link chain of kilometre links",
            "extreme lengths and mass ratios",
            chain_scene(&[1.0; 8], 1e3, None, (1e3f64 / 9.81).sqrt() / 10.0, 200),
            Expect::Stable {
                g_bound: chain_g_bound(1e3, 8e3),
                energy: EnergyRule::Bounded { rel: 1e-2 },
            },
        ),
        // A light body between heavy ones under tension T swings across its rods at
        // ω² = T (1/ℓ₁ + 1/ℓ₂)/m_light: here T ≈ 6 · 9.81 · m_heavy at the top, ω ≈ 3.4e4 for a
        // ratio of 1e±6 and 3.4e5 for 1e±8. RATTLE resolves it for ω h < 2; the steps below
        // keep ω h ≈ 0.3–0.7. The energy: Strang's relative error O((Ω h)²) for the chain's
        // swing (Ω ≈ 3 rad/s) is below 1e-6 with a wide margin.
        scene_case(
            "mass-ratio-1e6",
            "12-link chain, masses alternating 1 and 1e6, h = 2e-5 (the light bodies' frequency across their rods times h: 0.7)",
            "extreme lengths and mass ratios",
            chain_scene(&alternating(1e6), 0.1, None, 2e-5, 1000),
            Expect::Stable {
                g_bound: chain_g_bound(0.1, 1.2),
                energy: EnergyRule::Bounded { rel: 1e-6 },
            },
        ),
        scene_case(
            "mass-ratio-1e-6",
            "12-link chain, masses alternating 1 and 1e-6, h = 1e-5 (frequency times h: 0.34)",
            "extreme lengths and mass ratios",
            chain_scene(&alternating(1e-6), 0.1, None, 1e-5, 1000),
            Expect::Stable {
                g_bound: chain_g_bound(0.1, 1.2),
                energy: EnergyRule::Bounded { rel: 1e-6 },
            },
        ),
        scene_case(
            "mass-ratio-1e6-coarse",
            "the 1e6 chain at h = 1e-3: 34 times past the light bodies' stability limit, must stop typed",
            "extreme lengths and mass ratios",
            chain_scene(&alternating(1e6), 0.1, None, 1e-3, 200),
            Expect::Unstable,
        ),
        scene_case(
            "mass-ratio-1e8",
            "12-link chain, masses alternating 1 and 1e8, h = 2e-6 (frequency times h: 0.7): runs or stops typed",
            "extreme lengths and mass ratios",
            chain_scene(&alternating(1e8), 0.1, None, 2e-6, 1000),
            Expect::StableOrTyped {
                g_bound: chain_g_bound(0.1, 1.2),
            },
        ),
        scene_case(
            "mass-ratio-1e-8",
            "12-link chain, masses alternating 1 and 1e-8, h = 1e-6 (frequency times h: 0.34)",
            "extreme lengths and mass ratios",
            chain_scene(&alternating(1e-8), 0.1, None, 1e-6, 1000),
            Expect::Stable {
                g_bound: chain_g_bound(0.1, 1.2),
                energy: EnergyRule::Bounded { rel: 1e-6 },
            },
        ),
        scene_case(
            "taut-chain",
            "10-link chain pinned at both ends, 1e-6 slack: nearly singular G W^-1 G^T",
            "extreme lengths and mass ratios",
            taut_chain_scene(10, 1e-6),
            Expect::StableOrTyped {
                g_bound: 1e4 * f64::EPSILON * 0.1,
            },
        ),
        scene_case(
            "duplicated-rod",
            "a rod listed twice: redundant constraints are refused by default",
            "redundant constraints",
            chain_scene(&[1.0; 3], 0.5, None, 0.01, 10).replace(
                "[[effects]]",
                "[[constraints]]\ntype = \"rod\"\nbodies = [\"b0\", \"b1\"]\n[[effects]]",
            ),
            Expect::Refused("redundant"),
        ),
        scene_case(
            "redundant-dropped",
            "parallel cranks with a rigid 3-point coupler (one redundant rod), redundant = \"drop-dependent\"",
            "redundant constraints",
            include_str!("../../../scenes/parallel_cranks.toml").to_owned(),
            // The Newton tolerance 16 ε ℓ L (ℓ = 1, L ≈ 2.2) plus rounding; RATTLE's energy
            // error O(h²) at h = 1e-3.
            Expect::Stable {
                g_bound: 64.0 * f64::EPSILON * 2.3,
                energy: EnergyRule::Bounded { rel: 1e-5 },
            },
        ),
        scene_case(
            "forced-resonance",
            "undamped pendulum driven at its small-oscillation frequency (torque 0.3 N m), 60 s: the swing grows past 90 degrees",
            "ports",
            forced_resonance_scene(0.3, 1e-3, 60.0),
            // The budget's error is Strang's O(h²) energy error, ~(ω h)²/24 of the energy
            // exchanged (ω ≈ 3.1, h = 1e-3): 4e-7 relative; bound with a factor 25 for the
            // large swings' higher frequencies.
            Expect::Stable {
                g_bound: 64.0 * f64::EPSILON,
                energy: EnergyRule::Budget { rel: 1e-5 },
            },
        ),
        scene_case(
            "chattering-event",
            "a body in a stiff trap crossing an event plane every 2.5 steps, 1000 steps; a body resting exactly on another event plane",
            "ports",
            chattering_scene(5.0, 1e-3, 1.0),
            // Störmer–Verlet from rest: x_n = cos(n θ), cos θ = 1 − (ω h)²/2 with
            // ω h = 2π/5, so x changes sign after steps n with n θ past π/2 + kπ.
            Expect::Events {
                g_bound: 0.0,
                count: {
                    let wh = 2.0 * std::f64::consts::PI / 5.0;
                    let theta = (1.0 - wh * wh / 2.0).acos();
                    ((1000.0 * theta - std::f64::consts::FRAC_PI_2) / std::f64::consts::PI).floor()
                        as usize
                        + 1
                },
            },
        ),
        StressCase {
            name: "hostile-input",
            about: "NaN, infinite, zero and negative parameters, steps and states: typed, located errors",
            source: "hostile input",
            long: false,
            kind: Kind::Hostile,
        },
    ];
    v.push(StressCase {
        name: "fekete-petrov-galerkin-1e5",
        about: "the Fekete problem (scenes/fekete.toml), the energy-consistent Petrov–Galerkin scheme of order 4, 1e5 steps of h = 0.01",
        source: "IVP test set (Bari), Fekete problem",
        long: false,
        kind: Kind::Scene {
            text: include_str!("../../../scenes/fekete.toml").replace(
                "t_end = 10.0",
                "t_end = 1000.0\nscheme = \"petrov-galerkin\"\norder = 4",
            ),
            // H(x_{n+1}) − H(x_n) = −D_n with D_n ≥ 0 up to the Newton tolerance: each step's
            // balance rounds at a few dozen ε of |H| (|H| ≈ 54 over the run).
            expect: Expect::Stable {
                g_bound: 1e-14,
                energy: EnergyRule::Balanced {
                    slack: 64.0 * f64::EPSILON * 60.0,
                },
            },
        },
    });
    v.push(StressCase {
        name: "paper-1e7",
        about: "the paper's example, 1e7 steps of h = 0.1",
        source: "Zhang & Deng (2004), section 4; very long runs",
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
    v.push(StressCase {
        name: "spherical-pendulum-1e7",
        about: "the spherical pendulum, 1e7 steps of h = 0.01",
        source: "very long runs",
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
pub(super) fn hostile_scenes() -> Vec<(&'static str, String, &'static str)> {
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

pub(super) fn hostile() -> Row {
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
