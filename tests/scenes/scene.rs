//! Scenes: only what is declared is assembled and evaluated; the assembled sub-flows are exact
//! and compose to the promised orders (errors: tests/scenes/scene_errors.rs).

use faer::Col;
use lieflow::flow::FlowExt;
use lieflow::models::pendulum_chain::PendulumChain;
use lieflow::scene::{DEFAULT_SCENE, EffectReport};
use lieflow::{Flow, Hamiltonian, HolonomicConstraint, Vector};

use crate::scene_text;

use scene_text::{parse, run_scene, set};

const ALL_EFFECTS: &str = include_str!("../../scenes/all_effects.toml");

fn counts(effects: &[EffectReport]) -> Vec<(String, u64)> {
    effects
        .iter()
        .map(|e| (e.name.clone(), e.evaluations))
        .collect()
}

/// Removes every `[[effects]]` block of type `kind`.
fn without_effects_of(text: &str, kind: &str) -> String {
    let blocks: Vec<&str> = text.split("\n[[").collect();
    let kept: Vec<&str> = blocks
        .into_iter()
        .filter(|b| !(b.starts_with("effects]]") && b.contains(&format!("type = \"{kind}\""))))
        .collect();
    kept.join("\n[[")
}

#[test]
fn a_switched_off_effect_is_never_evaluated_and_the_run_equals_the_run_without_it() {
    let short = set(ALL_EFFECTS, "t_end", "0.2");
    for (flag, effect, kind) in [
        ("springs", "arm-slider", "spring"),
        ("pair", "coulomb", "pair"),
        ("magnetic", "magnetic", "magnetic"),
    ] {
        // The flag switches off every effect of its kind; the file without them is the
        // reference.
        let off = short.replace("[flags]", &format!("[flags]\n{flag} = false"));
        let removed = without_effects_of(&short, kind);
        assert!(!removed.contains(&format!("type = \"{kind}\"")));
        assert!(short.contains(&format!("type = \"{kind}\"")));
        let a = run_scene(&parse(&off));
        let b = run_scene(&parse(&removed));
        assert_eq!(a.steps, 40 * 5);
        assert_eq!(a.error, None);
        // Bit for bit: the same terms in the same order.
        assert_eq!(a.x.len(), b.x.len());
        for (u, v) in a.x.iter().zip(&b.x) {
            assert_eq!(u.to_bits(), v.to_bits(), "{flag}: {u} vs {v}");
        }
        assert_eq!(counts(&a.effects), counts(&b.effects), "{flag}");
        assert!(
            a.effects.iter().all(|e| e.kind != kind),
            "{flag}: an effect of kind {kind} was assembled: {:?}",
            a.effects
        );
        // And with it on, it is evaluated.
        let on = run_scene(&parse(&short));
        let n = on.effects.iter().find(|e| e.name == effect).unwrap();
        assert!(n.evaluations > 0);
    }
}

#[test]
fn every_declared_effect_is_evaluated_and_constraints_hold_at_round_off() {
    let s = run_scene(&parse(&set(ALL_EFFECTS, "t_end", "0.5")));
    assert_eq!(s.error, None);
    assert_eq!(s.steps, 500);
    for e in &s.effects {
        assert!(e.evaluations > 0, "{} never evaluated", e.name);
    }
    // Rods of length 0.4 and spheres of radius 0.5 at positions of size ~3: |g| is a few ulps
    // of |q|².
    assert!(
        s.max_abs_g.unwrap() < 64.0 * f64::EPSILON * 9.0,
        "{:?}",
        s.max_abs_g
    );
    assert!(s.max_abs_phi.unwrap() < 1e-12, "{:?}", s.max_abs_phi);
}

/// The chain of the built-in model and the same chain as a scene: the same equations, the same
/// RATTLE splitting; they agree to the Newton tolerance accumulated over the run.
#[test]
fn a_chain_scene_runs_the_built_in_chain() {
    let links = 8;
    let angle = 0.5f64;
    let text = format!(
        r#"
        version = 1
        dim = 2
        [[chains]]
        name = "c"
        links = {links}
        direction = [{}, {}]
        length = {}
        mass = 1.0
        [[effects]]
        type = "gravity"
        g = [0.0, -1.0]
        [integrator]
        dt = 0.01
        t_end = 2.0
        "#,
        angle.sin(),
        -angle.cos(),
        1.0 / links as f64
    );
    let s = run_scene(&parse(&text));
    let chain = PendulumChain::<f64>::uniform(2, links).unwrap();
    let mut x: Col<f64> = chain.at_rest(|_| angle);
    let mut flow = chain
        .kick()
        .strang(chain.drift())
        .projected(chain.system(), &x, chain.projection_options())
        .unwrap();
    for _ in 0..200 {
        flow.step(0.01, &mut x).unwrap();
    }
    let diff =
        s.x.iter()
            .zip(x.as_slice())
            .fold(0.0f64, |a, (u, v)| a.max((u - v).abs()));
    // Both solve the same multiplier equations to a tolerance of ~16 ε l L per step.
    assert!(diff < 1e-11, "scene vs built-in chain: {diff:e}");
    // The energies agree too.
    let e_builtin = chain.energy(&x);
    assert!((s.energy_final.unwrap() - e_builtin).abs() < 1e-11);
}

