//! Contact rows against the seed formula, and the stick impulse against its closed form and bounds.

use super::friction::{clamp_to_room, disc_solve};
use super::*;
use crate::impulse::{ImpulseBody, inverse_effective_mass};
use bevy::math::{BVec3, Mat3};

/// A solver body as the impulse formula's reference API sees it.
fn as_impulse(b: &SolverBody) -> ImpulseBody {
    ImpulseBody {
        inverse_mass: b.inverse_mass,
        inverse_inertia: b.inverse_inertia,
        center_of_mass: b.position,
        linear_velocity: b.linear_velocity,
        angular_velocity: b.angular_velocity,
    }
}

/// A seeded xorshift stream of numbers uniform in [0, 1).
pub(crate) fn uniform(mut seed: u64) -> impl FnMut() -> f32 {
    move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 40) as f32 / (1u64 << 24) as f32
    }
}

/// A vector with each component uniform in [-scale, scale).
pub(crate) fn random_vec(scale: f32, unit: &mut dyn FnMut() -> f32) -> Vec3 {
    Vec3::new(unit() - 0.5, unit() - 0.5, unit() - 0.5) * 2.0 * scale
}

/// The prepared effective mass is the reciprocal of the impulse formula's denominator K.
#[test]
fn prepared_mass_matches_impulse_formula() {
    let rot = Quat::from_rotation_y(0.7);
    let inv_local = Mat3::from_diagonal(Vec3::new(3.0, 1.0, 2.0));
    let bodies = [
        SolverBody::new(Motion::Dynamic, Vec3::ZERO, rot).with_mass(
            0.5,
            inv_local,
            false,
            BVec3::FALSE,
        ),
        SolverBody::new(Motion::Dynamic, Vec3::new(1.0, 0.2, 0.0), Quat::IDENTITY).with_mass(
            0.25,
            inv_local,
            false,
            BVec3::FALSE,
        ),
    ];
    let (p, n) = (
        Vec3::new(0.5, 0.3, 0.2),
        Vec3::new(1.0, 0.1, 0.0).normalize(),
    );
    let mut contacts = [ContactConstraint::new(0, 1, p, n, 0.0, 0.0, 0.0)];
    prepare_contacts(&bodies, &mut contacts);
    let k = inverse_effective_mass(&as_impulse(&bodies[0]), &as_impulse(&bodies[1]), p, n);
    // Relative 1e-6: the two compute the same sums in a different order.
    assert!((contacts[0].normal_mass * k - 1.0).abs() <= 1e-6);
    assert!(contacts[0].angular);
}

/// The solver's row maths is the seed formula: on 200 seeded random contacts (masses 0.01
/// to 100 kg, one body static in a quarter of them, anisotropic inertias, random poses,
/// velocities, contact points, normals and restitutions, kept where the bodies approach),
/// the prepared row (`prepare_contacts`), its impulse (`row_impulse` with target `-e v_n`)
/// and its application (`apply_normal_impulse`) leave both bodies with the velocities that
/// `impulse::resolve_impact` gives on the same bodies as `ImpulseBody`s. Tolerance 1e-4
/// of the velocity scale (`|v| + |w|` before and after): the two compute the same sums
/// in a different order, a few f32 roundings (6e-8 each) of products of numbers up to
/// 1e4 (an inverse inertia of 100 times an impulse of 100).
#[test]
fn rows_run_the_seed_formula() {
    let mut unit = uniform(0x2545_f491_4f6c_dd1d);
    let mut checked = 0;
    for trial in 0..200 {
        let mut make = |fixed: bool| {
            let position = random_vec(1.0, &mut unit);
            let rotation = Quat::from_scaled_axis(random_vec(3.0, &mut unit));
            let body = SolverBody::new(
                if fixed {
                    Motion::Static
                } else {
                    Motion::Dynamic
                },
                position,
                rotation,
            );
            if fixed {
                return body;
            }
            let mass = 10f32.powf(unit() * 4.0 - 2.0);
            let moments = Vec3::new(unit(), unit(), unit()) * mass + Vec3::splat(0.05 * mass);
            body.with_mass(
                1.0 / mass,
                Mat3::from_diagonal(moments.recip()),
                false,
                BVec3::FALSE,
            )
            .with_velocity(random_vec(5.0, &mut unit), random_vec(5.0, &mut unit))
        };
        let mut bodies = [make(trial % 4 == 0), make(false)];
        let point = random_vec(1.0, &mut unit);
        let normal = random_vec(1.0, &mut unit).normalize_or(Vec3::Y);
        let e = unit();
        let (mut a, mut b) = (as_impulse(&bodies[0]), as_impulse(&bodies[1]));
        if crate::impulse::normal_velocity(&a, &b, point, normal) >= 0.0 {
            continue;
        }
        let reference = crate::impulse::resolve_impact(&mut a, &mut b, point, normal, e);
        let mut contacts = [ContactConstraint::new(0, 1, point, normal, 0.0, e, 0.0)];
        prepare_contacts(&bodies, &mut contacts);
        let c = &contacts[0];
        let vn = c.normal_velocity(&bodies);
        let j = crate::impulse::row_impulse(c.normal_mass, vn, -e * vn);
        c.apply_normal_impulse(&mut bodies, j);
        for (body, expected) in bodies.iter().zip([a, b]) {
            let scale = 1.0
                + expected.linear_velocity.length()
                + expected.angular_velocity.length()
                + body.linear_velocity.length()
                + body.angular_velocity.length();
            let error = (body.linear_velocity - expected.linear_velocity).length()
                + (body.angular_velocity - expected.angular_velocity).length();
            assert!(
                error <= 1e-4 * scale,
                "trial {trial}: j {j} vs {reference}, error {error} of {scale}"
            );
        }
        checked += 1;
    }
    // About half the random contacts approach; the rest are skipped.
    assert!(checked > 60, "only {checked} approaching contacts");
}

