//! Zero heap allocations per step after construction, on the stack and on the heap storage.
//! A counting global allocator counts the allocations made by the current thread only, so
//! tests running in parallel do not disturb each other.

use lieflow::models::{SphericalPendulum, paper};
use lieflow::prelude::*;
use nalgebra::SVector;
use std::alloc::{GlobalAlloc, Layout, System as SystemAlloc};
use std::cell::Cell;

struct Counting;

thread_local! {
    static ALLOCATIONS: Cell<u64> = const { Cell::new(0) };
}

// SAFETY: delegates to the system allocator; only counts.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let _ = ALLOCATIONS.try_with(|c| c.set(c.get() + 1));
        unsafe { SystemAlloc.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { SystemAlloc.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let _ = ALLOCATIONS.try_with(|c| c.set(c.get() + 1));
        unsafe { SystemAlloc.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

fn allocations() -> u64 {
    ALLOCATIONS.with(|c| c.get())
}

/// Steps `flow` once (a composition prepares its backup on the first step if nobody called
/// `prepare`), then counts the allocations of `steps` more steps.
fn allocations_per_run<V: Vector<Real = f64>, F: Flow<V>>(flow: &mut F, x: &mut V, h: f64) -> u64 {
    flow.prepare(x);
    flow.step(h, x).unwrap();
    let before = allocations();
    for _ in 0..1000 {
        flow.step(h, x).unwrap();
    }
    allocations() - before
}

#[test]
fn the_counter_counts() {
    let before = allocations();
    let v = std::hint::black_box(vec![1u8; 16]);
    assert_eq!(allocations() - before, 1);
    drop(v);
}

#[test]
fn stack_storage_steps_allocate_nothing() {
    type V = SVector<f64, 4>;
    let mut x: V = paper::initial_state();
    let mut f = paper::drift()
        .projected(paper::system(), &x, ProjectionOptions::default())
        .unwrap();
    assert_eq!(allocations_per_run(&mut f, &mut x, 0.1), 0);
    let mut f = paper::drift()
        .projected(paper::system(), &x, ProjectionOptions::default())
        .unwrap()
        .composed(&coefficients::SUZUKI_UMENO8);
    assert_eq!(allocations_per_run(&mut f, &mut x, 0.1), 0);
    let mut f = paper::drift()
        .projected(
            paper::system(),
            &x,
            ProjectionOptions::default().with_coupling(Coupling::Coupled),
        )
        .unwrap();
    assert_eq!(allocations_per_run(&mut f, &mut x, 0.1), 0);

    let model = SphericalPendulum::try_new(1.0, 1.0, 9.81).unwrap();
    let mut x: SVector<f64, 6> = model.state(1.0, 1.0);
    let mut f = model
        .kick()
        .strang(model.drift())
        .projected(model.system(), &x, ProjectionOptions::default())
        .unwrap()
        .triple_jump();
    assert_eq!(allocations_per_run(&mut f, &mut x, 0.01), 0);
}

#[test]
fn implicit_midpoint_steps_allocate_nothing() {
    use lieflow::flow::ImplicitMidpoint;
    use lieflow::models::RigidBody;
    use lieflow::nonlinear::NewtonOptions;
    let body = RigidBody::gni();
    let mut y: SVector<f64, 3> = RigidBody::gni_initial_state();
    let mut f = ImplicitMidpoint::<SVector<f64, 3>, _, _>::try_new(
        body.structure(),
        body,
        &y,
        NewtonOptions::default(),
    )
    .unwrap()
    .triple_jump();
    assert_eq!(allocations_per_run(&mut f, &mut y, 0.1), 0);
    let mut y: faer::Col<f64> = RigidBody::gni_initial_state();
    let mut f = ImplicitMidpoint::<faer::Col<f64>, _, _>::try_new(
        body.structure(),
        body,
        &y,
        NewtonOptions::default(),
    )
    .unwrap();
    assert_eq!(allocations_per_run(&mut f, &mut y, 0.1), 0);
}

#[test]
fn heap_storage_steps_allocate_nothing_after_construction() {
    type V = faer::Col<f64>;
    let mut x: V = paper::initial_state();
    let mut f = paper::drift()
        .projected(paper::system(), &x, ProjectionOptions::default())
        .unwrap();
    assert_eq!(allocations_per_run(&mut f, &mut x, 0.1), 0);
    let mut f = paper::drift()
        .projected(paper::system(), &x, ProjectionOptions::default())
        .unwrap()
        .triple_jump();
    assert_eq!(allocations_per_run(&mut f, &mut x, 0.1), 0);
    let mut f = paper::drift()
        .projected(
            paper::system(),
            &x,
            ProjectionOptions::default().with_coupling(Coupling::Coupled),
        )
        .unwrap();
    assert_eq!(allocations_per_run(&mut f, &mut x, 0.1), 0);
}

/// The flows added for dissipation: the exact linear flow (cached exponentials), the projection
/// around it, the constrained discrete gradient (heap Newton workspace), and the paper's §2
/// scheme (projection around the implicit midpoint of the modified Hamiltonian).
#[test]
fn dissipative_and_general_flows_allocate_nothing_per_step() {
    use faer::Col;
    use lieflow::flow::ConstrainedDiscreteGradient;
    use lieflow::models::DampedPendulum;
    type V = SVector<f64, 4>;
    let model = DampedPendulum::try_new(0.1).unwrap();
    let x0: V = model.state(1.2, 0.0);
    let mut x = x0;
    let mut f = model.free_flow().unwrap();
    assert_eq!(allocations_per_run(&mut f, &mut x, 0.1), 0);
    let mut x = x0;
    let mut f = model
        .free_flow()
        .unwrap()
        .projected(model.system(), &x0, ProjectionOptions::default())
        .unwrap();
    assert_eq!(allocations_per_run(&mut f, &mut x, 0.1), 0);
    let mut x = x0;
    let mut f: ConstrainedDiscreteGradient<V, _, Col<f64>> =
        ConstrainedDiscreteGradient::try_new(model.system(), &x0, ProjectionOptions::default())
            .unwrap();
    assert_eq!(allocations_per_run(&mut f, &mut x, 0.1), 0);
    // The §2 scheme, with the generic H + μ g and with its closed form.
    assert_eq!(section2_allocations(paper::modified_hamiltonian::<V>()), 0);
    assert_eq!(section2_allocations(paper::modified_energy()), 0);
    // ... and as one Newton system (ProjectedMidpoint), on stack and heap storage.
    assert_eq!(joint_section2_allocations::<V>(), 0);
    assert_eq!(joint_section2_allocations::<Col<f64>>(), 0);
    // Its general path (more than four constraints: Newton on n + m unknowns).
    use lieflow::models::PendulumChain;
    let chain = PendulumChain::<f64>::uniform(2, 6).unwrap();
    let mut x: Col<f64> = chain.at_rest(|i| 0.4 + 0.3 * i as f64);
    let mut f: ProjectedMidpoint<Col<f64>, _, _> = ProjectedMidpoint::try_new(
        chain.system(),
        chain.clone(),
        &x,
        chain.projection_options(),
    )
    .unwrap();
    assert_eq!(allocations_per_run(&mut f, &mut x, 0.01), 0);
}

/// Allocations of 1000 steps of the §2 scheme as one Newton system (`ProjectedMidpoint`).
fn joint_section2_allocations<W: Vector<Real = f64>>() -> u64 {
    let mut x: W = paper::initial_state();
    let mut f: ProjectedMidpoint<W, _, _> = ProjectedMidpoint::try_new(
        paper::system(),
        paper::modified_energy(),
        &x,
        ProjectionOptions::default(),
    )
    .unwrap();
    allocations_per_run(&mut f, &mut x, 0.1)
}

/// Allocations of 1000 steps of the paper's §2 scheme (projection around the implicit midpoint
/// rule for `h_n1`).
fn section2_allocations<H: Hamiltonian<SVector<f64, 4>>>(h_n1: H) -> u64 {
    use lieflow::flow::ImplicitMidpoint;
    use lieflow::nonlinear::NewtonOptions;
    type V = SVector<f64, 4>;
    let mut x: V = paper::initial_state();
    let inner: ImplicitMidpoint<V, _, _> =
        ImplicitMidpoint::try_new(paper::Structure, h_n1, &x, NewtonOptions::default()).unwrap();
    let mut f = inner
        .projected(paper::system(), &x, ProjectionOptions::default())
        .unwrap();
    allocations_per_run(&mut f, &mut x, 0.1)
}

/// An over-constrained mechanism through `DropDependent` (Bricard, RATTLE on heap storage):
/// the wrapper's full-length scratch and row map are made at construction.
#[test]
fn drop_dependent_steps_allocate_nothing() {
    use lieflow::models::bricard::Bricard;
    let x0: faer::Col<f64> = Bricard::initial_state();
    let mut f = Bricard::rattle(&x0).unwrap();
    let mut x = x0.clone();
    assert_eq!(allocations_per_run(&mut f, &mut x, 1e-3), 0);
}

#[test]
fn sparse_chain_steps_allocate_nothing_after_the_first() {
    for kind in [
        lieflow::linalg::SolverKind::Sparse,
        lieflow::linalg::SolverKind::Banded,
    ] {
        chain_steps_allocate_nothing(kind);
    }
}

fn chain_steps_allocate_nothing(kind: lieflow::linalg::SolverKind) {
    use lieflow::linalg::{LinearSolver, SolverChoice};
    use lieflow::models::PendulumChain;
    type V = faer::Col<f64>;
    let model = PendulumChain::<f64>::uniform(2, 300).unwrap();
    let mut x: V = model.at_rest(|i| 0.5 + 0.1 * (i as f64 * 0.01).sin());
    let options = model.projection_options();
    // Full Newton: every iteration reassembles and refactors the sparse Jacobian, so the
    // count below covers numeric refactorizations, not only solves.
    let options = options.with_newton(
        options
            .newton
            .with_solver(SolverChoice::Force(kind))
            .with_jacobian(lieflow::nonlinear::JacobianUpdate::EveryIteration),
    );
    let mut f = model
        .kick::<V>()
        .strang(model.drift())
        .projected(model.system(), &x, options)
        .unwrap();
    assert_eq!(f.newton().linear_solver().kind(), kind);
    assert_eq!(allocations_per_run(&mut f, &mut x, 1e-4), 0);
    assert!(f.stats().factorizations >= 1000, "{:?}", f.stats());
}

/// The driver itself: a step of the stepping object (its copy of the last good state, its
/// finiteness check) allocates nothing once it is built.
#[test]
fn stepper_steps_allocate_nothing() {
    type V = faer::Col<f64>;
    let x: V = paper::initial_state();
    let f = paper::drift()
        .projected(paper::system(), &x, ProjectionOptions::default())
        .unwrap()
        .triple_jump();
    let mut stepper = lieflow::Stepper::new(f, x, 0.0, 0.1).unwrap();
    stepper.step().unwrap();
    let before = allocations();
    for _ in 0..1000 {
        stepper.step().unwrap();
    }
    assert_eq!(allocations() - before, 0);
}

/// A forced, projected, composed pendulum stepped by the Stepper with a held input set before
/// every step and an event watched: no allocation per step (the input's integrals, the
/// ledger and the events' values live in the flow, the stepper and the event set).
#[test]
fn a_stepper_with_inputs_and_events_allocates_nothing_per_step() {
    use lieflow::port::{ComponentInputs, Held, InputFlow, Signal};
    use lieflow::stepper::{Direction, Event, Events};
    type V6 = SVector<f64, 6>;
    let model = SphericalPendulum::try_new(1.0, 1.0, 9.81).unwrap();
    let x0 = V6::from_column_slice(&[0.6, 0.0, -0.8, 0.0, 0.0, 0.0]);
    let held = Held::new(0.0);
    let input = InputFlow::try_new(ComponentInputs::new(&[3]), vec![Signal::Held(held.clone())])
        .unwrap()
        .supplying(model);
    let flow = model
        .kick::<V6>()
        .strang(input)
        .strang(model.drift::<V6>())
        .projected(model.system(), &x0, ProjectionOptions::default())
        .unwrap()
        .triple_jump();
    let mut stepper = lieflow::Stepper::new(flow, x0, 0.0, 0.01).unwrap();
    let mut events = Events::new(vec![Event::new(|_t, x: &V6| x[0], Direction::Either)]);
    for _ in 0..10 {
        stepper.step_with_events(&mut events).unwrap();
    }
    let before = allocations();
    let mut hits = 0;
    for k in 0..1000 {
        held.set((k as f64 * 0.01).sin());
        if stepper.step_with_events(&mut events).unwrap().is_some() {
            hits += 1;
        }
    }
    assert!(hits > 5, "the pendulum crossed the vertical {hits} times");
    assert_eq!(allocations() - before, 0);
}

/// `ProjectedMidpoint` and `ConstrainedDiscreteGradient` on a model of mechanical form solve on
/// `(δq, ν)`, the Petrov–Galerkin scheme on its stages' momenta and multipliers: dense for ten
/// particles with pair forces, sparse for a 200-link chain; none allocates per step.
#[test]
fn the_reduced_schemes_allocate_nothing_per_step() {
    use lieflow::flow::{ConstrainedDiscreteGradient, PetrovGalerkin};
    use lieflow::scene::Scene;
    let chain = "version = 1\ndim = 2\n[[chains]]\nname = \"c\"\nlinks = 200\n\
                 anchor = [0.0, 0.0]\ndirection = [1.0, -1.0]\nlength = 0.01\nmass = 0.01\n\
                 [[effects]]\ntype = \"gravity\"\ng = [0.0, -9.81]\n\
                 [[effects]]\ntype = \"damping\"\ncoefficient = 0.01\n\
                 [integrator]\ndt = 1e-4\nt_end = 0.01\n";
    for (text, h) in [
        (include_str!("../scenes/shell_damped.toml"), 0.01),
        (chain, 1e-4),
    ] {
        let c = Scene::from_toml(text, "t.toml").unwrap().compile().unwrap();
        let model = c.model.unwrap();
        let state = c.simulation.state();
        let x0 = faer::Col::<f64>::from_fn(state.len(), |i| state[i]);
        let system = || System::new(model.clone(), model.clone(), model.clone());
        let mut x = x0.clone();
        let mut f: ProjectedMidpoint<faer::Col<f64>, _, _> =
            ProjectedMidpoint::try_new(system(), model.clone(), &x, ProjectionOptions::default())
                .unwrap();
        assert_eq!(allocations_per_run(&mut f, &mut x, h), 0);
        let mut x = x0.clone();
        let mut f: ConstrainedDiscreteGradient<faer::Col<f64>, _> =
            ConstrainedDiscreteGradient::try_new(system(), &x, ProjectionOptions::default())
                .unwrap();
        assert!(format!("{f:?}").contains("mechanical: true"), "{f:?}");
        assert_eq!(allocations_per_run(&mut f, &mut x, h), 0);
        for order in [4, 6] {
            let mut x = x0.clone();
            let mut f: PetrovGalerkin<faer::Col<f64>, _> =
                PetrovGalerkin::try_new(system(), &x, order, ProjectionOptions::default()).unwrap();
            assert!(format!("{f:?}").contains("mechanical: true"), "{f:?}");
            assert_eq!(allocations_per_run(&mut f, &mut x, h), 0, "order {order}");
        }
    }
}

#[test]
fn rigid_bodies_on_damped_sprung_hinges_allocate_nothing_per_step() {
    // Two boxes chained by hinges (6 + 6 rows of QᵀQ = I, 5 + 5 of the hinges: the sparse path),
    // a spring and a consistent damper on each hinge: RATTLE around the kick (gravity,
    // springs, dampers with their Gram solves) and the drift.
    use lieflow::rigid::{BodyRef, Hinge, Inertia, Multibody, RigidBody};
    let inertia = Inertia::solid_box(1.0, [0.3, 0.2, 0.1]).unwrap();
    let mut model = Multibody::new([0.0, 0.0, -9.81]);
    let mut first = RigidBody::at_rest(1.0, inertia, [0.0, 0.0, -0.15]);
    first.angular_velocity = [0.0, 1.0, 0.0];
    first.velocity = [-0.15, 0.0, 0.0];
    let a = model.add_rigid(first).unwrap();
    let mut second = RigidBody::at_rest(1.0, inertia, [0.0, 0.0, -0.45]);
    second.angular_velocity = [0.0, 1.0, 0.0];
    second.velocity = [-0.45, 0.0, 0.0];
    let b = model.add_rigid(second).unwrap();
    let top = Hinge {
        a: BodyRef::Body(a),
        anchor_a: [0.0, 0.0, 0.15],
        axis_a: [0.0, 1.0, 0.0],
        b: BodyRef::World,
        anchor_b: [0.0; 3],
        axis_b: [0.0, 1.0, 0.0],
    };
    let middle = Hinge {
        a: BodyRef::Body(b),
        anchor_a: [0.0, 0.0, 0.15],
        axis_a: [0.0, 1.0, 0.0],
        b: BodyRef::Body(a),
        anchor_b: [0.0, 0.0, -0.15],
        axis_b: [0.0, 1.0, 0.0],
    };
    for hinge in [&top, &middle] {
        model.add_joint(hinge).unwrap();
        model.add_hinge_spring(hinge, 2.0, 0.0).unwrap();
        model.add_hinge_damper(hinge, 0.05).unwrap();
    }
    type V = faer::Col<f64>;
    let mut x: V = model.initial_state();
    let mut flow = model
        .kick::<V>()
        .strang(model.drift::<V>())
        .projected(model.system::<f64>(), &x, model.projection_options())
        .unwrap();
    assert_eq!(allocations_per_run(&mut flow, &mut x, 1e-3), 0);
}
