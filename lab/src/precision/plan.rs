//! What a work–precision set runs and what it returns: the plan, the reference, one row
//! per run; the helpers the lieflow and peer runs share.

use lieflow::scene::Scene;
use lieflow::scene::schema::Method;
use serde::Serialize;

/// What to run.
#[derive(Debug, Clone, PartialEq)]
pub struct PrecisionPlan {
    /// Step sizes for every lieflow scheme.
    pub dts: Vec<f64>,
    /// Orders of the projected splitting (2 = Strang; 4, 6, 8 = Suzuki 4, Kahan–Li 6,
    /// Kahan–Li 8, or for scenes with damping the splitting extrapolated to that order, every
    /// sub-step forward).
    pub orders: Vec<u32>,
    /// Also run the discrete gradient (scenes of bodies).
    pub discrete_gradient: bool,
    /// Also run the projection around the implicit midpoint rule (scenes with a state of at
    /// most [`DENSE_MAX_DIM`], the paper's model).
    pub midpoint: bool,
    /// Also run the paper's §2 scheme (the built-in paper model only).
    pub modified: bool,
    /// Orders of the energy-consistent Petrov–Galerkin scheme to run (scenes of bodies; a
    /// scene above its dense limit gets a `Setup` row).
    pub petrov_galerkin: Vec<u32>,
    /// Tolerances (`rtol = atol`) for the peers and for lieflow's adaptive extrapolation.
    pub tolerances: Vec<f64>,
    /// Also run lieflow's adaptive extrapolation of the splitting at every tolerance (scenes of
    /// bodies): one report interval over the whole run, the steps and orders chosen inside.
    pub adaptive: bool,
    /// Run the peers (needs the `peers` feature; otherwise no peer rows).
    pub peers: bool,
    /// Timed runs after the warm-up.
    pub repeats: usize,
    /// Compute the reference in double-double for scenes of at most [`DD_MAX_DIM`] (else in
    /// double precision).
    pub double_double: bool,
    /// The motion is periodic and the final time a whole number of periods: the reference is
    /// the initial state (exact).
    pub periodic: bool,
    /// Compute the reference with the Petrov–Galerkin scheme of order 6 in double precision at
    /// `h_min/8` and `h_min/16` (stiff damping: the splitting's expansion in `h²` breaks down).
    pub implicit_reference: bool,
}

impl PrecisionPlan {
    /// Four step sizes `dt · 2^k`, the largest `k ≤ 3` whose steps divide `t_end`; orders 2,
    /// 4, 6, 8; the implicit schemes (Petrov–Galerkin of orders 4 and 6); tolerances `1e-4 …
    /// 1e-14` (every second decade) for the peers and the adaptive extrapolation; three timed
    /// runs.
    pub fn around(dt: f64, t_end: f64) -> Self {
        let divides = |h: f64| {
            let n = t_end / h;
            n >= 1.0 && (n - n.round()).abs() <= 1e-9 * n
        };
        let mut dts: Vec<f64> = (-3..=3)
            .rev()
            .map(|k| dt * 2f64.powi(k))
            .filter(|&h| divides(h))
            .take(4)
            .collect();
        if dts.is_empty() {
            dts.push(dt);
        }
        Self {
            dts,
            orders: vec![2, 4, 6, 8],
            discrete_gradient: true,
            midpoint: true,
            modified: true,
            petrov_galerkin: vec![4, 6],
            tolerances: vec![1e-4, 1e-6, 1e-8, 1e-10, 1e-12, 1e-14],
            adaptive: true,
            peers: true,
            repeats: 3,
            double_double: true,
            periodic: false,
            implicit_reference: false,
        }
    }
}

/// The reference solution at the final time.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Reference {
    /// The state at `t`.
    pub x: Vec<f64>,
    /// The time.
    pub t: f64,
    /// Where it comes from, e.g. `closed form` or `kahan-li8 at h = …, Richardson-checked`.
    pub source: String,
    /// Its own error estimate (max-norm), `None` for a closed form.
    pub error_estimate: Option<f64>,
}