/// An elastic (e = 1) impulse on a single frictionless contact against static ground
/// reflects the contact's normal velocity and leaves the body's kinetic energy unchanged
/// (the impulse formula's energy balance `j (v_n + v_n') / 2 = 0`), also after the body has
/// turned since the row was prepared, once `refresh_inertia` has re-derived the row: 1e-5
/// relative is f32 rounding of a few products. The body: three different moments, spinning
/// at 115 rad/s (0.48 rad in the 1/240 s it turns first), struck at a corner. Without the
/// refresh the same reflection changes its energy by 1.6% (asserted: more than 1%).
#[test]
fn refreshed_row_reflects_without_energy_change() {
    let kinetic = |b: &SolverBody| {
        0.5 * b.linear_velocity.length_squared() / b.inverse_mass
            + 0.5
                * b.angular_velocity
                    .dot(b.inverse_inertia.inverse() * b.angular_velocity)
    };
    let run = |refresh: bool| {
        let mut bodies = [
            SolverBody::new(Motion::Static, Vec3::ZERO, Quat::IDENTITY),
            SolverBody::new(Motion::Dynamic, Vec3::new(0.0, 0.5, 0.0), Quat::IDENTITY)
                .with_mass(
                    0.5,
                    Mat3::from_diagonal(Vec3::new(60.0, 15.0, 25.0)),
                    false,
                    BVec3::FALSE,
                )
                .with_velocity(
                    Vec3::new(1.0, -5.0, 0.5),
                    Vec3::new(0.2, 0.3, 1.0).normalize() * 115.0,
                ),
        ];
        let p = Vec3::new(0.3, 0.0, 0.2);
        let mut contacts = [ContactConstraint::new(0, 1, p, Vec3::Y, 0.0, 1.0, 0.0)];
        prepare_contacts(&bodies, &mut contacts);
        crate::dynamics::solver::body::integrate_positions(&mut bodies, Vec3::ZERO, 1.0 / 240.0);
        if refresh {
            refresh_inertia(&bodies, &mut contacts);
        }
        let c = &contacts[0];
        let e0 = kinetic(&bodies[1]);
        let vn = c.normal_velocity(&bodies);
        c.apply_normal_impulse(&mut bodies, -2.0 * vn * c.normal_mass);
        assert!((c.normal_velocity(&bodies) + vn).abs() <= 1e-4 * vn.abs());
        kinetic(&bodies[1]) / e0 - 1.0
    };
    let refreshed = run(true);
    assert!(refreshed.abs() <= 1e-5, "{refreshed}");
    let stale = run(false);
    assert!(stale.abs() > 0.01, "{stale}");
}

