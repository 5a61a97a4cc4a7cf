//! The exact casts against closed-form answers in f64, and on meshes, heightfields and
//! compounds.

mod closed_form;

use super::*;
use bevy::math::DVec3;
use closed_form::{Compared, Lcg, SOLIDS, Solid, compare};
use parry3d::shape::SharedShape;

/// Rays on capsules, cylinders, cones, rounded boxes and convex hulls: 20,000 random rays
/// each against the closed-form chord. Where the ray meets the surface at an angle (cosine
/// at least 0.01) the distance is within `2e-6 (1 + d)` (measured 3.6e-7 to 9.0e-7; f32
/// rounds a ray's origin to 6e-8 of its 50 m, and the tolerance is 1e-6 of it); a ray nearer
/// tangent hits within 1e-4 m of the surface (measured 2.9e-5 m: the f32 floor of a tangent,
/// where parry's closed-form ray on a ball is off by up to 2e-2 m in distance) and no chord
/// longer than 1 mm is missed (none is). parry's own casts on these shapes, measured the same
/// way: errors of 2.4e-4 to 1.8e-3 `(1 + d)`, chords of up to 0.61 m missed (capsule).
#[test]
fn rays_enter_curved_shapes_where_the_closed_form_says() {
    for solid in SOLIDS {
        let Compared {
            error,
            graze,
            missed,
            ..
        } = compare(solid, 0.0, 20_000, |shape, o, d| {
            cast_ray(
                shape.as_ref(),
                &Pose::IDENTITY,
                &Ray::new(o, d),
                f32::MAX,
                true,
            )
            .map(|hit| hit.time_of_impact)
        });
        let name = format!("{:?}", solid.shape().shape_type());
        assert!(error <= 2e-6, "{name}: distance error {error:e} (1 + d)");
        assert!(
            graze <= 1e-4,
            "{name}: grazing hit {graze:e} m off the surface"
        );
        assert!(missed <= 1e-3, "{name}: missed a chord of {missed:e} m");
    }
}

/// A ball of 0.2 m cast at capsules, cylinders, cones and rounded boxes meets them where a
/// ray meets the shape grown by 0.2 m (the closed-form distance minus 0.2), with the bounds
/// for rays (measured 2.9e-7 to 3.8e-7 `(1 + d)`, nothing missed). parry's `cast_shapes`,
/// measured the same way: errors of 2.5e-4 to 1.2e-3 `(1 + d)`, chords of 0.95 to 1.33 m
/// missed. (A hull's face planes give no closed form for the hull grown by a ball.)
#[test]
fn ball_casts_meet_curved_shapes_where_the_closed_form_says() {
    let ball = SharedShape::ball(0.2);
    let options = ShapeCastOptions::with_max_time_of_impact(f32::MAX);
    for solid in &SOLIDS[..4] {
        let solid = *solid;
        let Compared {
            error,
            graze,
            missed,
            ..
        } = compare(solid, 0.2, 5_000, |shape, o, d| {
            cast_shape(
                &Pose::IDENTITY,
                shape.as_ref(),
                &Pose::from_translation(o),
                d,
                ball.as_ref(),
                &options,
            )
            .map(|hit| hit.distance)
        });
        let name = format!("{:?}", solid.shape().shape_type());
        assert!(error <= 2e-6, "{name}: distance error {error:e} (1 + d)");
        assert!(
            graze <= 1e-4,
            "{name}: grazing hit {graze:e} m off the surface"
        );
        assert!(missed <= 1e-3, "{name}: missed a chord of {missed:e} m");
    }
}

/// Shape casts whose sum with the collider has a closed form: an unturned box cast at an
/// unturned box meets it when its centre enters the box of the summed half extents; a
/// capsule along y cast at another along y, when its centre enters the capsule of the
/// summed half heights and radii. Here the distance between the two shapes is parry's GJK
/// (the cores of two capsules are segments), which calls shapes 1.2e-6 m apart
/// intersecting: the hit is where that gap closes, which a shallow approach turns into
/// `1.2e-6 / cos` along the motion. So the bound is on the gap across the surface left at
/// the distance found, `|error| cos`: within `2e-6 (1 + d)` (measured 5.8e-7 for the boxes,
/// 7.5e-8 for the capsules); grazing and missed chords as for rays.
#[test]
fn box_and_capsule_casts_meet_where_the_closed_form_says() {
    let options = ShapeCastOptions::with_max_time_of_impact(f32::MAX);
    let pairs = [
        (
            SharedShape::cuboid(0.4, 0.3, 0.2),
            SharedShape::cuboid(0.1, 0.25, 0.3),
            Solid::RoundBox(DVec3::new(0.5, 0.55, 0.5), 0.0),
        ),
        (
            SharedShape::capsule_y(0.4, 0.2),
            SharedShape::capsule_y(0.2, 0.1),
            Solid::Capsule(0.6, 0.3),
        ),
    ];
    for (fixed, moving, sum) in pairs {
        let Compared {
            gap, graze, missed, ..
        } = compare(sum, 0.0, 5_000, |_, o, d| {
            cast_shape(
                &Pose::IDENTITY,
                fixed.as_ref(),
                &Pose::from_translation(o),
                d,
                moving.as_ref(),
                &options,
            )
            .map(|hit| hit.distance)
        });
        let name = format!("{:?}", fixed.shape_type());
        assert!(
            gap <= 2e-6,
            "{name}: gap {gap:e} (1 + d) across the surface"
        );
        assert!(
            graze <= 1e-4,
            "{name}: grazing hit {graze:e} m off the surface"
        );
        assert!(missed <= 1e-3, "{name}: missed a chord of {missed:e} m");
    }
}

