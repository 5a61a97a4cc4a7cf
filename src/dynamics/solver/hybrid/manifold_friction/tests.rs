use bevy::math::{BVec3, Mat3, Quat};

use super::*;
use crate::dynamics::solver::body::{cube_over_ground, kinetic_energy};
use crate::dynamics::solver::contact::tests::{random_vec, uniform};
use crate::dynamics::solver::contact::{prepare_contacts, warm_start};
use crate::dynamics::solver::ledger::RestitutionLedger;

/// A 1 kg cube of side 1 (`I^-1 = 6` about every axis) resting on static ground on its four
/// bottom corners, each carrying `load` N s of normal impulse, friction `mu`, moving at `v`
/// and spinning at `w`.
fn cube_on_ground(
    mu: f32,
    load: f32,
    v: Vec3,
    w: Vec3,
) -> (Vec<SolverBody>, Vec<ContactConstraint>) {
    let bodies = cube_over_ground(0.5, v, w).to_vec();
    let mut contacts: Vec<_> = [(0.5, 0.5), (0.5, -0.5), (-0.5, -0.5), (-0.5, 0.5)]
        .iter()
        .map(|&(x, z)| ContactConstraint::new(0, 1, Vec3::new(x, 0.0, z), Vec3::Y, 0.0, 0.0, mu))
        .collect();
    prepare_contacts(&bodies, &mut contacts);
    for c in &mut contacts {
        c.normal_impulse = load;
    }
    (bodies, contacts)
}

/// One pass of the manifold's friction on `bodies`, written back.
fn solve_once(bodies: &mut [SolverBody], contacts: &mut [ContactConstraint]) -> bool {
    let rows = ManifoldFriction::new(bodies, contacts);
    assert!(rows.ready);
    let (a, b) = (contacts[0].body_a, contacts[0].body_b);
    let mut v = PairVelocities::load(bodies, a, b);
    let changed = rows.solve_in(&mut v, contacts, 0.0);
    v.store(bodies, a, b);
    changed
}

/// The points' tangent impulses as a resultant (N s, world frame) and a twist about `n`
/// (N m s) about their centroid.
fn resultant_and_twist(contacts: &[ContactConstraint]) -> (Vec3, f32) {
    let center = contacts.iter().map(|c| c.point).sum::<Vec3>() / contacts.len() as f32;
    let n = contacts[0].normal;
    let t = contacts[0].tangents;
    let mut force = Vec3::ZERO;
    let mut twist = 0.0;
    for c in contacts {
        let along = c.tangent_impulse[0] * t[0] + c.tangent_impulse[1] * t[1];
        force += along;
        twist += c.twist_impulse + (c.point - center).cross(along).dot(n);
    }
    (force, twist)
}

/// Within the Coulomb bounds, one pass stops the cube exactly: its rows decouple here (a
/// tangent impulse at the centroid, straight below the centre of mass, turns the cube about
/// the other tangent, which moves the centroid only along its own tangent, and the twist row
/// about the normal moves neither), so each row's `1/K` takes its slip out in one update. The
/// impulses handed back to the points sum to the momentum the cube lost: `m dv` of the
/// resultant (1 kg) and, about the normal, `I dw = dw / 6` of the twist. Bound 1e-6 (f32
/// rounding of quantities of order 1).
#[test]
fn manifold_friction_stops_slip_and_twist_within_its_bounds() {
    let (v0, w0) = (Vec3::new(0.1, 0.0, 0.05), Vec3::new(0.0, 0.2, 0.0));
    let (mut bodies, mut contacts) = cube_on_ground(0.5, 1.0, v0, w0);
    assert!(solve_once(&mut bodies, &mut contacts));
    let cube = &bodies[1];
    let slip = cube.linear_velocity + cube.angular_velocity.cross(Vec3::new(0.0, -0.5, 0.0));
    assert!(slip.x.abs() <= 1e-6 && slip.z.abs() <= 1e-6, "slip {slip}");
    assert!(
        cube.angular_velocity.y.abs() <= 1e-6,
        "spin {}",
        cube.angular_velocity
    );
    let (force, twist) = resultant_and_twist(&contacts);
    let lost = v0 - cube.linear_velocity;
    assert!((force + lost).length() <= 1e-6, "{force} against {lost}");
    let spun = (cube.angular_velocity.y - w0.y) / 6.0;
    assert!((twist - spun).abs() <= 1e-6, "{twist} against {spun}");
    // The bounds were not reached: mu times the load of 4 N s is 2 N s; the twist's bound,
    // times the corners' mean distance from the centroid, is 1.414 N m s.
    assert!(force.length() < 2.0 && twist.abs() < 1.414);
}