/// A sphere contact through the centres has no angular terms at all.
#[test]
fn sphere_contacts_skip_angular_terms() {
    let inv = Mat3::from_diagonal(Vec3::splat(10.0));
    let bodies = [
        SolverBody::new(Motion::Dynamic, Vec3::ZERO, Quat::IDENTITY).with_mass(
            1.0,
            inv,
            true,
            BVec3::FALSE,
        ),
        SolverBody::new(Motion::Dynamic, Vec3::new(0.6, 0.8, 0.0), Quat::IDENTITY).with_mass(
            1.0,
            inv,
            true,
            BVec3::FALSE,
        ),
    ];
    let n = Vec3::new(0.6, 0.8, 0.0);
    let mut contacts = [ContactConstraint::new(0, 1, 0.5 * n, n, 0.0, 0.0, 0.0)];
    prepare_contacts(&bodies, &mut contacts);
    assert!(!contacts[0].angular);
    assert_eq!(contacts[0].normal_mass, 0.5);
}

/// Kinetic energy of a body, from its inverse mass and world inverse inertia.
fn kinetic_energy(b: &SolverBody) -> f64 {
    if b.inverse_mass == 0.0 {
        return 0.0;
    }
    let w = b.angular_velocity;
    let inertia = b.inverse_inertia.inverse();
    0.5 * (b.linear_velocity.length_squared() / b.inverse_mass) as f64
        + 0.5 * w.dot(inertia * w) as f64
}

/// The stick impulse's closed form on a sphere: a solid ball (m = 2 kg, r = 0.5 m,
/// I = 2/5 m r^2) sliding at 3 m/s without spin on static ground, stopped from slipping in
/// one go, rolls: v' = 5/7 v, w' = v' / r (the impulse 2/7 m v against the slip, its torque
/// r x t spinning the ball up), the textbook result of a sliding ball meeting friction.
/// Within the Coulomb limit (mu j = 0.5 x 2 N s), the ball only slows to
/// v - mu j / m. Tolerance 1e-5 relative: a few f32 roundings.
#[test]
fn stick_impulse_rolls_a_sliding_ball() {
    let (m, r, v) = (2.0f32, 0.5f32, 3.0f32);
    let inertia = 0.4 * m * r * r;
    for (limit, expected_v) in [(100.0, 5.0 / 7.0 * v), (1.0, v - 1.0 / m)] {
        let mut bodies = [
            SolverBody::new(Motion::Static, Vec3::ZERO, Quat::IDENTITY),
            SolverBody::new(Motion::Dynamic, Vec3::new(0.0, r, 0.0), Quat::IDENTITY).with_mass(
                1.0 / m,
                Mat3::from_diagonal(Vec3::splat(1.0 / inertia)),
                true,
                BVec3::FALSE,
            ),
        ];
        bodies[1].linear_velocity = Vec3::new(v, 0.0, 0.0);
        let mut contacts = [ContactConstraint::new(
            0,
            1,
            Vec3::ZERO,
            Vec3::Y,
            0.0,
            0.0,
            0.5,
        )];
        prepare_contacts(&bodies, &mut contacts);
        let t = contacts[0].apply_stick_impulse(&mut bodies, limit);
        let size = (t[0] * t[0] + t[1] * t[1]).sqrt();
        let ball = &bodies[1];
        let tol = 1e-5 * v;
        assert!(
            (ball.linear_velocity.x - expected_v).abs() <= tol,
            "{limit}: {ball:?}"
        );
        assert!(ball.linear_velocity.y.abs() <= tol && ball.linear_velocity.z.abs() <= tol);
        // Spin about -z: the bottom point moves at v' - w r (x), stopped for the full stick.
        let spin = (v - ball.linear_velocity.x) * m * r / inertia;
        assert!((ball.angular_velocity - Vec3::new(0.0, 0.0, -spin)).length() <= tol / r);
        assert!((size - (v - expected_v) * m).abs() <= 1e-5 * m * v);
        if limit > 10.0 {
            assert!((ball.linear_velocity.x - ball.angular_velocity.z.abs() * r).abs() <= tol);
        }
    }
}