/// A ball cast down onto a triangle mesh floor and a heightfield (flat at 0.5 m) touches
/// them when its bottom reaches them; a box cast sideways into a compound of two boxes
/// touches the nearer part.
#[test]
fn casts_on_meshes_heightfields_and_compounds() {
    let options = ShapeCastOptions::with_max_time_of_impact(100.0);
    let ball = SharedShape::ball(0.25);
    let mesh = SharedShape::trimesh(
        vec![
            Vec3::new(-5.0, 0.5, -5.0),
            Vec3::new(5.0, 0.5, -5.0),
            Vec3::new(5.0, 0.5, 5.0),
            Vec3::new(-5.0, 0.5, 5.0),
        ],
        vec![[0, 2, 1], [0, 3, 2]],
    )
    .unwrap();
    let field = SharedShape::heightfield(
        parry3d::utils::Array2::new(3, 3, vec![0.25; 9]),
        Vec3::new(10.0, 2.0, 10.0),
    );
    for floor in [mesh, field] {
        for (x, z) in [(0.3, -1.7), (4.0, 4.0), (-2.2, 0.9)] {
            let start = Pose::from_translation(Vec3::new(x, 7.0, z));
            let hit = cast_shape(
                &Pose::IDENTITY,
                floor.as_ref(),
                &start,
                Vec3::NEG_Y,
                ball.as_ref(),
                &options,
            )
            .unwrap();
            // From 7 m, its bottom 0.25 m lower, down to 0.5 m: 6.25 m.
            assert!(
                (hit.distance - 6.25).abs() <= 1e-5,
                "{:?}: {hit:?}",
                floor.shape_type()
            );
            assert!((hit.normal1 - Vec3::Y).length() <= 1e-4, "{hit:?}");
            assert!(
                (hit.point1 - Vec3::new(x, 0.5, z)).length() <= 1e-4,
                "{hit:?}"
            );
        }
    }
    let parts = SharedShape::compound(vec![
        (
            Pose::from_translation(Vec3::new(3.0, 0.0, 0.0)),
            SharedShape::cuboid(0.5, 0.5, 0.5),
        ),
        (
            Pose::from_translation(Vec3::new(6.0, 0.0, 0.0)),
            SharedShape::cuboid(0.5, 0.5, 0.5),
        ),
    ]);
    let cube = SharedShape::cuboid(0.2, 0.2, 0.2);
    let hit = cast_shape(
        &Pose::IDENTITY,
        parts.as_ref(),
        &Pose::IDENTITY,
        Vec3::X,
        cube.as_ref(),
        &options,
    )
    .unwrap();
    // Its face at x = 0.2 reaches the near part's at 2.5 after 2.3 m.
    assert!((hit.distance - 2.3).abs() <= 1e-5, "{hit:?}");
    assert!((hit.normal1 + Vec3::X).length() <= 1e-4, "{hit:?}");
}

/// Hollow rays from inside leave where the closed form says, with the normal turned
/// against the ray; solid ones hit at 0 with a zero normal.
#[test]
fn rays_from_inside_leave_where_the_closed_form_says() {
    let mut rng = Lcg(5);
    for solid in SOLIDS {
        let shape = solid.shape();
        let mut checked = 0;
        for _ in 0..2_000 {
            let origin = rng.vec(Vec3::new(0.3, 0.6, 0.3));
            let dir = rng.vec(Vec3::ONE).normalize();
            let (o, d) = (origin.as_dvec3(), dir.as_dvec3());
            if solid.distance(o) > -1e-3 {
                continue;
            }
            let ray = Ray::new(origin, dir);
            let solid_hit = cast_ray(shape.as_ref(), &Pose::IDENTITY, &ray, 10.0, true).unwrap();
            assert_eq!(
                (solid_hit.time_of_impact, solid_hit.normal),
                (0.0, Vec3::ZERO)
            );
            let hit = cast_ray(shape.as_ref(), &Pose::IDENTITY, &ray, 10.0, false).unwrap();
            let (_, exit) = solid.chord(o, d, 0.0).unwrap();
            assert!(
                (hit.time_of_impact as f64 - exit).abs() <= 1e-5,
                "{} vs {exit}",
                hit.time_of_impact
            );
            assert!(hit.normal.dot(dir) < 0.0, "the normal faces the ray");
            checked += 1;
        }
        assert!(checked > 200);
    }
}
