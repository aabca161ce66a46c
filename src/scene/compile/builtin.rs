//! Scenes that name a built-in model (`builtin = { model = "paper" }` and the others)
//! instead of declaring bodies.

use super::{
    Assembly, CANONICAL, Compiled, MAX_BODIES, Result, err, initial_state_error,
    scheme::{choose_scheme, plan, with_table},
};
use crate::error::SetupError;
use crate::flow::{
    CompositionTable, Flow, FlowExt, ImplicitMidpoint, ProjectedMidpoint, ProjectionOptions,
};
use crate::nonlinear::NewtonOptions;
use crate::scene::error::{FieldPath, SceneErrorKind};
use crate::scene::run::{ModelRun, Simulation};
use crate::scene::schema::{Builtin, Method, Redundant, SceneFile};
use crate::system::{System, Unconstrained};
use faer::Col;

/// The built-in models, with the scene's integrator.
pub(super) fn compile_builtin(file: &SceneFile, b: &Builtin) -> Result<Compiled> {
    use crate::models::{
        paper, pendulum_chain::PendulumChain, spherical_pendulum::SphericalPendulum,
    };
    use nalgebra::SVector;
    let path = FieldPath::root().key("builtin");
    let (run_plan, profile) = plan(&file.integrator, &file.flags)?;
    let steps = run_plan.total_steps();
    // What a built-in model does not use is an error, not silently ignored.
    let unused = |what: &str, at: FieldPath| {
        Err(err(
            SceneErrorKind::Unsupported,
            at,
            format!("{what} does not apply to a built-in model"),
        ))
    };
    let root = FieldPath::root();
    if file.dim.is_some() {
        return unused("`dim` (use `builtin.dim` for the chain)", root.key("dim"));
    }
    if file.integrator.project_initial {
        return unused(
            "`project_initial`",
            root.key("integrator").key("project_initial"),
        );
    }
    if file.integrator.redundant != Redundant::Refuse {
        return unused("`redundant`", root.key("integrator").key("redundant"));
    }
    if profile {
        return unused(
            "the `profile` diagnostic",
            root.key("integrator").key("diagnostics"),
        );
    }
    let f = &file.flags;
    if !(f.gravity && f.springs && f.pair && f.trap && f.damping && f.magnetic && f.constraints) {
        return unused("switching effects or constraints off", root.key("flags"));
    }
    if b.model != "pendulum-chain" && (b.links.is_some() || b.dim.is_some()) {
        return unused(
            "`links` and `dim` (only the chain has them)",
            path.key("links"),
        );
    }
    let (raise, order) = choose_scheme(&file.integrator, false, None)?;
    if raise.is_controlled() {
        let key = ["tol", "rtol", "atol"]
            .into_iter()
            .zip([
                file.integrator.tol,
                file.integrator.rtol,
                file.integrator.atol,
            ])
            .find_map(|(k, v)| v.map(|_| k))
            .unwrap_or("tol");
        return Err(err(
            SceneErrorKind::Unsupported,
            FieldPath::root().key("integrator").key(key),
            "a tolerance is for scenes of bodies; the built-in models take a fixed `dt`",
        ));
    }
    let table = raise.table();
    let scheme = file.integrator.scheme;
    if scheme == Method::DiscreteGradient
        || scheme == Method::Extrapolation
        || scheme == Method::PetrovGalerkin
        || (b.model != "paper" && matches!(scheme, Method::Midpoint | Method::Modified))
    {
        return Err(err(
            SceneErrorKind::Unsupported,
            FieldPath::root().key("integrator").key("scheme"),
            format!(
                "the built-in model '{}' does not offer the scheme '{scheme}'",
                b.model
            ),
        ));
    }
    let dt = file.integrator.step();
    let setup = |e: SetupError| err(SceneErrorKind::Setup, path.clone(), e.to_string());
    let compose = |t: Option<&'static CompositionTable>, name: &str| match t {
        None => name.to_owned(),
        Some(t) => format!("{name} composed by {} ({} stages)", t.name, t.stages),
    };
    let (simulation, assembly): (Box<dyn Simulation>, Assembly) = match b.model.as_str() {
        "paper" => {
            type V = SVector<f64, 4>;
            let x0: V = paper::initial_state();
            let (flow, inner): (Box<dyn Flow<V>>, &str) = match file.integrator.scheme {
                // The paper's §2 scheme: projection around the flow of H_N1 = H + μ g by the
                // implicit midpoint rule.
                // The midpoint increment and λ_k are solved as one Newton system
                // (ProjectedMidpoint: the same map as Projected around ImplicitMidpoint).
                Method::Modified => {
                    let p = ProjectedMidpoint::<V, _, _>::try_new(
                        paper::system(),
                        paper::modified_energy(),
                        &x0,
                        ProjectionOptions::default(),
                    )
                    .map_err(setup)?;
                    (
                        with_table(p, table),
                        "§2: projection around the implicit midpoint rule for H + μ g",
                    )
                }
                Method::Midpoint => {
                    let p = ProjectedMidpoint::<V, _, _>::try_new(
                        paper::system(),
                        paper::Energy,
                        &x0,
                        ProjectionOptions::default(),
                    )
                    .map_err(setup)?;
                    (
                        with_table(p, table),
                        "projection around the implicit midpoint rule",
                    )
                }
                _ => {
                    let p = paper::drift()
                        .projected(paper::system(), &x0, ProjectionOptions::default())
                        .map_err(setup)?;
                    (with_table(p, table), "projection around the drift (exact)")
                }
            };
            let assembly = builtin_assembly(
                file,
                "Zhang & Deng (2004) §4",
                4,
                1,
                "J non-canonical (the paper's state-dependent structure matrix)",
                compose(table, inner),
                order,
                steps,
            );
            (
                Box::new(
                    ModelRun::new(flow, paper::system(), x0, dt, 1, None)
                        .map_err(initial_state_error)?,
                ),
                assembly,
            )
        }
        "rigid-body" => {
            use crate::models::RigidBody;
            type V = SVector<f64, 3>;
            if table.is_some() {
                let field = if file.integrator.scheme == Method::Auto {
                    "order"
                } else {
                    "scheme"
                };
                return Err(err(
                    SceneErrorKind::Unsupported,
                    FieldPath::root().key("integrator").key(field),
                    "the rigid body runs the implicit midpoint rule (order 2) only",
                ));
            }
            let body = RigidBody::<f64>::gni();
            let y0: V = RigidBody::gni_initial_state();
            let flow: Box<dyn Flow<V>> = Box::new(
                ImplicitMidpoint::<V, _, _>::try_new(
                    body.structure(),
                    body,
                    &y0,
                    NewtonOptions::default(),
                )
                .map_err(setup)?,
            );
            let mut assembly = builtin_assembly(
                file,
                "free rigid body (Lie-Poisson, GNI constants)",
                3,
                0,
                "J non-canonical (Lie–Poisson, the rigid body's angular momentum)",
                "implicit midpoint rule".to_owned(),
                2,
                steps,
            );
            assembly.constraints.clear();
            assembly.case = None;
            let system = System::new(body.structure(), body, Unconstrained);
            (
                Box::new(
                    ModelRun::new(flow, system, y0, dt, 0, None).map_err(initial_state_error)?,
                ),
                assembly,
            )
        }
        "spherical-pendulum" => {
            type V = SVector<f64, 6>;
            let pend = SphericalPendulum::try_new(1.0, 1.0, 9.81).expect("valid constants");
            let x0: V = pend.state(1.0, 1.0);
            let p = pend
                .kick()
                .strang(pend.drift())
                .projected(pend.system(), &x0, ProjectionOptions::default())
                .map_err(setup)?;
            let flow: Box<dyn Flow<V>> = with_table(p, table);
            let assembly = builtin_assembly(
                file,
                "spherical pendulum (RATTLE)",
                6,
                1,
                CANONICAL,
                compose(table, "projection around kick ∘ drift ∘ kick (RATTLE)"),
                order,
                steps,
            );
            (
                Box::new(
                    ModelRun::new(flow, pend.system(), x0, dt, 1, None)
                        .map_err(initial_state_error)?,
                ),
                assembly,
            )
        }
        "pendulum-chain" => {
            let links = b.links.unwrap_or(10);
            if links > MAX_BODIES {
                return Err(err(
                    SceneErrorKind::Unsupported,
                    path.key("links"),
                    format!("more than {MAX_BODIES} links"),
                ));
            }
            let dim = b.dim.unwrap_or(2);
            let chain = PendulumChain::<f64>::uniform(dim, links)
                .map_err(|e| err(SceneErrorKind::Value, path.clone(), e.to_string()))?;
            let x0: Col<f64> = chain.at_rest(|_| 0.5);
            let p = chain
                .kick()
                .strang(chain.drift())
                .projected(chain.system(), &x0, chain.projection_options())
                .map_err(setup)?;
            let flow: Box<dyn Flow<Col<f64>>> = with_table(p, table);
            let assembly = builtin_assembly(
                file,
                "pendulum chain",
                chain.state_len(),
                links,
                CANONICAL,
                compose(table, "projection around kick ∘ drift ∘ kick (RATTLE)"),
                order,
                steps,
            );
            (
                Box::new(
                    ModelRun::new(flow, chain.system(), x0, dt, links, None)
                        .map_err(initial_state_error)?,
                ),
                assembly,
            )
        }
        other => {
            return Err(err(
                SceneErrorKind::Value,
                path.key("model"),
                format!(
                    "unknown built-in model '{other}' (paper, spherical-pendulum, pendulum-chain, rigid-body)"
                ),
            ));
        }
    };
    Ok(Compiled {
        simulation,
        assembly,
        plan: run_plan,
        model: None,
        sketch: None,
    })
}

#[allow(clippy::too_many_arguments)]
pub(super) fn builtin_assembly(
    file: &SceneFile,
    what: &str,
    n: usize,
    m: usize,
    structure: &str,
    scheme: String,
    order: u32,
    steps: usize,
) -> Assembly {
    Assembly {
        name: file.name.clone().unwrap_or_else(|| what.to_owned()),
        dim: None,
        bodies: 0,
        rigid_bodies: 0,
        state_len: n,
        constraints: if m == 0 {
            Vec::new()
        } else {
            vec![("built-in".to_owned(), m)]
        },
        constraint_rows: m,
        effects: vec![(what.to_owned(), "built-in".to_owned())],
        disabled: Vec::new(),
        canonical: structure == CANONICAL,
        structure: structure.to_owned(),
        dissipative: false,
        case: Some("degenerate".to_owned()),
        projection: None,
        scheme,
        order,
        reason: "the built-in model's scheme as named in `integrator.scheme`".to_owned(),
        solver: None,
        steps,
        initial_projection: None,
        dropped_constraints: Vec::new(),
        notes: Vec::new(),
        inputs: Vec::new(),
        outputs: Vec::new(),
        events: Vec::new(),
    }
}