/// The stick impulse never adds energy and stays in its Coulomb disk: on 200 seeded random
/// pairs (masses 0.01 to 100 kg, one body static in a quarter, anisotropic inertias,
/// random poses, velocities, points and normals) and limits from 0 to far above the
/// impulse that stops the slip, the kinetic energy after is at most that before (relative
/// 1e-5: f32 roundings of sums of terms up to the energy itself), the impulse's size at
/// most the limit (relative 1e-5), and with an unbounded limit the slip is stopped (to
/// 1e-3 of the speed scale: the 2 x 2 solve in f32 of an inverse mass matrix whose
/// entries spread over 1e4).
#[test]
fn stick_impulse_takes_energy_out_within_the_disk() {
    let mut unit = uniform(0x9e37_79b9_7f4a_7c15);
    for trial in 0..200 {
        let mut make = |fixed: bool| {
            let position = random_vec(1.0, &mut unit);
            let rotation = Quat::from_scaled_axis(random_vec(3.0, &mut unit));
            if fixed {
                return SolverBody::new(Motion::Static, position, rotation);
            }
            let mass = 10f32.powf(4.0 * unit() - 2.0);
            let inertia = Vec3::new(0.1 + unit(), 0.1 + unit(), 0.1 + unit()) * mass;
            let mut body = SolverBody::new(Motion::Dynamic, position, rotation).with_mass(
                1.0 / mass,
                Mat3::from_diagonal(inertia.recip()),
                false,
                BVec3::FALSE,
            );
            body.linear_velocity = random_vec(5.0, &mut unit);
            body.angular_velocity = random_vec(5.0, &mut unit);
            body
        };
        let bodies = [make(trial % 4 == 0), make(false)];
        let point = random_vec(1.0, &mut unit);
        let normal = random_vec(1.0, &mut unit).normalize();
        let mut contacts = [ContactConstraint::new(0, 1, point, normal, 0.0, 0.0, 0.5)];
        prepare_contacts(&bodies, &mut contacts);
        let c = &contacts[0];
        let energy = bodies.iter().map(kinetic_energy).sum::<f64>();
        let scale = bodies
            .iter()
            .map(|b| b.linear_velocity.length() + 2.0 * b.angular_velocity.length())
            .sum::<f32>();
        for limit in [0.0, 0.01, 1.0, 1e9] {
            let mut after = bodies;
            let t = c.apply_stick_impulse(&mut after, limit);
            let size = (t[0] * t[0] + t[1] * t[1]).sqrt();
            let energy_after = after.iter().map(kinetic_energy).sum::<f64>();
            assert!(
                energy_after <= energy * (1.0 + 1e-5),
                "trial {trial}, limit {limit}: {energy} -> {energy_after}"
            );
            assert!(
                size <= limit * (1.0 + 1e-5),
                "trial {trial}: {size} > {limit}"
            );
            if limit > 1e8 {
                for k in 0..2 {
                    let slip = c.tangent_velocity(&after, k);
                    assert!(slip.abs() <= 1e-3 * scale, "trial {trial}: slip {slip}");
                }
            }
        }
    }
}

/// Friction's clamp into the disc (`clamp_to_room`), which skips the square root well inside
/// it, returns bit for bit what clamping to the square root returns: for rooms over 60 orders
/// of magnitude and at the edges of the floats (zero, subnormal, the smallest normal), for
/// impulses within 16 ulps of the bound on either side (its shortcut's threshold lies about 4
/// ulps inside), at it, and spread over the disc and beyond.
#[test]
fn friction_clamp_shortcut_is_the_clamp() {
    let reference = |impulse: f32, room2: f32| {
        let room = room2.sqrt();
        impulse.clamp(-room, room)
    };
    let mut unit = uniform(0x5eed_f00d);
    let mut rooms = vec![
        0.0,
        f32::MIN_POSITIVE / 4.0,
        f32::MIN_POSITIVE,
        f32::MIN_POSITIVE.next_up(),
        1.0,
    ];
    rooms.extend((0..2000).map(|_| 10f32.powf(unit() * 60.0 - 30.0)));
    let mut checked = 0;
    for room2 in rooms {
        let room = room2.sqrt();
        let mut impulses = vec![0.0, -0.0, room, -room, f32::NAN];
        let (mut up, mut down) = (room, room);
        for _ in 0..16 {
            (up, down) = (up.next_up(), down.next_down());
            impulses.extend([up, -up, down, -down]);
        }
        impulses.extend((0..16).map(|_| (unit() * 2.0 - 1.0) * 1.5 * room));
        for impulse in impulses {
            assert_eq!(
                clamp_to_room(impulse, room2).to_bits(),
                reference(impulse, room2).to_bits(),
                "impulse {impulse:e}, room^2 {room2:e}"
            );
            checked += 1;
        }
    }
    assert!(checked > 100_000);
}

/// The change of kinetic energy, J, of a tangent plane's impulse change `d` at slip `slip`
/// under `K = [k00, k01, k11]`: `d . slip + d . K d / 2`, in f64.
fn plane_energy(d: [f64; 2], slip: [f32; 2], k: [f32; 3]) -> f64 {
    let [k00, k01, k11] = k.map(f64::from);
    d[0] * slip[0] as f64
        + d[1] * slip[1] as f64
        + 0.5 * (k00 * d[0] * d[0] + 2.0 * k01 * d[0] * d[1] + k11 * d[1] * d[1])
}

