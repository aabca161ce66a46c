//! The diagonal account's closed form against the account through the consistent parts.

use super::*;
use crate::scene::model::flight::{BodyForm, body3};
use crate::vector::Vector;

/// Three bodies of different masses in 3D: `a` on a sphere, `b` and `c` joined by a rod, `d`
/// free; no two constraints share a body, so `S` is diagonal.
const SCENE: &str = r#"
version = 1
dim = 3
[[bodies]]
name = "a"
mass = 1.0
position = [1.0, 0.0, 0.0]
[[bodies]]
name = "b"
mass = 2.5
position = [0.0, 2.0, 0.5]
[[bodies]]
name = "c"
mass = 0.7
position = [0.3, 2.4, -0.2]
[[bodies]]
name = "d"
mass = 1.3
position = [3.0, 0.0, 0.0]
[[constraints]]
type = "sphere"
bodies = ["a"]
center = [0.0, 0.0, 0.0]
[[constraints]]
type = "rod"
bodies = ["b", "c"]
[integrator]
dt = 0.01
t_end = 1.0
"#;

/// A reproducible spread of values in `[−1, 1)`.
fn values(n: usize, seed: u64) -> Vec<f64> {
    let mut s = seed;
    (0..n)
        .map(|_| {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 11) as f64 / (1u64 << 52) as f64 - 1.0
        })
        .collect()
}

#[test]
fn the_diagonal_closed_form_is_the_account_through_the_consistent_parts() {
    let scene = crate::scene::Scene::from_toml(SCENE, "test.toml").unwrap();
    let (model, x0) = crate::scene::model_of(&scene.file).unwrap();
    let bodies = model.masses.len();
    let n = model.dim * bodies;
    let mut account = ConsistentAccount::new(model.clone());
    let mut general = ConsistentAccount::new(model.clone());
    for seed in 1..20u64 {
        // Positions near the initial ones (the rod's and sphere's gradients move with them),
        // momenta and forces of any direction, forms with every term.
        let dq = values(n, seed);
        let q: Vec<f64> = (0..n).map(|i| x0[i] + 0.1 * dq[i]).collect();
        let p = values(n, 100 + seed);
        let forces = values(n, 200 + seed);
        let shape = values(3 * bodies, 300 + seed);
        let forms = (0..bodies)
            .map(|b| BodyForm {
                p2: 1.0 + shape[3 * b].abs(),
                pf: 0.5 * shape[3 * b + 1],
                f2: 1.0 + shape[3 * b + 2].abs(),
            })
            .collect();
        let books = BodyBooks {
            forms,
            forces,
            t: None,
        };
        assert_eq!(account.is_diagonal(&q), Some(true));
        let closed = account.removed_diagonal(&q, &p, &books);
        let through = general.removed_general(&q, &p, &books).unwrap();
        // Both are sums of O(1) terms over four bodies: they agree to a few roundings.
        assert!(
            (closed - through).abs() <= 1e-14 * through.abs().max(1.0),
            "seed {seed}: {closed} against {through}"
        );
        assert!(closed > 0.0, "seed {seed}: {closed}");
    }
}

#[test]
fn the_diagonal_account_books_nothing_of_a_momentum_along_the_constraint_gradients() {
    // p = Gᵀ μ and F = Gᵀ ν are all impulse and normal force: nothing is booked.
    let scene = crate::scene::Scene::from_toml(SCENE, "test.toml").unwrap();
    let (model, x0) = crate::scene::model_of(&scene.file).unwrap();
    let bodies = model.masses.len();
    let n = model.dim * bodies;
    let q: Vec<f64> = x0.as_slice()[..n].to_vec();
    let (mut p, mut forces) = (vec![0.0; n], vec![0.0; n]);
    model.gradient_transpose_add(&q, &[0.8, -1.7], 1.0, &mut p);
    model.gradient_transpose_add(&q, &[-0.4, 2.2], 1.0, &mut forces);
    let form = BodyForm {
        p2: 1.0,
        pf: 0.3,
        f2: 0.5,
    };
    let books = BodyBooks {
        forms: vec![form; bodies],
        forces,
        t: None,
    };
    let mut account = ConsistentAccount::new(model.clone());
    assert_eq!(account.is_diagonal(&q), Some(true));
    let own: f64 = (0..bodies)
        .map(|b| form.eval(body3(&p, b, 3), body3(&books.forces, b, 3)))
        .sum();
    let booked = account.removed_diagonal(&q, &p, &books);
    assert!(own > 1.0, "{own}");
    assert!(booked <= 1e-15 * own, "{booked} of {own}");
}
