//! Fekete's problem (Hairer & Wanner's DAE test set): 20 charged particles on the unit sphere
//! relaxing to the Fekete points, with the reference positions and the scene that poses it.

use super::{Check, EnergyRule, Measured, Row, energy_check, measured_row, refused_row, simulate};
use lieflow::scene::{Compiled, Scene};

/// Particles of the Fekete problem.
pub(super) const FEKETE_N: usize = 20;

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

pub(super) fn fekete() -> Row {
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