/// A charged particle in a uniform field with damping: the free flight is exact, so any step
/// size reproduces the closed form `v(t) = v₀ e^{(−γ − iω) t}` (complex notation, `ω = eB/m`,
/// `γ = c/m`) to round-off.
#[test]
fn the_magnetic_and_damped_free_flight_is_exact() {
    let (m, e, bz, c) = (2.0, 1.5, 0.7, 0.3);
    let (vx, vy) = (0.4, -1.1);
    for damping in [0.0, c] {
        let text = format!(
            r#"
            version = 1
            dim = 2
            [[bodies]]
            name = "ion"
            mass = {m}
            charge = {e}
            position = [0.1, 0.2]
            velocity = [{vx}, {vy}]
            [[effects]]
            type = "magnetic"
            field = [{bz}]
            [[effects]]
            type = "damping"
            coefficient = {damping}
            [integrator]
            dt = 0.37
            t_end = 37.0
            "#
        );
        let s = run_scene(&parse(&text));
        let t = s.t;
        let (w, g) = (e * bz / m, damping / m);
        // z = −γ − iω; e^{zt} = e^{−γt}(cos ωt − i sin ωt).
        let (er, ei) = (
            (-g * t).exp() * (w * t).cos(),
            -(-g * t).exp() * (w * t).sin(),
        );
        let v = (vx * er - vy * ei, vx * ei + vy * er);
        // (e^{zt} − 1)/z.
        let (nr, ni) = (er - 1.0, ei);
        let den = g * g + w * w;
        let (ar, ai) = ((nr * -g + ni * -w) / den, (ni * -g - nr * -w) / den);
        let q = (0.1 + vx * ar - vy * ai, 0.2 + vx * ai + vy * ar);
        let expect = [q.0, q.1, m * v.0, m * v.1];
        for (a, b) in s.x.iter().zip(expect) {
            assert!((a - b).abs() < 1e-13, "{:?} vs {expect:?}", s.x);
        }
        if damping == 0.0 {
            assert!(s.max_abs_energy_error.unwrap() < 1e-14);
        } else {
            assert!(s.max_energy_increase.unwrap() <= 0.0);
        }
    }
}

