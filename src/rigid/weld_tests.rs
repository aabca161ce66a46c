// Per-coordinate loops index several arrays at once.
#![allow(clippy::needless_range_loop)]

use super::*;

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * (1.0 + a.abs().max(b.abs()))
}

fn sorted(mut m: [f64; 3]) -> [f64; 3] {
    m.sort_by(f64::total_cmp);
    m
}

/// Two equal boxes side by side are one box twice as long (closed form of a solid box).
#[test]
fn two_boxes_side_by_side_are_one_long_box() {
    let (m, sides) = (1.5, [0.4, 0.3, 0.2]);
    let part = |x: f64| {
        Part::Rigid(RigidBody::at_rest(
            m,
            Inertia::solid_box(m, sides).unwrap(),
            [x, 1.0, -2.0],
        ))
    };
    let welded = weld(&[part(0.3), part(0.7)], 0).unwrap();
    let long = Inertia::solid_box(2.0 * m, [0.8, 0.3, 0.2]).unwrap();
    assert!(close(welded.body.mass, 2.0 * m, 1e-15));
    assert_eq!(
        welded.body.position.map(|x| (x * 1e12).round()),
        [0.5e12, 1e12, -2e12]
    );
    let (got, want) = (
        sorted(welded.body.inertia.moments()),
        sorted(long.moments()),
    );
    for k in 0..3 {
        assert!(close(got[k], want[k], 1e-14), "{got:?} vs {want:?}");
    }
    assert!(close(welded.placements[0].offset[0], -0.2, 1e-15));
    assert!(close(welded.placements[1].offset[0], 0.2, 1e-15));
}

/// Every part's points land where they were: `cᵢ + Rᵢ p = c + R (offset + rotation p)`, for
/// turned parts, a point mass, and a spinning, moving body.
#[test]
fn placements_carry_each_parts_points_to_the_merged_frame() {
    let omega = [0.3, -1.2, 0.7];
    let v0 = [0.5, 0.1, -0.4];
    let turned = |axis: [f64; 3], angle: f64, c: [f64; 3], moments: [f64; 3]| {
        let c0 = [0.0, 0.0, 0.0];
        let r: [f64; 3] = core::array::from_fn(|k| c[k] - c0[k]);
        let w = cross(omega, r);
        Part::Rigid(RigidBody {
            mass: 2.0,
            inertia: Inertia::principal(moments).unwrap(),
            position: c,
            orientation: Rotation::from_axis_angle(axis, angle).unwrap(),
            velocity: core::array::from_fn(|k| v0[k] + w[k]),
            angular_velocity: omega,
        })
    };
    let pc = [0.2, 0.9, -0.3];
    let pw = cross(omega, pc);
    let parts = [
        turned([0.0, 0.0, 1.0], 0.4, [0.0; 3], [1.0, 1.5, 2.0]),
        turned([1.0, 1.0, 0.0], -1.1, [0.6, -0.2, 0.1], [0.3, 0.4, 0.5]),
        Part::Point {
            mass: 0.7,
            position: pc,
            velocity: core::array::from_fn(|k| v0[k] + pw[k]),
        },
    ];
    let welded = weld(&parts, 1).unwrap();
    let body = welded.body;
    assert_eq!(
        body.orientation,
        match parts[1] {
            Part::Rigid(b) => b.orientation,
            Part::Point { .. } => unreachable!(),
        }
    );
    for (part, place) in parts.iter().zip(&welded.placements) {
        let (c, r) = match part {
            Part::Rigid(b) => (b.position, b.orientation),
            Part::Point { position, .. } => (*position, Rotation::identity()),
        };
        for p in [[0.0; 3], [0.1, -0.3, 0.25], [1.0, 2.0, 3.0]] {
            let rp = r.apply(p);
            let want: [f64; 3] = core::array::from_fn(|k| c[k] + rp[k]);
            let rq = body.orientation.apply(place.point(p));
            for k in 0..3 {
                assert!(
                    close(body.position[k] + rq[k], want[k], 1e-14),
                    "{k} {:?} {want:?}",
                    body.position[k] + rq[k]
                );
            }
        }
    }
    // The merged body's momentum and angular momentum are the parts'.
    let mut p = [0.0; 3];
    for part in &parts {
        let (m, _, v) = motion(part);
        for k in 0..3 {
            p[k] += m * v[k];
        }
    }
    for k in 0..3 {
        assert!(close(body.mass * body.velocity[k], p[k], 1e-14));
    }
    assert_eq!(body.angular_velocity, omega);
}

/// A sphere with a point mass at distance `L`: moments about the common centre in closed form,
/// `J_s + μ L²` across the line and `J_s` along it, `μ = m M_s/(m + M_s)`.
#[test]
fn a_point_mass_adds_its_parallel_axis_moment() {
    let (ms, radius, mp, l) = (3.0, 0.2, 0.5, 1.2);
    let sphere = Inertia::solid_sphere(ms, radius).unwrap();
    let parts = [
        Part::Rigid(RigidBody::at_rest(ms, sphere, [0.0; 3])),
        Part::Point {
            mass: mp,
            position: [l, 0.0, 0.0],
            velocity: [0.0; 3],
        },
    ];
    let welded = weld(&parts, 0).unwrap();
    let js = sphere.moments()[0];
    let reduced = mp * ms / (mp + ms);
    let got = sorted(welded.body.inertia.moments());
    let want = sorted([js, js + reduced * l * l, js + reduced * l * l]);
    for k in 0..3 {
        assert!(close(got[k], want[k], 1e-14), "{got:?} vs {want:?}");
    }
}

#[test]
fn parts_that_do_not_move_as_one_body_are_refused() {
    let inertia = Inertia::principal([1.0, 1.0, 1.0]).unwrap();
    let still = RigidBody::at_rest(1.0, inertia, [0.0; 3]);
    let mut spinning = RigidBody::at_rest(1.0, inertia, [1.0, 0.0, 0.0]);
    spinning.angular_velocity = [0.0, 0.0, 1.0];
    let e = weld(&[Part::Rigid(still), Part::Rigid(spinning)], 0).unwrap_err();
    assert!(e.to_string().contains("velocity of welded part 1"), "{e}");
    let mut sliding = RigidBody::at_rest(1.0, inertia, [1.0, 0.0, 0.0]);
    sliding.velocity = [0.0, 1e-3, 0.0];
    assert!(weld(&[Part::Rigid(still), Part::Rigid(sliding)], 0).is_err());
    // Spinning together about z: the second centre moves at ω × r.
    let mut a = still;
    a.angular_velocity = [0.0, 0.0, 2.0];
    let mut b = spinning;
    b.angular_velocity = [0.0, 0.0, 2.0];
    b.velocity = [0.0, 2.0, 0.0];
    let w = weld(&[Part::Rigid(a), Part::Rigid(b)], 0).unwrap();
    assert!(close(w.body.velocity[1], 1.0, 1e-15));
    // The frame must be a rigid part.
    let point = Part::Point {
        mass: 1.0,
        position: [0.0; 3],
        velocity: [0.0; 3],
    };
    assert!(weld(&[point, Part::Rigid(still)], 0).is_err());
}