/// One run of a work–precision set.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PrecisionRow {
    /// `projection order 2`, `projection order 8`, `discrete gradient`, `DOP853 (index-1 ODE)`, …
    pub method: String,
    /// The step size (lieflow) …
    pub dt: Option<f64>,
    /// … or the tolerance (peers).
    pub tol: Option<f64>,
    /// `ok`, or the error's kind (`Newton`, `NonFinite`, `Setup`, `Skipped`, …).
    pub status: String,
    /// What failed, if anything.
    pub message: String,
    /// Max-norm error of the final state against the reference.
    pub error: Option<f64>,
    /// `max |g|` over the run (at the peers' accepted steps).
    pub max_abs_g: Option<f64>,
    /// `max |φ|` over the run.
    pub max_abs_phi: Option<f64>,
    /// `max |H − H₀|`, or with damping `max |H − H₀ + dissipated|`.
    pub energy_error: Option<f64>,
    /// Steps (accepted steps for the peers).
    pub steps: u64,
    /// Multiplier-residual evaluations (lieflow) or right-hand-side evaluations (peers).
    pub evaluations: u64,
    /// Newton iterations.
    pub newton_iterations: u64,
    /// Factorizations of Newton matrices (peers: LU decompositions).
    pub factorizations: u64,
    /// Minimum wall time of the timed runs, seconds.
    pub time_min: Option<f64>,
    /// Median wall time of the timed runs, seconds.
    pub time_median: Option<f64>,
}

impl PrecisionRow {
    pub(crate) fn failed(
        method: &str,
        dt: Option<f64>,
        tol: Option<f64>,
        status: &str,
        message: String,
    ) -> Self {
        Self {
            method: method.to_owned(),
            dt,
            tol,
            status: status.to_owned(),
            message,
            error: None,
            max_abs_g: None,
            max_abs_phi: None,
            energy_error: None,
            steps: 0,
            evaluations: 0,
            newton_iterations: 0,
            factorizations: 0,
            time_min: None,
            time_median: None,
        }
    }
}

/// `true` for the built-in paper model.
pub(crate) fn is_paper(scene: &Scene) -> bool {
    scene
        .file
        .builtin
        .as_ref()
        .is_some_and(|b| b.model == "paper")
}

/// Max-norm distance.
pub(crate) fn distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
}

/// `(min, median)` of the times.
pub(crate) fn min_median(mut times: Vec<f64>) -> (Option<f64>, Option<f64>) {
    if times.is_empty() {
        return (None, None);
    }
    times.sort_by(f64::total_cmp);
    let k = times.len();
    let median = if k % 2 == 1 {
        times[k / 2]
    } else {
        0.5 * (times[k / 2 - 1] + times[k / 2])
    };
    (Some(times[0]), Some(median))
}

pub(crate) fn with_scheme(scene: &Scene, scheme: Method, order: Option<u32>, dt: f64) -> Scene {
    let mut s = scene.clone();
    s.file.integrator.scheme = scheme;
    s.file.integrator.order = order;
    s.file.integrator.dt = dt;
    s.file.integrator.tol = None;
    s.file.integrator.rtol = None;
    s.file.integrator.atol = None;
    s
}

/// `scene` run by the adaptive extrapolation of its splitting at `tol` (`rtol = atol`), its
/// whole run one report interval: the controller chooses every step and order.
pub(crate) fn with_tolerance(scene: &Scene, tol: f64) -> Scene {
    let mut s = with_scheme(scene, Method::Auto, None, scene.file.integrator.t_end);
    s.file.integrator.tol = Some(tol);
    s
}

/// The final time of the scene: `round(t_end/dt) · dt` is what a run reaches; the plan's step
/// sizes must all divide `t_end` (checked by [`work_precision`]).
pub(crate) fn final_time(scene: &Scene) -> f64 {
    scene.file.integrator.t_end
}