/// Beyond the bounds, the resultant lies on the Coulomb disc, `|f| = mu W`, and the twist at
/// its bound `mu W r`, `r` the corners' mean distance from the centroid (`sqrt(1/2)` m for a
/// unit square): mu 0.5, W 4 N s gives 2 N s and 1.41421 N m s. Bound 1e-5 relative (f32
/// rounding through the disc's square root and the hand-back to the points).
#[test]
fn manifold_friction_is_bounded_by_the_resultant_and_mean_radius() {
    let (mut bodies, mut contacts) = cube_on_ground(
        0.5,
        1.0,
        Vec3::new(30.0, 0.0, -40.0),
        Vec3::new(0.0, 50.0, 0.0),
    );
    solve_once(&mut bodies, &mut contacts);
    let (force, twist) = resultant_and_twist(&contacts);
    assert!((force.length() - 2.0).abs() <= 2e-5, "{force}");
    // Against the slip (30, -40)/50 m/s.
    let against = -Vec3::new(0.6, 0.0, -0.8);
    assert!((force.normalize() - against).length() <= 1e-5, "{force}");
    let bound = 2.0 * 0.5f32.sqrt();
    assert!(
        (twist + bound).abs() <= 1e-5 * bound,
        "{twist} against -{bound}"
    );
}

/// A property: from no friction impulse, passes of the manifold's friction never raise the
/// kinetic energy of two free bodies (random masses over three decades, inertias
/// anisotropic and turned, velocities, spins, points in the plane, loads and `mu`). Each row's
/// update is the minimiser of the energy along it within its bound, which contains the
/// impulse it starts from. Bound: 1e-6 of the energy (f32 rounding of the velocities).
#[test]
fn manifold_friction_never_raises_energy() {
    let mut unit = uniform(0x0f1c_7105);
    for case in 0..500 {
        let mut body = |x: Vec3| {
            let mass = 10f32.powf(unit() * 3.0 - 1.5);
            let inertia = Vec3::new(0.1 + unit(), 0.1 + unit(), 0.1 + unit()) * mass;
            let turn = Quat::from_scaled_axis(random_vec(3.0, &mut unit));
            let (v, w) = (random_vec(5.0, &mut unit), random_vec(10.0, &mut unit));
            SolverBody::new(Motion::Dynamic, x, turn)
                .with_mass(
                    1.0 / mass,
                    Mat3::from_diagonal(inertia.recip()),
                    false,
                    BVec3::FALSE,
                )
                .with_velocity(v, w)
        };
        let mut bodies = vec![
            body(Vec3::new(0.0, -0.5, 0.0)),
            body(Vec3::new(0.0, 0.5, 0.0)),
        ];
        let points = 2 + (unit() * 3.0) as usize;
        let mu = unit();
        let mut contacts: Vec<_> = (0..points)
            .map(|_| {
                let p = Vec3::new(unit() - 0.5, 0.0, unit() - 0.5);
                let mut c = ContactConstraint::new(0, 1, p, Vec3::Y, 0.0, 0.0, mu);
                c.normal_impulse = unit();
                c
            })
            .collect();
        prepare_contacts(&bodies, &mut contacts);
        let mut before = kinetic_energy(&bodies);
        for pass in 0..3 {
            solve_once(&mut bodies, &mut contacts);
            let after = kinetic_energy(&bodies);
            assert!(
                after <= before * (1.0 + 1e-6),
                "case {case}, pass {pass}: {before} J -> {after} J"
            );
            before = after;
        }
    }
}

