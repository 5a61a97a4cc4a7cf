//! Unit tests of the narrow phase.

use super::*;
use parry3d::shape::{Ball, Cuboid, HalfSpace, SharedShape};

/// A ball of radius 0.5 whose centre is 0.49 m above a ground plane at y = 0 touches it
/// with 0.01 m penetration at the point straight below, normal +y (from ground to ball).
#[test]
fn ball_on_half_space() {
    let ground = HalfSpace::new(Vec3::Y);
    let ball = Ball::new(0.5);
    let (pg, pb) = (
        Pose::identity(),
        Pose::from_parts(Vec3::new(1.0, 0.49, 0.0), Quat::IDENTITY),
    );
    let mut pair = ContactPair::new(
        Entity::from_raw_u32(1).unwrap(),
        Entity::from_raw_u32(2).unwrap(),
    );
    assert!(pair.update(&pg, &ground, &pb, &ball, 0.02, 1.0));
    let points: Vec<_> = pair.world_points(&pg, &pb).collect();
    assert_eq!(points.len(), 1);
    let (_, _, p, n, d) = points[0];
    // 1e-6: parry's exact closed form for this pair, f32 rounding only.
    assert!((d + 0.01).abs() < 1e-6, "{d}");
    assert!((n - Vec3::Y).length() < 1e-6);
    assert!((p - Vec3::new(1.0, -0.005, 0.0)).length() < 1e-6, "{p}");
}

/// Two 1 mm dice, the upper one 5 um into the lower, offset by 0.5 um and turned by 1e-3
/// rad about the vertical: the contact polygon is a square (nearly the whole face), whose
/// corners are crossings of the two faces' edges. In metres parry drops those crossings
/// (see [`ContactPair::update`]) and gives fewer than four points; in the binary unit of
/// 1 mm it gives at least four, every one 5 um deep with the normal straight up and within
/// the die's face. Measured: 3 points in metres, 5 in the unit, 5 um deep to 2e-10 m.
/// Tolerances: 1e-8 m on depths and 1e-6 m on the face (a hundred ulps at 1 mm, f32
/// rounding of the poses), 1e-6 on the normal.
#[test]
fn millimetre_dice_touch_at_four_corners_in_the_unit() {
    let h = 0.0005;
    let die = SharedShape::cuboid(h, h, h);
    let lower = Pose::from_parts(Vec3::new(0.0, h, 0.0), Quat::IDENTITY);
    let upper = Pose::from_parts(
        Vec3::new(5e-7, 3.0 * h - 5e-6, 5e-7),
        Quat::from_rotation_y(1e-3),
    );
    let (a, b) = (
        Entity::from_raw_u32(1).unwrap(),
        Entity::from_raw_u32(2).unwrap(),
    );
    let mut metres = ContactPair::new(a, b);
    assert!(metres.update(&lower, die.as_ref(), &upper, die.as_ref(), 2e-5, 1.0));
    let points = metres.world_points(&lower, &upper).count();
    assert!(points < 4, "{points} points in metres");

    let unit = binary_unit(1e-3);
    let mut shapes = UnitShapes::default();
    let scaled = shapes.get(&die, unit).unwrap();
    let mut pair = ContactPair::new(a, b);
    assert!(pair.update(&lower, scaled.as_ref(), &upper, scaled.as_ref(), 2e-5, unit));
    let points: Vec<_> = pair.world_points(&lower, &upper).collect();
    assert!(points.len() >= 4, "{} points in the unit", points.len());
    for (_, _, p, n, d) in points {
        assert!((d + 5e-6).abs() <= 1e-8, "{d}");
        assert!((n - Vec3::Y).length() <= 1e-6, "{n}");
        assert!(p.x.abs().max(p.z.abs()) <= h + 1e-6, "{p}");
    }
}

/// A box resting flat on the ground gives four corner points at the box's corners.
#[test]
fn box_on_half_space_has_four_corners() {
    let ground = HalfSpace::new(Vec3::Y);
    let cuboid = Cuboid::new(Vec3::new(1.0, 0.25, 0.5));
    let (pg, pb) = (
        Pose::identity(),
        Pose::from_parts(Vec3::new(0.0, 0.25, 0.0), Quat::IDENTITY),
    );
    let mut pair = ContactPair::new(
        Entity::from_raw_u32(1).unwrap(),
        Entity::from_raw_u32(2).unwrap(),
    );
    assert!(pair.update(&pg, &ground, &pb, &cuboid, 0.02, 1.0));
    let mut xs: Vec<(f32, f32)> = pair
        .world_points(&pg, &pb)
        .map(|(_, _, p, _, _)| (p.x, p.z))
        .collect();
    xs.sort_by(|a, b| a.partial_cmp(b).unwrap());
    assert_eq!(xs, vec![(-1.0, -0.5), (-1.0, 0.5), (1.0, -0.5), (1.0, 0.5)]);
}

/// The time of impact of a turned body falling onto a half-space is the closed form whatever
/// the order of the two: a capsule (r 0.3, half height 0.5) turned by 1 rad about x and
/// z, its lowest point 3.6 cm above the plane, falling at 10 m/s, meets it at 3.6 ms
/// (within 1e-5 s: f32 rounding of the support point). Before the relative velocity was
/// given to the cast with the first body at rest, parry 0.27 subtracted the first body's
/// world velocity from a velocity in its own frame, and with the capsule first the pair was
/// a miss (the energy property test's seed 1409: a 110 kg capsule ended a step 10.8 cm deep).
#[test]
fn turned_body_meets_half_space_in_either_order() {
    use parry3d::shape::Capsule;
    let ground = HalfSpace::new(Vec3::Y);
    let capsule = Capsule::new_y(0.5, 0.3);
    let rotation = Quat::from_rotation_x(1.0) * Quat::from_rotation_z(1.0);
    let lowest = (0.5 * (rotation * Vec3::Y).y.abs()) + 0.3;
    let at = |pose: Pose, linear: Vec3| StepMotion {
        pose,
        local_center: Vec3::ZERO,
        linear,
        angular: Vec3::ZERO,
        spin_reach: 0.0,
    };
    let body = at(
        Pose::from_parts(Vec3::new(0.0, lowest + 0.036, 0.0), rotation),
        Vec3::new(0.0, -10.0, 0.0),
    );
    let floor = at(Pose::identity(), Vec3::ZERO);
    let dt = 1.0 / 70.0;
    for meeting in [
        time_of_impact(&capsule, &body, &ground, &floor, dt, 0.0, 0.02),
        time_of_impact(&ground, &floor, &capsule, &body, dt, 0.0, 0.02),
    ] {
        assert!(
            matches!(meeting, Meeting::At(t) if (t - 0.0036).abs() < 1e-5),
            "{meeting:?}"
        );
    }
}
