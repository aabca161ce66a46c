//! Scene texts the cases are built from: chains with given masses, damped and stiff chains,
//! stiff springs, a taut chain with little slack.

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

pub(super) fn alternating(ratio: f64) -> Vec<f64> {
    (0..12)
        .map(|i| if i % 2 == 0 { 1.0 } else { ratio })
        .collect()
}

/// A pendulum (`L = 1`, `g = 9.81`) driven at its small-oscillation frequency by a torque of
/// `amplitude` about its pivot, undamped: the swing grows until the nonlinearity detunes it.
pub fn forced_resonance_scene(amplitude: f64, dt: f64, t_end: f64) -> String {
    format!(
        r#"version = 1
dim = 2
[[bodies]]
name = "bob"
mass = 1.0
position = [0.0, -1.0]
[[constraints]]
type = "rod"
bodies = ["bob"]
point = [0.0, 0.0]
[[effects]]
type = "gravity"
g = [0.0, -9.81]
[[inputs]]
type = "torque"
name = "drive"
body = "bob"
pivot = [0.0, 0.0]
signal = {{ type = "sine", amplitude = {amplitude:e}, omega = {:e} }}
[integrator]
dt = {dt:e}
t_end = {t_end:e}
"#,
        9.81f64.sqrt()
    )
}

/// A body in a stiff trap (`ω h = 2π / steps_per_period`) released at `x = 1`, crossing the
/// plane `x = 0` every half period: a recorded event in almost every step; and a body at rest
/// exactly on the plane `y = 0`, whose event function is zero throughout and never crosses.
pub fn chattering_scene(steps_per_period: f64, dt: f64, t_end: f64) -> String {
    let omega = 2.0 * std::f64::consts::PI / (steps_per_period * dt);
    format!(
        r#"version = 1
dim = 2
[[bodies]]
name = "fast"
mass = 1.0
position = [1.0, 1.0]
[[bodies]]
name = "still"
mass = 1.0
position = [5.0, 0.0]
[[effects]]
type = "trap"
stiffness = {:e}
center = [0.0, 1.0]
bodies = ["fast"]
[[events]]
name = "cross"
body = "fast"
plane = {{ normal = [1.0, 0.0] }}
[[events]]
name = "resting"
body = "still"
plane = {{ normal = [0.0, 1.0] }}
[integrator]
dt = {dt:e}
t_end = {t_end:e}
"#,
        omega * omega
    )
}