/// The warm start puts back exactly the wrench the manifold's rows read back: on a cube at
/// rest, the stored impulses give it `F / m` and `I^-1 ((c - x) x F + tau n)`, `F` and `tau`
/// the resultant and twist the rows read, `c` the points' centroid. Here the two corners at
/// `x = +0.5` lie 1 cm above the plane of the points and the two at `x = -0.5` 1 cm below it
/// (a tilted face's corners, or points at different depths), and the cube slides and spins
/// fast enough for the twist to reach its bound. Handed back as tangent impulses
/// `(tau / S) n x d`, the twist's warm start also turned the cube by
/// `6 (tau / S) sum(e_i d_i)`, 0.085 rad/s about x here, which no row reads (this test failed
/// so: 1.2849 against 1.2000 rad/s); as a share of its own it is a pure torque about `n`.
/// Bound 1e-5 (f32 rounding of quantities of order 1).
#[test]
fn manifold_friction_warm_start_applies_what_its_rows_read() {
    let (v0, w0) = (Vec3::new(2.0, 0.0, 1.0), Vec3::new(0.0, 12.0, 0.0));
    let (mut bodies, mut contacts) = cube_on_ground(0.5, 1.0, v0, w0);
    for (c, e) in contacts.iter_mut().zip([0.01, 0.01, -0.01, -0.01]) {
        c.point.y = e;
    }
    prepare_contacts(&bodies, &mut contacts);
    for c in &mut contacts {
        c.normal_impulse = 1.0;
    }
    assert!(solve_once(&mut bodies, &mut contacts));
    let (force, twist) = resultant_and_twist(&contacts);
    // The slip stopped (0.894 N s: the centroid's `1 / K_t` is 0.4 kg, under the bound of
    // 2 N s) and the twist at its bound (1.414 N m s, see above): neither is trivial.
    assert!(
        (force.length() - 0.89443).abs() < 1e-4
            && (twist.abs() - std::f32::consts::SQRT_2).abs() < 1e-4,
        "{force} {twist}"
    );
    let cube = &mut bodies[1];
    (cube.linear_velocity, cube.angular_velocity) = (Vec3::ZERO, Vec3::ZERO);
    for c in &mut contacts {
        c.normal_impulse = 0.0;
    }
    let mut ledger = RestitutionLedger::new(&bodies, &mut contacts);
    warm_start(&mut bodies, &contacts, &mut ledger);
    let center = contacts.iter().map(|c| c.point).sum::<Vec3>() / 4.0;
    let cube = &bodies[1];
    let turn = 6.0 * ((center - cube.position).cross(force) + twist * Vec3::Y);
    assert!(
        (cube.linear_velocity - force).length() <= 1e-5,
        "{} against {force}",
        cube.linear_velocity
    );
    assert!(
        (cube.angular_velocity - turn).length() <= 1e-5,
        "{} against {turn}",
        cube.angular_velocity
    );
}

/// A block solved per point drops the twist shares its points carry, and a manifold keeps
/// them: here the cube's four corners carry shares of 0.1 N m s, and the blocks are one
/// corner alone (as when its manifold has shrunk to one point) and the other three. Carried
/// by the lone corner, the share would be warm-started every substep, step after step, and
/// never updated (no row of a point reads it): the cube would be spun up without end.
#[test]
fn a_block_solved_per_point_drops_its_twist() {
    let (bodies, mut contacts) = cube_on_ground(0.5, 1.0, Vec3::ZERO, Vec3::ZERO);
    for c in &mut contacts {
        c.twist_impulse = 0.1;
    }
    let block = |range: std::ops::Range<usize>| Block {
        range,
        support: Support::A,
        hold: 1.0,
        push: Vec3::Y,
        load: 1.0,
        lever: 0.5,
        spread: 0.5,
        touching: true,
        carries_released: false,
        passes_on: false,
        gripped: false,
    };
    let blocks = [block(0..1), block(1..4)];
    let mut rows = Vec::new();
    manifold_frictions(
        FrictionModel::Manifold,
        &bodies,
        &mut contacts,
        &blocks,
        &mut rows,
    );
    assert!(!rows[0].ready && rows[1].ready);
    let twists: Vec<f32> = contacts.iter().map(|c| c.twist_impulse).collect();
    assert_eq!(twists, [0.0, 0.1, 0.1, 0.1]);
}