/// In 3D with the field along an arbitrary axis, the flight is the 2D one in the plane across
/// the field, rotated, plus uniform (damped) motion along it.
#[test]
fn the_3d_flight_is_the_rotated_planar_one() {
    let bhat = {
        let b = [1.0f64, -2.0, 0.5];
        let n = (b[0] * b[0] + b[1] * b[1] + b[2] * b[2]).sqrt();
        b.map(|x| x / n)
    };
    // An orthonormal frame (u, w, b̂) with u × w = b̂.
    let u = {
        let a = [0.0, 0.0, 1.0];
        let c = cross(a, bhat);
        let n = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
        c.map(|x| x / n)
    };
    let w = cross(bhat, u);
    let (bmag, v2, vpar) = (0.9, [0.3, -0.8], 0.25);
    let v3: Vec<f64> = (0..3)
        .map(|k| v2[0] * u[k] + v2[1] * w[k] + vpar * bhat[k])
        .collect();
    let scene3 = format!(
        r#"
        version = 1
        dim = 3
        [[bodies]]
        name = "ion"
        mass = 1.0
        charge = 1.0
        position = [0.0, 0.0, 0.0]
        velocity = [{}, {}, {}]
        [[effects]]
        type = "magnetic"
        field = [{}, {}, {}]
        [[effects]]
        type = "damping"
        coefficient = 0.2
        [integrator]
        dt = 0.5
        t_end = 10.0
        "#,
        v3[0],
        v3[1],
        v3[2],
        bmag * bhat[0],
        bmag * bhat[1],
        bmag * bhat[2]
    );
    let scene2 = format!(
        r#"
        version = 1
        dim = 2
        [[bodies]]
        name = "ion"
        mass = 1.0
        charge = 1.0
        position = [0.0, 0.0]
        velocity = [{}, {}]
        [[effects]]
        type = "magnetic"
        field = [{bmag}]
        [[effects]]
        type = "damping"
        coefficient = 0.2
        [integrator]
        dt = 0.5
        t_end = 10.0
        "#,
        v2[0], v2[1]
    );
    let a = run_scene(&parse(&scene3));
    let b = run_scene(&parse(&scene2));
    let t = a.t;
    let par = vpar * (1.0 - (-0.2 * t).exp()) / 0.2;
    for k in 0..3 {
        let q = b.x[0] * u[k] + b.x[1] * w[k] + par * bhat[k];
        let p = b.x[2] * u[k] + b.x[3] * w[k] + vpar * (-0.2 * t).exp() * bhat[k];
        assert!((a.x[k] - q).abs() < 1e-13, "q[{k}]");
        assert!((a.x[3 + k] - p).abs() < 1e-13, "p[{k}]");
    }
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Every term's gradient is the derivative of its energy, and its Hessian product the derivative
/// of its gradient (central differences, error `O(δ²)`): the projection's Newton matrices and
/// the kick rely on them.
#[test]
fn gradients_and_hessians_of_every_term_match_finite_differences() {
    let flags_off_damping = ALL_EFFECTS.replace("[flags]", "[flags]\ndamping = false");
    let c = parse(&flags_off_damping).compile().unwrap();
    let model = c.model.unwrap();
    let x0 = Col::<f64>::from_fn(c.simulation.state().len(), |i| {
        c.simulation.state()[i] + 0.01 * ((i * 7 % 11) as f64 - 5.0) / 5.0
    });
    let n = x0.nrows();
    let mut grad = Col::<f64>::zeros(n);
    model.gradient(&x0, &mut grad);
    let delta = 1e-5;
    for i in 0..n {
        let (mut a, mut b) = (x0.clone(), x0.clone());
        a[i] += delta;
        b[i] -= delta;
        let fd = (model.energy(&a) - model.energy(&b)) / (2.0 * delta);
        assert!(
            (fd - grad[i]).abs() < 1e-6 * (1.0 + grad[i].abs()),
            "gradient {i}: {fd} vs {}",
            grad[i]
        );
    }
    let v = Col::<f64>::from_fn(n, |i| ((i * 5 % 13) as f64 - 6.0) / 6.0);
    let mut hv = Col::<f64>::zeros(n);
    assert!(model.hessian_apply(&x0, &v, &mut hv));
    let (mut a, mut b) = (x0.clone(), x0.clone());
    for i in 0..n {
        a[i] += delta * v[i];
        b[i] -= delta * v[i];
    }
    let (mut ga, mut gb) = (Col::<f64>::zeros(n), Col::<f64>::zeros(n));
    model.gradient(&a, &mut ga);
    model.gradient(&b, &mut gb);
    let scale = hv.as_slice().iter().fold(1.0f64, |m, x| m.max(x.abs()));
    for i in 0..n {
        let fd = (ga[i] - gb[i]) / (2.0 * delta);
        assert!(
            (fd - hv[i]).abs() < 1e-5 * scale,
            "Hessian {i}: {fd} vs {}",
            hv[i]
        );
    }
    // ⟨G v, μ⟩ = ⟨v, Gᵀ μ⟩ and G v against differences of g.
    let m = HolonomicConstraint::<Col<f64>>::dim(&model);
    let mu: Vec<f64> = (0..m).map(|j| (j as f64 - 3.0) / 4.0).collect();
    let mut gv = vec![0.0; m];
    model.jacobian_apply(&x0, &v, &mut gv);
    let mut gtmu = Col::<f64>::zeros(n);
    model.jacobian_transpose_apply_add(&x0, &mu, 1.0, &mut gtmu);
    let lhs: f64 = gv.iter().zip(&mu).map(|(a, b)| a * b).sum();
    let rhs: f64 = (0..n).map(|i| v[i] * gtmu[i]).sum();
    assert!((lhs - rhs).abs() < 1e-13 * (1.0 + lhs.abs()));
    let (mut ra, mut rb) = (vec![0.0; m], vec![0.0; m]);
    model.residual(&a, &mut ra);
    model.residual(&b, &mut rb);
    for j in 0..m {
        let fd = (ra[j] - rb[j]) / (2.0 * delta);
        assert!((fd - gv[j]).abs() < 1e-8, "G v row {j}: {fd} vs {}", gv[j]);
    }
    // Every constraint is quadratic (rods, spheres) or affine (plane, pin): for a finite step
    // `v`, g(x + v) = g(x) + G v + ½ vᵀ∇²g v exactly, to the rounding of the evaluations.
    let mut hgv = vec![0.0; m];
    assert!(model.hessian_form(&x0, &v, &v, &mut hgv));
    let mut xv = x0.clone();
    for i in 0..n {
        xv[i] += v[i];
    }
    let (mut g0, mut g1) = (vec![0.0; m], vec![0.0; m]);
    model.residual(&x0, &mut g0);
    model.residual(&xv, &mut g1);
    let size = (0..n).fold(1.0f64, |s, i| s.max(x0[i].abs()).max(xv[i].abs()));
    for j in 0..m {
        let taylor = g0[j] + gv[j] + 0.5 * hgv[j];
        assert!(
            (g1[j] - taylor).abs() <= 16.0 * f64::EPSILON * size * size,
            "row {j}: g(x + v) = {} against the quadratic expansion {taylor}",
            g1[j]
        );
    }
}

/// Convergence orders of composed scenes: an unconstrained one (springs, pair potential, trap
/// and a magnetic field) and a constrained one (a spring-coupled double pendulum), each with
/// Strang and its order-4 composition, against a run at a much smaller step.
#[test]
fn composed_scenes_reach_their_orders() {
    let free = r#"
        version = 1
        dim = 2
        [[grids]]
        name = "g"
        spacing = 1.0
        counts = [2, 2]
        mass = 1.0
        charge = 1.0
        velocity = [0.3, -0.2]
        [[effects]]
        type = "pair"
        law = "inverse-power"
        strength = 0.5
        [[effects]]
        type = "trap"
        stiffness = 2.0
        center = [0.5, 0.5]
        [[effects]]
        type = "magnetic"
        field = [1.3]
        [integrator]
        order = 2
        dt = 0.1
        t_end = 2.0
    "#;
    let pendulum = r#"
        version = 1
        dim = 2
        [[chains]]
        name = "c"
        links = 2
        direction = [1.0, -0.3]
        length = 1.0
        mass = 1.0
        [[bodies]]
        name = "b"
        mass = 0.5
        position = [2.5, 0.0]
        [[effects]]
        type = "gravity"
        g = [0.0, -9.81]
        [[effects]]
        type = "spring"
        bodies = ["c.1", "b"]
        stiffness = 3.0
        [integrator]
        order = 2
        dt = 0.1
        t_end = 2.0
    "#;
    for text in [free, pendulum] {
        for order in [2u32, 4] {
            let with_order = set(text.trim_start(), "        order", &order.to_string());
            let at = |dt: f64| {
                let mut s = parse(&with_order);
                s.file.integrator.dt = dt;
                run_scene(&s).x
            };
            let reference = at(1.0 / 1280.0);
            let hs = [0.1, 0.05, 0.025, 0.0125];
            let errs: Vec<f64> = hs
                .iter()
                .map(|&h| {
                    at(h)
                        .iter()
                        .zip(&reference)
                        .fold(0.0f64, |a, (u, v)| a.max((u - v).abs()))
                })
                .collect();
            let slope = fit_slope(&hs, &errs);
            assert!(
                (slope - order as f64).abs() < 0.3,
                "order {order}: slope {slope}, errors {errs:?}"
            );
        }
    }
}

fn fit_slope(h: &[f64], e: &[f64]) -> f64 {
    let xs: Vec<f64> = h.iter().map(|x| x.ln()).collect();
    let ys: Vec<f64> = e.iter().map(|x| x.ln()).collect();
    let n = xs.len() as f64;
    let (mx, my) = (xs.iter().sum::<f64>() / n, ys.iter().sum::<f64>() / n);
    let sxy: f64 = xs.iter().zip(&ys).map(|(x, y)| (x - mx) * (y - my)).sum();
    let sxx: f64 = xs.iter().map(|x| (x - mx) * (x - mx)).sum();
    sxy / sxx
}

#[test]
fn with_damping_the_energy_never_increases_and_its_budget_closes() {
    // The default scene: Strang with the exact damping flow, positive sub-steps only. Per step
    // the energy changes by −h·(dissipated power) + O(h³) splitting error; with this scene's
    // damping the first dominates, so H decreases at every step, and H + (dissipated energy)
    // stays at H₀ up to the trapezoidal quadrature's O(h²).
    let s = run_scene(&parse(&set(DEFAULT_SCENE, "t_end", "2.0")));
    assert_eq!(s.error, None);
    assert!(
        s.max_energy_increase.unwrap() <= 0.0,
        "{:?}",
        s.max_energy_increase
    );
    assert!(s.dissipated.unwrap() > 1.0);
    assert!(s.max_energy_balance_error.unwrap() < 1e-5 * s.dissipated.unwrap());
    // The discrete gradient makes the decrease structural, whatever the splitting error.
    let dg = set(DEFAULT_SCENE, "scheme", "\"discrete-gradient\"");
    let s = run_scene(&parse(&set(&dg, "t_end", "0.2")));
    assert_eq!(s.error, None);
    assert!(s.max_energy_increase.unwrap() <= 0.0);
    assert!(s.max_abs_g.unwrap() < 1e-14);
}

#[test]
fn time_shares_are_shares_of_the_run() {
    let text = set(ALL_EFFECTS, "t_end", "0.2").replace(
        "diagnostics = [\"energy\", \"constraints\"]",
        "diagnostics = [\"energy\", \"constraints\", \"profile\"]",
    );
    let s = run_scene(&parse(&text));
    let total: f64 = s.effects.iter().filter_map(|e| e.time_share).sum();
    assert!(total > 0.0 && total <= 1.0, "{total}");
}

/// A splitting of 4, 6, 8 or 12 state entries runs on a stack state (`SVector`); the same
/// splitting on a heap column (`heap_splitting`, what every larger scene runs) agrees
/// with it step for step — base and extrapolated, planar and in space, with damping and a field —
/// to the round-off the two storages' different operation order can accumulate over the run
/// (`64 ε` per step relative to the state).
#[test]
fn small_scenes_on_the_stack_agree_with_the_heap_column() {
    use lieflow::scene::{Raise, heap_splitting};
    let pendulum = include_str!("../../scenes/damped_pendulum.toml");
    let double_3d = r#"
        version = 1
        dim = 3
        [[bodies]]
        name = "a"
        mass = 1.0
        position = [0.6, -0.8, 0.0]
        velocity = [0.0, 0.0, 0.5]
        charge = 1.0
        [[bodies]]
        name = "b"
        mass = 2.0
        position = [0.6, -1.8, 0.0]
        velocity = [0.3, 0.0, 0.0]
        [[constraints]]
        type = "rod"
        bodies = ["a"]
        point = [0.0, 0.0, 0.0]
        length = 1.0
        [[constraints]]
        type = "rod"
        bodies = ["a", "b"]
        length = 1.0
        [[effects]]
        type = "gravity"
        g = [0.0, -9.81, 0.0]
        [[effects]]
        type = "damping"
        coefficient = 0.3
        [[effects]]
        type = "magnetic"
        field = [0.0, 0.0, 0.7]
        [integrator]
        dt = 0.01
        t_end = 1.0
        "#;
    let cases = [
        (pendulum.to_owned(), 4, Raise::Base),
        (
            pendulum.replace("[integrator]", "[integrator]\norder = 4"),
            4,
            Raise::Extrapolate(4),
        ),
        (double_3d.to_owned(), 12, Raise::Base),
    ];
    for (text, n, raise) in cases {
        let compiled = parse(&text).compile().unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(compiled.assembly.state_len, n);
        let mut sim = compiled.simulation;
        let model = compiled.model.expect("a scene model");
        let mut x = Col::<f64>::zeros(n);
        x.as_mut_slice().copy_from_slice(sim.state());
        let (mut heap, _, _) = heap_splitting(&model, &x, raise.clone(), false).expect("a flow");
        let steps = 300;
        let mut worst = 0.0f64;
        for _ in 0..steps {
            sim.step().expect("a stack step");
            heap.step(sim.dt(), &mut x).expect("a heap step");
            let scale = x.as_slice().iter().fold(1.0f64, |s, v| s.max(v.abs()));
            let gap = (0..n)
                .map(|i| (sim.state()[i] - x.as_slice()[i]).abs())
                .fold(0.0, f64::max);
            worst = worst.max(gap / scale);
        }
        let bound = 64.0 * f64::EPSILON * steps as f64;
        assert!(
            worst <= bound,
            "n = {n}, {raise:?}: the stack and heap runs differ by {worst:.2e} (> {bound:.1e})"
        );
        println!("n = {n}, {raise:?}: stack against heap {worst:.1e}");
    }
}