/// A random symmetric positive definite `K_t` (condition numbers up to about 100, scales over
/// four decades), an accumulated impulse inside the disc, a slip and a limit.
fn random_plane(unit: &mut dyn FnMut() -> f32) -> ([f32; 3], [f32; 2], [f32; 2], f32) {
    let scale = 10f32.powf(unit() * 4.0 - 2.0);
    let (l1, l2) = (scale * (0.01 + unit()), scale * (0.01 + unit()));
    let angle = unit() * std::f32::consts::TAU;
    let (c, s) = (angle.cos(), angle.sin());
    let k = [
        l1 * c * c + l2 * s * s,
        (l1 - l2) * c * s,
        l1 * s * s + l2 * c * c,
    ];
    let limit = 10f32.powf(unit() * 2.0 - 1.0);
    let (r, a) = (limit * unit().sqrt(), unit() * std::f32::consts::TAU);
    let old = [r * a.cos(), r * a.sin()];
    let slip = [(unit() - 0.5) * 20.0, (unit() - 0.5) * 20.0];
    (k, old, slip, limit)
}

/// `disc_solve` is the nearest point of the Coulomb disc to the stopped slip in `K`'s metric:
/// its answer lies in the disc, lowers the energy at least as much as any of 720 points on the
/// disc's edge and the centre (each checked against it in f64), and never raises it from an
/// impulse inside the disc. Bounds: the disc's radius plus 1e-6 of it (the projection's
/// tolerance), and 1e-5 of the energy scale `limit * |slip| + K limit^2` (f32 rounding).
#[test]
fn friction_disc_solve_is_the_nearest_point_of_the_disc() {
    let mut unit = uniform(0x00d1_5c50);
    for case in 0..2000 {
        let (k, old, slip, limit) = random_plane(&mut unit);
        let new = disc_solve(old, slip, k, limit);
        let size = (new[0] * new[0] + new[1] * new[1]).sqrt();
        assert!(
            size <= limit * (1.0 + 1e-6),
            "case {case}: |f| {size} > {limit}"
        );
        let energy =
            |f: [f32; 2]| plane_energy([(f[0] - old[0]) as f64, (f[1] - old[1]) as f64], slip, k);
        let scale = limit as f64 * (slip[0].hypot(slip[1]) as f64)
            + (k[0] + k[2]) as f64 * (limit as f64).powi(2);
        let tolerance = 1e-5 * scale;
        let found = energy(new);
        assert!(found <= tolerance, "case {case}: energy rose by {found}");
        let mut best = energy([0.0; 2]);
        for i in 0..720 {
            let a = i as f32 * std::f32::consts::TAU / 720.0;
            best = best.min(energy([limit * a.cos(), limit * a.sin()]));
        }
        assert!(
            found <= best + tolerance,
            "case {case}: {found} against {best} on the edge"
        );
    }
}

/// `disc_solve` does not depend on the tangent basis: the same plane in a basis turned by an
/// angle (`K' = R^T K R`, the slip and the impulse turned with it) gives the same impulse,
/// turned. Bound: 1e-4 of the limit (f32 rounding through the turned `K`, and the projection's
/// tolerance). The tangent-by-tangent clamp it replaces fails this at the disc's edge.
#[test]
fn friction_disc_solve_is_isotropic() {
    let mut unit = uniform(0x150_7e0c);
    for case in 0..2000 {
        let (k, old, slip, limit) = random_plane(&mut unit);
        let angle = unit() * std::f32::consts::TAU;
        let (c, s) = (angle.cos(), angle.sin());
        // Components in the turned basis: x' = R^T x.
        let turn = |x: [f32; 2]| [c * x[0] + s * x[1], -s * x[0] + c * x[1]];
        let [k00, k01, k11] = k;
        let turned_k = [
            c * c * k00 + 2.0 * c * s * k01 + s * s * k11,
            (c * c - s * s) * k01 + c * s * (k11 - k00),
            s * s * k00 - 2.0 * c * s * k01 + c * c * k11,
        ];
        let new = turn(disc_solve(old, slip, k, limit));
        let turned = disc_solve(turn(old), turn(slip), turned_k, limit);
        let gap = (new[0] - turned[0]).hypot(new[1] - turned[1]);
        assert!(
            gap <= 1e-4 * limit,
            "case {case}: {new:?} against {turned:?}"
        );
    }
}
