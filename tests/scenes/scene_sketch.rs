//! What a viewer draws of a scene (`lieflow::scene::sketch`): the bodies by their slots, the
//! links between them, the surfaces; and the joints' anchors, carried by each body's frame
//! `R = Q Pᵀ` from the state, meet at the joint (both ends at one world point) at the start and
//! after a run.

use lieflow::scene::sketch::{End, Shape, Sketch};
use lieflow::scene::{Scene, run};

fn compiled(path: &str) -> lieflow::scene::Compiled {
    Scene::from_path(std::path::Path::new(&format!(
        "{}/scenes/{path}",
        env!("CARGO_MANIFEST_DIR")
    )))
    .unwrap()
    .compile()
    .unwrap()
}

/// The world point of end `e` in state `x`.
fn world(s: &Sketch, x: &[f64], e: End) -> [f64; 3] {
    let d = s.dim;
    let at = |slot: usize| -> [f64; 3] {
        std::array::from_fn(|k| if k < d { x[slot * d + k] } else { 0.0 })
    };
    match e {
        End::World(p) => p,
        End::Body { body, offset } => {
            let b = &s.bodies[body];
            let c = at(b.slot);
            let Some(r) = &b.rigid else {
                return std::array::from_fn(|i| c[i] + offset[i]);
            };
            // Q's columns: the directors (the plane's normal third in 2D).
            let q: Vec<[f64; 3]> = (0..3)
                .map(|k| r.directors.get(k).map_or([0.0, 0.0, 1.0], |&s| at(s)))
                .collect();
            // R = Q Pᵀ: R_ij = Σ_k Q_ik P_jk, P's columns r.axes[k].
            std::array::from_fn(|i| {
                c[i] + (0..3)
                    .map(|j| (0..3).map(|k| q[k][i] * r.axes[k][j]).sum::<f64>() * offset[j])
                    .sum::<f64>()
            })
        }
    }
}

/// Every joint's two ends at one point, to `tol`.
fn joints_meet(s: &Sketch, x: &[f64], tol: f64) -> usize {
    let mut joints = 0;
    for l in &s.links {
        // A slider's anchors part along its axis as it slides.
        if ["hinge", "ball", "universal"].contains(&l.kind) {
            let (a, b) = (world(s, x, l.a), world(s, x, l.b));
            let gap = (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt();
            assert!(gap < tol, "{}: its ends are {gap:e} apart", l.label);
            joints += 1;
        }
    }
    joints
}

#[test]
fn the_default_scene_is_two_chains_of_rods_and_a_spring() {
    let c = Scene::default_scene().compile().unwrap();
    let s = c.sketch.unwrap();
    assert_eq!(s.dim, 2);
    assert_eq!(s.bodies.len(), 6);
    let kinds: Vec<&str> = s.links.iter().map(|l| l.kind).collect();
    assert_eq!(kinds.iter().filter(|&&k| k == "rod").count(), 6);
    assert_eq!(kinds.iter().filter(|&&k| k == "spring").count(), 1);
    // Each chain's first rod hangs from a fixed point.
    assert_eq!(
        s.links
            .iter()
            .filter(|l| matches!(l.b, End::World(_)))
            .count(),
        2
    );
    assert!(s.bodies.iter().all(|b| b.rigid.is_none()));
}

#[test]
fn particles_on_a_shell_share_one_sphere() {
    let s = compiled("shell_damped.toml").sketch.unwrap();
    assert_eq!(s.surfaces.len(), 1, "{:?}", s.surfaces);
    assert!(s.links.is_empty());
}

#[test]
fn the_bricard_links_are_boxes_whose_hinges_meet_before_and_after_a_run() {
    let mut c = compiled("bricard.toml");
    let s = c.sketch.clone().unwrap();
    assert_eq!(s.bodies.len(), 5);
    for b in &s.bodies {
        let r = b.rigid.as_ref().expect("rigid");
        assert!(matches!(r.shape, Shape::Box { .. }), "{:?}", r.shape);
        assert_eq!(r.directors, vec![b.slot + 1, b.slot + 2, b.slot + 3]);
    }
    let x0 = c.simulation.state().to_vec();
    assert_eq!(joints_meet(&s, &x0, 1e-14), 6);
    let summary = run(c.simulation.as_mut(), &c.plan, &mut |_| {});
    assert!(summary.error.is_none());
    // A ball's rows are the gap between the anchors itself, at round-off after every step.
    assert_eq!(joints_meet(&s, c.simulation.state(), 1e-12), 6);
}

#[test]
fn a_planar_mechanism_and_a_top_carry_their_anchors_with_their_frames() {
    for (scene, joints) in [
        ("slider_crank_planar.toml", 3),
        ("slider_crank.toml", 3),
        ("spinning_top.toml", 1),
    ] {
        let mut c = compiled(scene);
        let s = c.sketch.clone().unwrap();
        assert!(s.bodies.iter().all(|b| b.rigid.is_some()), "{scene}");
        assert_eq!(
            joints_meet(&s, c.simulation.state(), 1e-14),
            joints,
            "{scene}"
        );
        let summary = run(c.simulation.as_mut(), &c.plan, &mut |_| {});
        assert!(summary.error.is_none(), "{scene}");
        assert_eq!(
            joints_meet(&s, c.simulation.state(), 1e-12),
            joints,
            "{scene}"
        );
    }
}
