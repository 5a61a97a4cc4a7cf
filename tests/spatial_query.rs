//! Spatial queries (`SpatialQuery`, `RayCaster`, `ShapeCaster`) against independent answers:
//! closed-form ray, shape cast and projection results on single shapes; the filter's rules; a
//! seeded random world whose every query must equal a loop over every collider with parry
//! directly (not through the tree); what a query sees between steps; and bad input.

mod common;

use std::f32::consts::FRAC_PI_2;

use bevy::ecs::system::RunSystemOnce;
use bevy::prelude::*;
use common::{quad, spawn_static};
use impact3d::collision::BroadPhaseTree;
use impact3d::prelude::*;
use impact3d::scenes::{headless_app, run_steps};
use impact3d::spatial_query::exact;
use parry3d::bounding_volume::{Aabb, BoundingVolume};
use parry3d::math::Pose;
use parry3d::query::{Ray, ShapeCastOptions};
use parry3d::shape::SharedShape;

/// Runs `f` with a `SpatialQuery` of `app`'s world (as a system would, between steps).
fn with_query<T: Send + 'static>(
    app: &mut App,
    f: impl FnOnce(&SpatialQuery) -> T + Send + Sync + 'static,
) -> T {
    let mut f = Some(f);
    app.world_mut()
        .run_system_once(move |query: SpatialQuery| (f.take().unwrap())(&query))
        .unwrap()
}

/// An app whose bodies are spawned by `spawn` and then stepped once (the step records them).
fn world_of(spawn: impl FnOnce(&mut World)) -> App {
    let mut app = headless_app(60.0);
    spawn(app.world_mut());
    run_steps(&mut app, 1);
    app
}

fn all() -> SpatialQueryFilter {
    SpatialQueryFilter::default()
}

/// A `Dir3` holding `v`, which need not be a unit vector: what deserialising a scene or an
/// editor writing through reflection can produce (`Dir3::new_unchecked` asserts in debug
/// builds).
fn bad_dir(v: Vec3) -> Dir3 {
    use bevy::reflect::{PartialReflect, ReflectMut};
    let mut d = Dir3::X;
    match d.reflect_mut() {
        ReflectMut::TupleStruct(t) => t.field_mut(0).unwrap().apply(&v as &dyn PartialReflect),
        _ => unreachable!("Dir3 reflects as a tuple struct"),
    }
    d
}

/// Asserts `a` and `b` agree within `tol` on every component.
fn assert_close(a: Vec3, b: Vec3, tol: f32, what: &str) {
    assert!(
        (a - b).abs().max_element() <= tol,
        "{what}: {a} differs from {b} by more than {tol}"
    );
}

// Closed-form answers. Tolerances: the shapes sit a few metres from the origin, where an f32
// ulp is 5e-7 m; parry's ray-sphere quadratic, slab tests and GJK-free support-map casts carry
// a few ulps of error, so 1e-5 m (20 ulps) on distances and points, 1e-5 on unit normals.
const TOL: f32 = 1e-5;

/// Rays against a sphere, a turned box, a capsule and two half-spaces (one tilted), each
/// against its closed-form distance and normal.
#[test]
fn rays_hit_primitives_at_their_closed_form_distance_and_normal() {
    let mut e = [Entity::PLACEHOLDER; 5];
    let mut app = world_of(|w| {
        e[0] = spawn_static(w, Collider::sphere(0.5), Transform::from_xyz(5.0, 0.0, 0.0));
        e[1] = spawn_static(
            w,
            Collider::cuboid(0.5, 1.0, 2.0),
            Transform::from_xyz(0.0, 0.0, 5.0)
                .with_rotation(Quat::from_rotation_y(30f32.to_radians())),
        );
        e[2] = spawn_static(
            w,
            Collider::capsule(0.3, 0.6),
            Transform::from_xyz(0.0, 0.0, -5.0),
        );
        e[3] = spawn_static(
            w,
            Collider::half_space(Vec3::Y),
            Transform::from_xyz(0.0, -3.0, 0.0),
        );
        // Tilted by 45 degrees about z, through (0, 20, 0), high above the rest, facing down.
        e[4] = spawn_static(
            w,
            Collider::half_space(Vec3::NEG_Y),
            Transform::from_xyz(0.0, 20.0, 0.0)
                .with_rotation(Quat::from_rotation_z(45f32.to_radians())),
        );
    });
    let cases = vec![
        // Sphere: from (0, 0.3, 0) along +x, the surface at x = 5 - sqrt(0.5^2 - 0.3^2) = 4.6,
        // normal (x - 5, 0.3, 0) / 0.5 = (-0.8, 0.6, 0).
        (
            Vec3::new(0.0, 0.3, 0.0),
            Vec3::X,
            e[0],
            4.6,
            Vec3::new(-0.8, 0.6, 0.0),
        ),
        // Box turned 30 degrees about y: the ray along +z through its centre runs along
        // R^T z = (-1/2, 0, sqrt 3 / 2) in its frame, so it crosses the x = +0.5 face 0.5 / 0.5
        // = 1 m before the centre (the z face would take 2 / 0.866 = 2.31 m): distance 4, normal
        // R x = (cos 30, 0, -sin 30).
        (
            Vec3::ZERO,
            Vec3::Z,
            e[1],
            4.0,
            Vec3::new(0.8660254, 0.0, -0.5),
        ),
        // Capsule along y: at y = 0 the cylinder, 0.3 m before its axis at z = -5.
        (Vec3::ZERO, Vec3::NEG_Z, e[2], 4.7, Vec3::Z),
        // At y = 0.8 the upper cap (centre y = 0.6): its circle there has radius
        // sqrt(0.09 - 0.04), the normal is (0, 0.2, sqrt 0.05) / 0.3.
        (
            Vec3::new(0.0, 0.8, 0.0),
            Vec3::NEG_Z,
            e[2],
            5.0 - 0.05f32.sqrt(),
            Vec3::new(0.0, 0.2, 0.05f32.sqrt()) / 0.3,
        ),
        // The ground y = -3 from (1, 2, 1) along (1, -2, 0) / sqrt 5: 5 m down at 2 / sqrt 5
        // per metre.
        (
            Vec3::new(1.0, 2.0, 1.0),
            Vec3::new(1.0, -2.0, 0.0).normalize(),
            e[3],
            2.5 * 5f32.sqrt(),
            Vec3::Y,
        ),
        // The tilted half-space (outward normal R (-y) = (sin 45, -cos 45, 0)) from (0, 10, 0)
        // straight up: n . (p - (0, 20, 0)) = 0 at y = 20, 10 m.
        (
            Vec3::new(0.0, 10.0, 0.0),
            Vec3::Y,
            e[4],
            10.0,
            Vec3::new(0.5f32.sqrt(), -(0.5f32.sqrt()), 0.0),
        ),
    ];
    for (origin, dir, entity, distance, normal) in cases {
        let hit = with_query(&mut app, move |q| {
            q.cast_ray(origin, Dir3::new(dir).unwrap(), 100.0, true, &all())
        })
        .unwrap_or_else(|| panic!("ray from {origin} along {dir} missed"));
        assert_eq!(hit.entity, entity, "ray from {origin} along {dir}");
        assert!(
            (hit.distance - distance).abs() <= TOL,
            "{hit:?}: distance {distance}"
        );
        assert_close(hit.normal, normal, TOL, "normal");
        assert_close(hit.point, origin + distance * dir, TOL, "point");
    }
}

/// Solid and hollow rays from inside a sphere, the maximum distance, and several hits in a row
/// sorted by distance (spheres of 0.5 m at x = 3, 6, 9: surfaces at 2.5, 5.5, 8.5).
#[test]
fn solid_hollow_max_distance_and_several_hits() {
    let mut e = [Entity::PLACEHOLDER; 3];
    let mut app = world_of(|w| {
        // Spawned out of order, so that entity order and distance order differ.
        for (k, x) in [(2, 9.0), (0, 3.0), (1, 6.0)] {
            e[k] = spawn_static(w, Collider::sphere(0.5), Transform::from_xyz(x, 0.0, 0.0));
        }
    });
    let x = Dir3::X;
    // From the centre of the first sphere: solid hits it at 0 (normal zero); hollow at its
    // surface 0.5 m away, the normal there turned against the ray (parry's convention).
    let (solid, hollow) = with_query(&mut app, move |q| {
        let o = Vec3::new(3.0, 0.0, 0.0);
        (
            q.cast_ray(o, x, 100.0, true, &all()).unwrap(),
            q.cast_ray(o, x, 100.0, false, &all()).unwrap(),
        )
    });
    assert_eq!(
        (solid.entity, solid.distance, solid.normal),
        (e[0], 0.0, Vec3::ZERO)
    );
    assert_eq!(hollow.entity, e[0]);
    assert!((hollow.distance - 0.5).abs() <= TOL);
    assert_close(hollow.normal, Vec3::NEG_X, TOL, "hollow normal");

    let (short, long, hits, two, none, unlimited) = with_query(&mut app, move |q| {
        (
            q.cast_ray(Vec3::ZERO, x, 2.4, true, &all()),
            q.cast_ray(Vec3::ZERO, x, 2.6, true, &all()),
            q.ray_hits(Vec3::ZERO, x, 100.0, u32::MAX, true, &all()),
            q.ray_hits(Vec3::ZERO, x, 100.0, 2, true, &all()),
            q.ray_hits(Vec3::ZERO, x, 100.0, 0, true, &all()),
            q.ray_hits(Vec3::ZERO, x, f32::INFINITY, u32::MAX, true, &all()),
        )
    });
    assert!(
        short.is_none(),
        "the first surface is 2.5 m away: {short:?}"
    );
    assert_eq!(long.unwrap().entity, e[0]);
    let found: Vec<(Entity, f32)> = hits.iter().map(|h| (h.entity, h.distance)).collect();
    assert_eq!(found.len(), 3);
    for (k, &(entity, distance)) in found.iter().enumerate() {
        assert_eq!(entity, e[k]);
        assert!(
            (distance - (2.5 + 3.0 * k as f32)).abs() <= TOL,
            "{found:?}"
        );
    }
    assert_eq!(two, hits[..2].to_vec(), "max_hits keeps the nearest");
    assert!(none.is_empty());
    assert_eq!(unlimited, hits, "an infinite distance is no limit");

    // The callback sees the hits nearest first and stops when asked.
    let seen = with_query(&mut app, move |q| {
        let mut seen = Vec::new();
        q.ray_hits_callback(Vec3::ZERO, x, 100.0, true, &all(), |hit| {
            seen.push(hit.entity);
            seen.len() < 2
        });
        seen
    });
    assert_eq!(seen, vec![e[0], e[1]]);
}

/// Compound shapes, triangle meshes and heightfields are hit where their geometry says.
#[test]
fn rays_hit_compounds_trimeshes_and_heightfields() {
    let mut e = [Entity::PLACEHOLDER; 3];
    let mut app = world_of(|w| {
        // Two balls of 0.5 m, 1 m either side of the body's origin along its local x, the body
        // turned 90 degrees about y: the parts sit at z = -/+ 1 (R x = (0, 0, -1)).
        e[0] = spawn_static(
            w,
            Collider::compound(vec![
                (
                    Vec3::new(1.0, 0.0, 0.0),
                    Quat::IDENTITY,
                    Collider::sphere(0.5),
                ),
                (
                    Vec3::new(-1.0, 0.0, 0.0),
                    Quat::IDENTITY,
                    Collider::sphere(0.5),
                ),
            ]),
            Transform::from_xyz(10.0, 0.0, 0.0)
                .with_rotation(Quat::from_rotation_y(90f32.to_radians())),
        );
        // A square of two triangles at y = 0.2, 4 m a side, about (20, 0, 0).
        e[1] = spawn_static(
            w,
            quad([
                Vec3::new(-2.0, 0.2, -2.0),
                Vec3::new(2.0, 0.2, -2.0),
                Vec3::new(2.0, 0.2, 2.0),
                Vec3::new(-2.0, 0.2, 2.0),
            ]),
            Transform::from_xyz(20.0, 0.0, 0.0),
        );
        // A flat heightfield at 0.5 x 2 = 1 m, 8 m a side, about (30, 0, 0).
        e[2] = spawn_static(
            w,
            Collider::heightfield(vec![vec![0.5; 3]; 3], Vec3::new(8.0, 2.0, 8.0)),
            Transform::from_xyz(30.0, 0.0, 0.0),
        );
    });
    let down = Dir3::NEG_Y;
    let hits = with_query(&mut app, move |q| {
        [
            // Over the part at z = +1: its top at y = 0.5.
            q.cast_ray(Vec3::new(10.0, 5.0, 1.0), down, 100.0, true, &all()),
            // Between the parts: nothing.
            q.cast_ray(Vec3::new(10.0, 5.0, 0.0), down, 100.0, true, &all()),
            q.cast_ray(Vec3::new(21.0, 5.0, 1.5), down, 100.0, true, &all()),
            q.cast_ray(Vec3::new(29.0, 5.0, -3.0), down, 100.0, true, &all()),
        ]
    });
    let expect = [
        Some((e[0], 4.5)),
        None,
        Some((e[1], 4.8)),
        Some((e[2], 4.0)),
    ];
    for (hit, expected) in hits.iter().zip(expect) {
        match (hit, expected) {
            (None, None) => {}
            (Some(h), Some((entity, distance))) => {
                assert_eq!(h.entity, entity);
                assert!((h.distance - distance).abs() <= TOL, "{h:?}");
                assert_close(h.normal, Vec3::Y, TOL, "normal");
            }
            _ => panic!("{hit:?}, expected {expected:?}"),
        }
    }
}

/// The filter: a collider is considered when one of its memberships is in the mask, whatever
/// its own filters; excluded entities and the predicate leave it out; sensors are hit; disabled
/// and quarantined colliders never are.
#[test]
fn the_filter_decides_by_memberships_and_disabled_colliders_are_never_hit() {
    let mut e = [Entity::PLACEHOLDER; 6];
    let mut app = world_of(|w| {
        // Along +x: spheres of 0.5 m at x = 2, 4, 6, 8, 10, 12.
        let at = |x: f32| Transform::from_xyz(x, 0.0, 0.0);
        e[0] = w
            .spawn((
                RigidBody::Static,
                Collider::sphere(0.5),
                at(2.0),
                CollisionLayers::new(0b001, LayerMask::ALL),
            ))
            .id();
        // Touches nothing (filters NONE), on layer 1.
        e[1] = w
            .spawn((
                RigidBody::Static,
                Collider::sphere(0.5),
                at(4.0),
                CollisionLayers::new(0b010, LayerMask::NONE),
            ))
            .id();
        e[2] = w
            .spawn((RigidBody::Static, Collider::sphere(0.5), at(6.0), Sensor))
            .id();
        e[3] = w
            .spawn((
                RigidBody::Static,
                Collider::sphere(0.5),
                at(8.0),
                ColliderDisabled,
            ))
            .id();
        e[4] = w
            .spawn((
                RigidBody::Dynamic,
                Collider::sphere(0.5),
                at(10.0),
                RigidBodyDisabled,
            ))
            .id();
        // An invalid collider: quarantined, never in the step.
        e[5] = w
            .spawn((
                RigidBody::Static,
                Collider::sphere(-1.0),
                at(12.0),
                Name::new("Broken"),
            ))
            .id();
    });
    assert!(app.world().get::<Quarantined>(e[5]).is_some());
    let first = |app: &mut App, filter: SpatialQueryFilter| {
        with_query(app, move |q| {
            q.ray_hits(Vec3::ZERO, Dir3::X, 100.0, u32::MAX, true, &filter)
                .iter()
                .map(|h| h.entity)
                .collect::<Vec<_>>()
        })
    };
    // All layers: the three enabled spheres (the sensor is on the default layer).
    assert_eq!(first(&mut app, all()), vec![e[0], e[1], e[2]]);
    assert_eq!(
        first(&mut app, SpatialQueryFilter::from_mask(0b001)),
        vec![e[0], e[2]]
    );
    // Layer 1 only: the body that touches nothing is still seen by the query.
    assert_eq!(
        first(&mut app, SpatialQueryFilter::from_mask(0b010)),
        vec![e[1]]
    );
    assert_eq!(
        first(&mut app, SpatialQueryFilter::from_mask(0b100)),
        vec![]
    );
    assert_eq!(
        first(&mut app, all().with_excluded_entities([e[0], e[2]])),
        vec![e[1]]
    );
    // Layers 0 and 1 without the second body: the first and the sensor (default layer 0).
    assert_eq!(
        first(
            &mut app,
            SpatialQueryFilter::from_excluded_entities([e[1]]).with_mask(0b011)
        ),
        vec![e[0], e[2]]
    );
    let (e0, e1) = (e[0], e[1]);
    let predicate = with_query(&mut app, move |q| {
        q.cast_ray_predicate(Vec3::ZERO, Dir3::X, 100.0, true, &all(), &|x| x != e0)
            .map(|h| h.entity)
    });
    assert_eq!(predicate, Some(e1));

    // Disabling a collider or body, or despawning it, hides it at once, before the next step.
    app.world_mut().entity_mut(e[0]).insert(ColliderDisabled);
    app.world_mut().entity_mut(e[1]).insert(RigidBodyDisabled);
    app.world_mut().despawn(e[2]);
    assert_eq!(first(&mut app, all()), vec![]);
    // Enabled again, they are seen after the next step.
    app.world_mut()
        .entity_mut(e[0])
        .remove::<ColliderDisabled>();
    app.world_mut()
        .entity_mut(e[3])
        .remove::<ColliderDisabled>();
    run_steps(&mut app, 1);
    assert_eq!(first(&mut app, all()), vec![e[0], e[3]]);
}

/// A body with colliders on two child entities: queries test each collider and report it, not
/// the body, as avian3d does, and filter it by its own layers. The body stands at (1, 2, 0)
/// turned 90 degrees about y (`R x = (0, 0, -1)`): its sphere child (r 0.5, local (2, 0, 0),
/// layer 0) is centred at (1, 2, -2), its box child (half extents (0.5, 0.25, 0.5), local
/// (-2, 0, 0), layer 1) at (1, 2, 2). Closed-form answers: a ray down from y = 10 meets the
/// sphere's top (y 2.5) at 7.5 and the box's top (y 2.25) at 7.75; a ray along +z from
/// z = -10 meets the sphere at z = -2.5 (7.5) and the box at z = 1.5 (11.5). Excluding the body
/// excludes both colliders.
#[test]
fn child_colliders_are_hit_and_filtered_as_themselves() {
    let (mut body, mut sphere, mut cube) = (
        Entity::PLACEHOLDER,
        Entity::PLACEHOLDER,
        Entity::PLACEHOLDER,
    );
    let mut app = world_of(|w| {
        body = w
            .spawn((
                RigidBody::Kinematic,
                Transform::from_xyz(1.0, 2.0, 0.0).with_rotation(Quat::from_rotation_y(FRAC_PI_2)),
            ))
            .id();
        sphere = w
            .spawn((
                Collider::sphere(0.5),
                Transform::from_xyz(2.0, 0.0, 0.0),
                CollisionLayers::new(0b01, LayerMask::ALL),
                ChildOf(body),
            ))
            .id();
        cube = w
            .spawn((
                Collider::cuboid(0.5, 0.25, 0.5),
                Transform::from_xyz(-2.0, 0.0, 0.0),
                CollisionLayers::new(0b10, LayerMask::ALL),
                ChildOf(body),
            ))
            .id();
    });
    run_steps(&mut app, 1);
    for (x, z, entity, distance) in [(1.0, -2.0, sphere, 7.5), (1.0, 2.0, cube, 7.75)] {
        let hit = with_query(&mut app, move |q| {
            q.cast_ray(Vec3::new(x, 10.0, z), Dir3::NEG_Y, 100.0, true, &all())
        })
        .expect("a hit");
        assert_eq!(hit.entity, entity);
        assert!((hit.distance - distance).abs() <= TOL, "{hit:?}");
        assert_close(hit.normal, Vec3::Y, TOL, "normal");
    }
    let along_z = |app: &mut App, filter: SpatialQueryFilter| {
        with_query(app, move |q| {
            q.ray_hits(
                Vec3::new(1.0, 2.0, -10.0),
                Dir3::Z,
                100.0,
                u32::MAX,
                true,
                &filter,
            )
            .iter()
            .map(|h| (h.entity, h.distance))
            .collect::<Vec<_>>()
        })
    };
    let hits = along_z(&mut app, all());
    assert_eq!(
        hits.iter().map(|h| h.0).collect::<Vec<_>>(),
        vec![sphere, cube]
    );
    assert!(
        (hits[0].1 - 7.5).abs() <= TOL && (hits[1].1 - 11.5).abs() <= TOL,
        "{hits:?}"
    );
    let only = |app: &mut App, filter| along_z(app, filter).iter().map(|h| h.0).collect::<Vec<_>>();
    assert_eq!(
        only(&mut app, SpatialQueryFilter::from_mask(0b01)),
        vec![sphere]
    );
    assert_eq!(
        only(&mut app, SpatialQueryFilter::from_mask(0b10)),
        vec![cube]
    );
    assert_eq!(
        only(&mut app, all().with_excluded_entities([sphere])),
        vec![cube]
    );
    assert_eq!(only(&mut app, all().with_excluded_entities([body])), vec![]);
    // Points: inside each collider, and between them (inside the body's box, in neither).
    for (point, expected) in [
        (Vec3::new(1.0, 2.0, -2.0), vec![sphere]),
        (Vec3::new(1.0, 2.0, 2.0), vec![cube]),
        (Vec3::new(1.0, 2.0, 0.0), vec![]),
    ] {
        let found = with_query(&mut app, move |q| q.point_intersections(point, &all()));
        assert_eq!(found, expected, "at {point}");
    }
    let projection = with_query(&mut app, |q| {
        q.project_point(Vec3::new(1.0, 2.0, -4.0), true, &all())
    })
    .expect("a projection");
    assert_eq!(projection.entity, sphere);
    assert_close(
        projection.point,
        Vec3::new(1.0, 2.0, -2.5),
        TOL,
        "projection",
    );
    // Disabling the body hides its colliders at once, before the next step.
    app.world_mut().entity_mut(body).insert(RigidBodyDisabled);
    assert_eq!(only(&mut app, all()), vec![]);
}

/// What a query sees between steps: a body spawned or moved is seen where the next step puts
/// it, not before; a falling body is hit exactly where its `Transform` says after every step,
/// from a system in `Update` as from a system run between updates; a body that leaves the box
/// the broad phase gave it in a step (a resting ball struck hard) is still found.
#[test]
fn queries_see_each_step_where_it_left_the_bodies() {
    let mut app = headless_app(60.0);
    let ground = spawn_static(
        app.world_mut(),
        Collider::half_space(Vec3::Y),
        Transform::IDENTITY,
    );
    run_steps(&mut app, 1);
    let ray_at = |app: &mut App, x: f32| {
        with_query(app, move |q| {
            q.cast_ray(Vec3::new(x, 10.0, 0.0), Dir3::NEG_Y, 100.0, true, &all())
                .map(|h| (h.entity, h.distance))
        })
    };
    // Spawned between steps: not seen until a step has read it.
    let post = spawn_static(
        app.world_mut(),
        Collider::cuboid(0.5, 1.0, 0.5),
        Transform::from_xyz(3.0, 1.0, 0.0),
    );
    assert_eq!(ray_at(&mut app, 3.0), Some((ground, 10.0)));
    run_steps(&mut app, 1);
    assert_eq!(ray_at(&mut app, 3.0), Some((post, 8.0)));
    // Moved between steps: seen where it was until the next step, then where it is.
    app.world_mut()
        .get_mut::<Transform>(post)
        .unwrap()
        .translation
        .x = -3.0;
    assert_eq!(ray_at(&mut app, 3.0), Some((post, 8.0)));
    assert_eq!(ray_at(&mut app, -3.0), Some((ground, 10.0)));
    run_steps(&mut app, 1);
    assert_eq!(ray_at(&mut app, 3.0), Some((ground, 10.0)));
    assert_eq!(ray_at(&mut app, -3.0), Some((post, 8.0)));

    // A ball of 0.25 m falling at x = 6: a ray down its axis from 10 m meets its top at
    // 10 - (y + 0.25) after every step, from here as from a system in Update (the ray-sphere
    // solve rounds at 10 m: 1e-5 m).
    #[derive(Resource, Default)]
    struct Seen(Vec<Option<(Entity, f32)>>);
    app.init_resource::<Seen>();
    app.add_systems(Update, |q: SpatialQuery, mut seen: ResMut<Seen>| {
        let hit = q.cast_ray(Vec3::new(6.0, 10.0, 0.0), Dir3::NEG_Y, 100.0, true, &all());
        seen.0.push(hit.map(|h| (h.entity, h.distance)));
    });
    let falling = app
        .world_mut()
        .spawn((
            RigidBody::Dynamic,
            Collider::sphere(0.25),
            Transform::from_xyz(6.0, 8.0, 0.0),
        ))
        .id();
    // A ball resting on the ground, struck at 30 m/s by another (e = 1): in the step it is
    // struck it leaves the box the broad phase gave it (its box at rest, 2 cm wider), and must be
    // found where it is all the same.
    let ball = |x: f32, v: f32| {
        (
            RigidBody::Dynamic,
            Collider::sphere(0.25),
            Restitution(1.0),
            Transform::from_xyz(x, 0.25, 5.0),
            LinearVelocity(Vec3::new(v, 0.0, 0.0)),
        )
    };
    app.world_mut().spawn(ball(-12.1, 30.0));
    let struck = app.world_mut().spawn(ball(-10.0, 0.0)).id();
    let mut outside_its_leaf = 0;
    for step in 0..20 {
        run_steps(&mut app, 1);
        let y = app.world().get::<Transform>(falling).unwrap().translation.y;
        let (entity, distance) = ray_at(&mut app, 6.0).unwrap();
        assert_eq!(entity, falling, "step {step}");
        assert!(
            (distance - (10.0 - y - 0.25)).abs() <= 1e-5,
            "step {step}: {distance} at y = {y}"
        );
        assert_eq!(
            app.world().resource::<Seen>().0.last().unwrap(),
            &Some((entity, distance))
        );

        let at = app.world().get::<Transform>(struck).unwrap().translation;
        let (hit, inside) = with_query(&mut app, move |q| {
            (
                q.cast_ray(
                    Vec3::new(at.x, 10.0, at.z),
                    Dir3::NEG_Y,
                    100.0,
                    true,
                    &all(),
                ),
                q.point_intersections(at, &all()),
            )
        });
        let hit = hit.unwrap();
        assert_eq!(hit.entity, struck, "step {step}");
        assert!(
            (hit.distance - (10.0 - at.y - 0.25)).abs() <= 1e-5,
            "step {step}"
        );
        assert_eq!(inside, vec![struck], "step {step}");
        // Whether the ball's box at its end pose is outside its leaf in the broad phase's tree.
        let tree = app.world().resource::<BroadPhaseTree>();
        let leaf = tree
            .bvh()
            .leaf_node(tree.leaf(struck).unwrap())
            .unwrap()
            .aabb();
        let pose = Pose::from_parts(at, Quat::IDENTITY);
        if !leaf.contains(&SharedShape::ball(0.25).compute_aabb(&pose)) {
            outside_its_leaf += 1;
        }
    }
    let speed = app.world().get::<LinearVelocity>(struck).unwrap().0.x;
    assert!(speed > 10.0, "the ball was struck: {speed} m/s");
    assert!(
        outside_its_leaf >= 1,
        "the scene must move the ball out of its leaf"
    );
}

/// A random world of 300 mixed bodies (spheres, boxes, capsules, cylinders, cones, rounded
/// boxes, hulls, compounds; static, dynamic, kinematic; sensors, disabled colliders, three
/// layers) on a half-space, with a triangle mesh and a heightfield: after 1, 40 and 120 steps
/// (bodies falling, colliding, some asleep), every query of 200 random rays, 60 shape casts,
/// 100 points, 40 shapes and 40 boxes gives exactly what a loop over every collider gives, bit
/// for bit: each collider read from its components, at its `Transform`, tested with parry
/// (projection, containment, intersection, boxes) or with the exact casts of
/// `spatial_query::exact` (rays and shape casts, which use parry where it is exact; they are
/// checked against closed forms in their own tests), never through the tree.
#[test]
fn every_query_equals_a_loop_over_every_collider() {
    let mut app = headless_app(60.0);
    let mut rng = Lcg(2024);
    random_world(app.world_mut(), &mut rng, 300);
    let mut checked = Counts::default();
    for (k, steps) in [1, 39, 80].into_iter().enumerate() {
        run_steps(&mut app, steps - 1);
        // In the last step before each look, a ball at 30 m/s strikes a resting one 0.25 m
        // away (e = 1), half way through the step: the struck ball leaves the box the broad
        // phase gave it, and the queries aimed at such bodies must find it.
        let z = 20.0 + 2.0 * k as f32;
        let ball = |x: f32, v: f32| {
            (
                RigidBody::Dynamic,
                Collider::sphere(0.25),
                Restitution(1.0),
                Transform::from_xyz(x, 0.25, z),
                LinearVelocity(Vec3::new(v, 0.0, 0.0)),
            )
        };
        app.world_mut().spawn(ball(-1.0, 30.0));
        app.world_mut().spawn(ball(-0.25, 0.0));
        run_steps(&mut app, 1);
        checked.add(compare_with_brute_force(&mut app, &mut rng));
    }
    // The queries found things (a test of empty answers would prove nothing).
    // (Measured: 208 ray hits, 117 shape hits, 87 points inside, 62 shapes and 251 boxes
    // overlapping, 120 of them the ground's.)
    assert!(checked.stragglers >= 3, "{checked:?}");
    assert!(
        checked.ray_hits >= 150 && checked.shape_hits >= 80,
        "{checked:?}"
    );
    assert!(
        checked.points_inside >= 50 && checked.shapes_overlapping >= 40,
        "{checked:?}"
    );
    assert!(checked.boxes_overlapping >= 200, "{checked:?}");
}

/// The same static world under `PhysicsLengthUnit` 1, 1e-3 and 1e3 (the broad phase's tree is
/// built with margins scaled by the unit) gives bit-identical answers in metres.
#[test]
fn the_length_unit_changes_no_answer() {
    let answers: Vec<Vec<String>> = [1.0, 1e-3, 1e3]
        .into_iter()
        .map(|unit| {
            let mut app = headless_app(60.0);
            app.insert_resource(PhysicsLengthUnit(unit));
            let mut rng = Lcg(77);
            random_static_world(app.world_mut(), &mut rng, 120);
            run_steps(&mut app, 2);
            let mut out = Vec::new();
            for _ in 0..150 {
                let (origin, dir) = (rng.point(), rng.direction());
                let shape = Collider::cuboid(0.3, 0.2, 0.4);
                let rotation = rng.rotation();
                out.push(with_query(&mut app, move |q| {
                    format!(
                        "{:?} {:?} {:?} {:?}",
                        q.ray_hits(origin, dir, 30.0, u32::MAX, true, &all()),
                        q.shape_hits(
                            &shape,
                            origin,
                            rotation,
                            dir,
                            u32::MAX,
                            &ShapeCastConfig::from_max_distance(30.0),
                            &all()
                        ),
                        q.project_point(origin, false, &all()),
                        q.shape_intersections(&shape, origin, rotation, &all()),
                    )
                }));
            }
            out
        })
        .collect();
    assert_eq!(answers[0], answers[1]);
    assert_eq!(answers[0], answers[2]);
    assert!(answers[0].iter().any(|a| a.contains("RayHitData")));
}

/// Two spheres at the same place: the nearest hit is the one of the smaller entity (by
/// `Entity`'s order), and both are listed in that order, however the tree holds them.
#[test]
fn equal_distances_are_ordered_by_entity() {
    let mut twins = [Entity::PLACEHOLDER; 2];
    let mut app = world_of(|w| {
        twins[0] = spawn_static(w, Collider::sphere(0.5), Transform::from_xyz(4.0, 0.0, 0.0));
        // Others between them in the tree.
        for k in 0..30 {
            spawn_static(
                w,
                Collider::sphere(0.3),
                Transform::from_xyz(k as f32, 5.0, 0.0),
            );
        }
        twins[1] = spawn_static(w, Collider::sphere(0.5), Transform::from_xyz(4.0, 0.0, 0.0));
    });
    let (first, hits, projection, intersections) = with_query(&mut app, |q| {
        (
            q.cast_ray(Vec3::ZERO, Dir3::X, 10.0, true, &all()).unwrap(),
            q.ray_hits(Vec3::ZERO, Dir3::X, 10.0, u32::MAX, true, &all()),
            q.project_point(Vec3::new(2.0, 0.0, 0.0), true, &all())
                .unwrap(),
            q.point_intersections(Vec3::new(4.0, 0.0, 0.0), &all()),
        )
    });
    let mut sorted = twins;
    sorted.sort();
    assert_eq!(first.entity, sorted[0]);
    assert_eq!(
        hits.iter().map(|h| h.entity).collect::<Vec<_>>(),
        sorted.to_vec()
    );
    assert_eq!(hits[0].distance, hits[1].distance);
    assert_eq!(projection.entity, sorted[0]);
    assert_eq!(intersections, sorted.to_vec());
}

/// Shape casts against closed form: a ball of 0.5 m cast along +x, 0.6 m off the axis of a
/// static ball of 1 m at x = 10, first touches it when the centres are 1.5 m apart:
/// `x = 10 - sqrt(1.5^2 - 0.6^2)`; with a target distance of 0.2, at 1.7 m. A cube turned 45
/// degrees about z dropped on the ground from 3 m touches with its edge, `sqrt(1/2)` m below
/// its centre. A shape starting inside a collider hits it at 0, unless told to ignore that and
/// moving out.
#[test]
fn shape_casts_meet_the_closed_form_time_of_impact() {
    let mut e = [Entity::PLACEHOLDER; 2];
    let mut app = world_of(|w| {
        e[0] = spawn_static(
            w,
            Collider::sphere(1.0),
            Transform::from_xyz(10.0, 0.0, 0.0),
        );
        e[1] = spawn_static(
            w,
            Collider::half_space(Vec3::Y),
            Transform::from_xyz(0.0, -20.0, 0.0),
        );
    });
    let ball = Collider::sphere(0.5);
    let origin = Vec3::new(0.0, 0.6, 0.0);
    let (hit, target) = with_query(&mut app, move |q| {
        (
            q.cast_shape(
                &ball,
                origin,
                Quat::IDENTITY,
                Dir3::X,
                &ShapeCastConfig::default(),
                &all(),
            ),
            q.cast_shape(
                &ball,
                origin,
                Quat::IDENTITY,
                Dir3::X,
                &ShapeCastConfig::from_target_distance(0.2),
                &all(),
            ),
        )
    });
    let hit = hit.unwrap();
    let x = 10.0 - (1.5f32 * 1.5 - 0.36).sqrt();
    assert_eq!(hit.entity, e[0]);
    assert!((hit.distance - x).abs() <= TOL, "{hit:?}, expected {x}");
    // The normal of the static ball points from its centre to the cast ball's centre.
    let n = (Vec3::new(x, 0.6, 0.0) - Vec3::new(10.0, 0.0, 0.0)) / 1.5;
    assert_close(hit.normal1, n, TOL, "normal1");
    assert_close(hit.normal2, -n, TOL, "normal2");
    assert_close(hit.point1, Vec3::new(10.0, 0.0, 0.0) + n, TOL, "point1");
    assert_close(hit.point2, Vec3::new(10.0, 0.0, 0.0) + n, TOL, "point2");
    let target = target.unwrap();
    let x2 = 10.0 - (1.7f32 * 1.7 - 0.36).sqrt();
    assert!(
        (target.distance - x2).abs() <= TOL,
        "{target:?}, expected {x2}"
    );

    // The turned cube onto the ground 20 m down: from y = -17, its lowest edge sqrt(1/2) m
    // below its centre, 3 - sqrt(1/2) m above the ground.
    let cube = Collider::cuboid(0.5, 0.5, 0.5);
    let turned = Quat::from_rotation_z(45f32.to_radians());
    let (drop, inside, leaving) = with_query(&mut app, move |q| {
        let leave = ShapeCastConfig {
            ignore_origin_penetration: true,
            ..default()
        };
        (
            q.cast_shape(
                &cube,
                Vec3::new(0.0, -17.0, 0.0),
                turned,
                Dir3::NEG_Y,
                &ShapeCastConfig::default(),
                &all(),
            ),
            // Starting in the static ball's side (its centre 0.8 m from the ball's), moving out
            // along +x.
            q.cast_shape(
                &cube,
                Vec3::new(10.8, 0.0, 0.0),
                Quat::IDENTITY,
                Dir3::X,
                &ShapeCastConfig::default(),
                &all(),
            ),
            q.cast_shape(
                &cube,
                Vec3::new(10.8, 0.0, 0.0),
                Quat::IDENTITY,
                Dir3::X,
                &leave,
                &all(),
            ),
        )
    });
    let drop = drop.unwrap();
    assert_eq!(drop.entity, e[1]);
    assert!(
        (drop.distance - (3.0 - 0.5f32.sqrt())).abs() <= TOL,
        "{drop:?}"
    );
    assert_close(drop.normal1, Vec3::Y, TOL, "ground normal");
    assert_eq!(inside.map(|h| (h.entity, h.distance)), Some((e[0], 0.0)));
    assert_eq!(leaving, None);

    // All hits of a long cast, nearest first: the ball then the ground below it.
    let hits = with_query(&mut app, |q| {
        q.shape_hits(
            &Collider::sphere(0.5),
            Vec3::new(10.0, 5.0, 0.0),
            Quat::IDENTITY,
            Dir3::NEG_Y,
            u32::MAX,
            &ShapeCastConfig::default(),
            &all(),
        )
    });
    let found: Vec<(Entity, f32)> = hits.iter().map(|h| (h.entity, h.distance)).collect();
    assert_eq!(found.len(), 2, "{found:?}");
    // Down from y = 5: the ball's top at 1, touched at 5 - 1 - 0.5 = 3.5; the ground at -20 at
    // 25 - 0.5 = 24.5.
    assert_eq!((found[0].0, found[1].0), (e[0], e[1]));
    assert!(
        (found[0].1 - 3.5).abs() <= TOL && (found[1].1 - 24.5).abs() <= TOL,
        "{found:?}"
    );
}

/// Point projection onto a sphere and a box from outside and inside (solid and hollow), point
/// and shape intersections, and box intersections, against closed form.
#[test]
fn points_project_and_intersect_as_geometry_says() {
    let mut e = [Entity::PLACEHOLDER; 3];
    let mut app = world_of(|w| {
        e[0] = spawn_static(w, Collider::sphere(1.0), Transform::from_xyz(0.0, 0.0, 0.0));
        e[1] = spawn_static(
            w,
            Collider::cuboid(1.0, 0.5, 0.5),
            Transform::from_xyz(1.5, 0.0, 0.0),
        );
        e[2] = spawn_static(
            w,
            Collider::cuboid(0.5, 0.5, 0.5),
            Transform::from_xyz(10.0, 0.0, 0.0),
        );
    });
    let (outside, solid, hollow, corner) = with_query(&mut app, |q| {
        (
            q.project_point(Vec3::new(-3.0, 4.0, 0.0), true, &all())
                .unwrap(),
            q.project_point(Vec3::new(-0.5, 0.0, 0.0), true, &all())
                .unwrap(),
            q.project_point(Vec3::new(-0.5, 0.0, 0.0), false, &all())
                .unwrap(),
            q.project_point(Vec3::new(12.0, 2.0, 3.0), true, &all())
                .unwrap(),
        )
    });
    // From (-3, 4, 0), 5 m from the sphere's centre: its surface at (-3, 4, 0) / 5.
    assert_eq!((outside.entity, outside.is_inside), (e[0], false));
    assert_close(
        outside.point,
        Vec3::new(-0.6, 0.8, 0.0),
        TOL,
        "onto the sphere",
    );
    // Inside the sphere, 0.5 m from its surface (the box is 1 m away): solid, the point
    // itself; hollow, the sphere's surface at (-1, 0, 0).
    assert_eq!(
        (solid.entity, solid.point, solid.is_inside),
        (e[0], Vec3::new(-0.5, 0.0, 0.0), true)
    );
    assert_eq!((hollow.entity, hollow.is_inside), (e[0], true));
    assert_close(
        hollow.point,
        Vec3::new(-1.0, 0.0, 0.0),
        TOL,
        "onto the surface",
    );
    // Beyond a corner of the far cube: the corner (10.5, 0.5, 0.5).
    assert_eq!(corner.entity, e[2]);
    assert_close(
        corner.point,
        Vec3::new(10.5, 0.5, 0.5),
        TOL,
        "onto the corner",
    );

    let (both, one, none, shapes, boxes, touching) = with_query(&mut app, |q| {
        (
            // Inside the sphere and the box (x in [0.5, 2.5]).
            q.point_intersections(Vec3::new(0.7, 0.1, 0.0), &all()),
            q.point_intersections(Vec3::new(2.2, 0.1, 0.0), &all()),
            q.point_intersections(Vec3::new(0.0, 2.0, 0.0), &all()),
            // A ball of 0.3 m at (0, 1.2, 0): 1.2 m from the sphere's centre (< 1.3: overlaps),
            // 0.7 m above the box's top (clear); reaching 5 cm into the cube's face at x = 9.5,
            // and stopping 5 cm short of it.
            (
                q.shape_intersections(
                    &Collider::sphere(0.3),
                    Vec3::new(0.0, 1.2, 0.0),
                    Quat::IDENTITY,
                    &all(),
                ),
                q.shape_intersections(
                    &Collider::sphere(0.3),
                    Vec3::new(9.25, 0.0, 0.0),
                    Quat::IDENTITY,
                    &all(),
                ),
                q.shape_intersections(
                    &Collider::sphere(0.3),
                    Vec3::new(9.15, 0.0, 0.0),
                    Quat::IDENTITY,
                    &all(),
                ),
            ),
            // Boxes: [-1, 1]^3 for the sphere, [0.5, 2.5] x [-0.5, 0.5]^2, [9.5, 10.5] x ...
            q.aabb_intersections_with_aabb(ColliderAabb::new(
                Vec3::new(3.0, 0.0, 0.0),
                Vec3::splat(0.4),
            )),
            q.aabb_intersections_with_aabb(ColliderAabb::from_min_max(
                Vec3::new(2.5, 0.5, 0.5),
                Vec3::new(9.5, 1.0, 1.0),
            )),
        )
    });
    let mut pair = vec![e[0], e[1]];
    pair.sort();
    assert_eq!(both, pair, "in entity order");
    assert_eq!(one, vec![e[1]]);
    assert_eq!(none, vec![]);
    assert_eq!(shapes.0, vec![e[0]]);
    assert_eq!(shapes.1, vec![e[2]]);
    assert_eq!(shapes.2, vec![]);
    assert_eq!(boxes, vec![]);
    // Touching corners count: the box's corner at (2.5, 0.5, 0.5), the cube's at (9.5, ...).
    let mut pair = vec![e[1], e[2]];
    pair.sort();
    assert_eq!(touching, pair, "in entity order");
}

/// A ray caster on a turned, moved entity casts from its pose: local origin (0.5, 0, 0) and
/// direction +x on an entity at (0, 5, 0) turned -90 degrees about z start at (0, 4.5, 0)
/// going down, hitting a ball of 0.5 m at y = 2 after 2 m and the ground after 4.5 m. Moved to
/// x = 3, after the next step only the ground. On a falling body it follows the body and, by
/// default, ignores the body's own collider; a game system in `PhysicsSystems::Last` reads the
/// hits of the step that just ran.
#[test]
fn ray_casters_cast_from_their_entity_after_every_step() {
    let mut app = headless_app(60.0);
    let w = app.world_mut();
    let ground = spawn_static(w, Collider::half_space(Vec3::Y), Transform::IDENTITY);
    let ball = spawn_static(w, Collider::sphere(0.5), Transform::from_xyz(0.0, 2.0, 0.0));
    let turned = Transform::from_xyz(0.0, 5.0, 0.0)
        .with_rotation(Quat::from_rotation_z(-90f32.to_radians()));
    let eye = w
        .spawn((RayCaster::new(Vec3::new(0.5, 0.0, 0.0), Dir3::X), turned))
        .id();
    let nearest = w
        .spawn((
            RayCaster::new(Vec3::new(0.5, 0.0, 0.0), Dir3::X).with_max_hits(1),
            turned,
        ))
        .id();
    let faller = w
        .spawn((
            RigidBody::Dynamic,
            Collider::sphere(0.25),
            Transform::from_xyz(20.0, 10.0, 0.0),
            RayCaster::new(Vec3::ZERO, Dir3::NEG_Y),
        ))
        .id();
    let faller_self = w
        .spawn((
            RigidBody::Dynamic,
            Collider::sphere(0.25),
            Transform::from_xyz(25.0, 10.0, 0.0),
            RayCaster::new(Vec3::ZERO, Dir3::NEG_Y).with_ignore_self(false),
        ))
        .id();
    // A game system in `PhysicsSystems::Last` reads the hits of the step that just ran: the
    // falling ball's ray meets the ground its height below.
    #[derive(Resource, Default)]
    struct InLast(Vec<(f32, f32)>);
    app.init_resource::<InLast>();
    app.add_systems(
        FixedPostUpdate,
        (move |casters: Query<(&RayHits, &Transform)>, mut seen: ResMut<InLast>| {
            if let Ok((hits, at)) = casters.get(faller) {
                seen.0.push((hits[0].distance, at.translation.y));
            }
        })
        .in_set(PhysicsSystems::Last),
    );
    run_steps(&mut app, 1);
    let hits = |app: &App, e: Entity| -> Vec<(Entity, f32)> {
        app.world()
            .get::<RayHits>(e)
            .unwrap()
            .iter()
            .map(|h| (h.entity, h.distance))
            .collect()
    };
    let caster = app.world().get::<RayCaster>(eye).unwrap();
    assert_close(
        caster.global_origin(),
        Vec3::new(0.0, 4.5, 0.0),
        1e-6,
        "global origin",
    );
    assert_close(
        caster.global_direction().as_vec3(),
        Vec3::NEG_Y,
        1e-6,
        "global direction",
    );
    let found = hits(&app, eye);
    assert_eq!(found.len(), 2, "{found:?}");
    assert_eq!((found[0].0, found[1].0), (ball, ground));
    assert!(
        (found[0].1 - 2.0).abs() <= TOL && (found[1].1 - 4.5).abs() <= TOL,
        "{found:?}"
    );
    assert_eq!(hits(&app, nearest), found[..1].to_vec());

    app.world_mut()
        .get_mut::<Transform>(eye)
        .unwrap()
        .translation
        .x = 3.0;
    for _ in 0..10 {
        run_steps(&mut app, 1);
        let found = hits(&app, eye);
        assert_eq!(found.len(), 1);
        assert_eq!(found[0].0, ground);
        assert!((found[0].1 - 4.5).abs() <= TOL);
        // The falling ball's ray, from its centre, meets the ground its height below; the one
        // that does not ignore itself starts inside its own ball (solid: distance 0).
        let y = app.world().get::<Transform>(faller).unwrap().translation.y;
        let down = hits(&app, faller);
        assert_eq!(down[0].0, ground);
        assert!((down[0].1 - y).abs() <= 1e-5, "{down:?} at y = {y}");
        assert_eq!(hits(&app, faller_self)[0], (faller_self, 0.0));
    }
    let in_last = &app.world().resource::<InLast>().0;
    assert_eq!(in_last.len(), 11);
    for &(distance, y) in in_last {
        assert!(
            (distance - y).abs() <= 1e-5,
            "in Last: {distance} at y = {y}"
        );
    }
    // Disabled, it clears its hits.
    app.world_mut().get_mut::<RayCaster>(eye).unwrap().disable();
    run_steps(&mut app, 1);
    assert!(hits(&app, eye).is_empty());
}

/// A shape caster turned with its entity: a box of half extents (1, 0.1, 0.1), along its local
/// x, on an entity turned 90 degrees about z (local x is world y) and cast along local +x from
/// 3 m under a ceiling at y = 10 reaches it when its top end (1 m above its centre) does:
/// after 10 - 3 - 1 = 6 m. Its own local rotation of 90 degrees about z lays it back along world
/// x: then 10 - 3 - 0.1 = 6.9 m.
#[test]
fn shape_casters_cast_from_their_entity() {
    let mut app = headless_app(60.0);
    let w = app.world_mut();
    let ceiling = spawn_static(
        w,
        Collider::half_space(Vec3::NEG_Y),
        Transform::from_xyz(0.0, 10.0, 0.0),
    );
    let frame =
        Transform::from_xyz(4.0, 3.0, 0.0).with_rotation(Quat::from_rotation_z(90f32.to_radians()));
    let bar = Collider::cuboid(1.0, 0.1, 0.1);
    let upright = w
        .spawn((
            ShapeCaster::new(bar.clone(), Vec3::ZERO, Quat::IDENTITY, Dir3::X),
            frame,
        ))
        .id();
    let lying = w
        .spawn((
            ShapeCaster::new(
                bar,
                Vec3::ZERO,
                Quat::from_rotation_z(-90f32.to_radians()),
                Dir3::X,
            ),
            frame,
        ))
        .id();
    run_steps(&mut app, 1);
    for (caster, distance) in [(upright, 6.0), (lying, 6.9)] {
        let hits = app.world().get::<ShapeHits>(caster).unwrap();
        assert_eq!(hits.len(), 1);
        assert_eq!(hits[0].entity, ceiling);
        assert!(
            (hits[0].distance - distance).abs() <= TOL,
            "{:?}, expected {distance}",
            hits[0]
        );
        assert_close(hits[0].normal1, Vec3::NEG_Y, TOL, "ceiling normal");
    }
}

/// Bad input to the system parameter: no panic, no hit.
#[test]
fn bad_query_input_gives_no_hit() {
    let mut app = world_of(|w| {
        spawn_static(w, Collider::sphere(100.0), Transform::IDENTITY);
    });
    let answers = with_query(&mut app, |q| {
        let zero = bad_dir(Vec3::ZERO);
        let nan_dir = bad_dir(Vec3::NAN);
        let nan = Vec3::splat(f32::NAN);
        let f = &all();
        let cfg = &ShapeCastConfig::default();
        let ball = &Collider::sphere(0.1);
        vec![
            q.cast_ray(nan, Dir3::X, 10.0, true, f).is_some(),
            q.cast_ray(Vec3::ZERO, zero, 10.0, true, f).is_some(),
            q.cast_ray(Vec3::ZERO, nan_dir, 10.0, true, f).is_some(),
            q.cast_ray(Vec3::ZERO, Dir3::X, -1.0, true, f).is_some(),
            q.cast_ray(Vec3::ZERO, Dir3::X, f32::NAN, true, f).is_some(),
            !q.ray_hits(Vec3::INFINITY, Dir3::X, 10.0, 10, true, f)
                .is_empty(),
            q.cast_shape(
                &Collider::sphere(-1.0),
                Vec3::ZERO,
                Quat::IDENTITY,
                Dir3::X,
                cfg,
                f,
            )
            .is_some(),
            q.cast_shape(ball, nan, Quat::IDENTITY, Dir3::X, cfg, f)
                .is_some(),
            q.cast_shape(
                ball,
                Vec3::ZERO,
                Quat::from_xyzw(0.0, 0.0, 0.0, 0.0),
                Dir3::X,
                cfg,
                f,
            )
            .is_some(),
            q.cast_shape(ball, Vec3::ZERO, Quat::IDENTITY, zero, cfg, f)
                .is_some(),
            q.cast_shape(
                ball,
                Vec3::ZERO,
                Quat::IDENTITY,
                Dir3::X,
                &ShapeCastConfig::from_max_distance(-1.0),
                f,
            )
            .is_some(),
            q.cast_shape(
                ball,
                Vec3::ZERO,
                Quat::IDENTITY,
                Dir3::X,
                &ShapeCastConfig::from_target_distance(f32::NAN),
                f,
            )
            .is_some(),
            !q.shape_hits(ball, nan, Quat::IDENTITY, Dir3::X, 5, cfg, f)
                .is_empty(),
            q.project_point(nan, true, f).is_some(),
            !q.point_intersections(nan, f).is_empty(),
            !q.shape_intersections(ball, nan, Quat::IDENTITY, f)
                .is_empty(),
            !q.shape_intersections(
                &Collider::cuboid(0.0, 1.0, 1.0),
                Vec3::ZERO,
                Quat::IDENTITY,
                f,
            )
            .is_empty(),
            !q.aabb_intersections_with_aabb(ColliderAabb::from_min_max(nan, Vec3::ONE))
                .is_empty(),
        ]
    });
    for (k, hit) in answers.iter().enumerate() {
        assert!(!hit, "bad input {k} gave a hit");
    }
    // The same queries with good input do hit (the answers above are not empty for nothing).
    let good = with_query(&mut app, |q| {
        (
            q.cast_ray(Vec3::ZERO, Dir3::X, 10.0, true, &all())
                .is_some(),
            q.cast_shape(
                &Collider::sphere(0.1),
                Vec3::ZERO,
                Quat::IDENTITY,
                Dir3::X,
                &ShapeCastConfig::default(),
                &all(),
            )
            .is_some(),
            q.point_intersections(Vec3::ZERO, &all()).len(),
        )
    });
    assert_eq!(good, (true, true, 1));
}

/// Bad input to casters: no panic, no hits, one logged error per caster naming it (by `Name`,
/// or by entity), not repeated while it stays, logged again after it was valid and broke again.
#[test]
fn bad_caster_input_is_logged_once_per_caster() {
    common::capture_logs();
    let mut app = headless_app(60.0);
    // The casters run in `FixedPostUpdate`; on one thread, the test's, so that the captured
    // logs (per thread) see them whatever Bevy's executor.
    app.edit_schedule(FixedPostUpdate, |schedule| {
        schedule.set_executor(bevy::ecs::schedule::SingleThreadedExecutor::new());
    });
    let w = app.world_mut();
    spawn_static(w, Collider::half_space(Vec3::Y), Transform::IDENTITY);
    let down = |origin: Vec3| RayCaster::new(origin, Dir3::NEG_Y);
    let casters = [
        w.spawn((Name::new("NanOrigin"), down(Vec3::new(f32::NAN, 1.0, 0.0))))
            .id(),
        w.spawn((
            Name::new("ZeroDirection"),
            RayCaster::new(Vec3::Y, bad_dir(Vec3::ZERO)),
        ))
        .id(),
        w.spawn((
            Name::new("NanDirection"),
            RayCaster::new(Vec3::Y, bad_dir(Vec3::NAN)),
        ))
        .id(),
        w.spawn((
            Name::new("NegativeDistance"),
            down(Vec3::Y).with_max_distance(-2.0),
        ))
        .id(),
        w.spawn((
            Name::new("NanTransform"),
            down(Vec3::Y),
            Transform::from_xyz(f32::NAN, 0.0, 0.0),
        ))
        .id(),
        w.spawn(down(Vec3::Y).with_max_distance(f32::NAN)).id(),
        w.spawn((
            Name::new("BadShape"),
            ShapeCaster::new(Collider::sphere(-1.0), Vec3::Y, Quat::IDENTITY, Dir3::NEG_Y),
        ))
        .id(),
        w.spawn((
            Name::new("ZeroRotation"),
            ShapeCaster::new(
                Collider::sphere(0.1),
                Vec3::Y,
                Quat::from_xyzw(0.0, 0.0, 0.0, 0.0),
                Dir3::NEG_Y,
            ),
        ))
        .id(),
    ];
    let names = [
        "NanOrigin",
        "ZeroDirection",
        "NanDirection",
        "NegativeDistance",
        "NanTransform",
        "",
        "BadShape",
        "ZeroRotation",
    ];
    run_steps(&mut app, 5);
    let logs = common::take_logs();
    let errors: Vec<&String> = logs
        .iter()
        .filter(|(level, m)| *level == log::Level::Error && m.contains("casts nothing"))
        .map(|(_, m)| m)
        .collect();
    assert_eq!(errors.len(), casters.len(), "{errors:#?}");
    for (k, &caster) in casters.iter().enumerate() {
        let label = if names[k].is_empty() {
            format!("{caster}")
        } else {
            format!("{:?}", names[k])
        };
        assert_eq!(
            errors.iter().filter(|m| m.contains(&label)).count(),
            1,
            "{label}: {errors:#?}"
        );
        let empty = match app.world().get::<RayHits>(caster) {
            Some(hits) => hits.is_empty(),
            None => app.world().get::<ShapeHits>(caster).unwrap().is_empty(),
        };
        assert!(empty, "{label} has hits");
    }
    // Fixed, it hits (1 m down to the ground) and logs nothing; broken again, it logs again.
    app.world_mut()
        .get_mut::<RayCaster>(casters[0])
        .unwrap()
        .origin = Vec3::Y;
    run_steps(&mut app, 2);
    let hits = app.world().get::<RayHits>(casters[0]).unwrap();
    assert_eq!(hits.len(), 1);
    assert_eq!(hits[0].distance, 1.0);
    app.world_mut()
        .get_mut::<RayCaster>(casters[0])
        .unwrap()
        .origin = Vec3::INFINITY;
    run_steps(&mut app, 3);
    let again: Vec<String> = common::take_logs()
        .into_iter()
        .filter(|(level, _)| *level == log::Level::Error)
        .map(|(_, m)| m)
        .collect();
    assert_eq!(again.len(), 1, "{again:#?}");
    assert!(again[0].contains("NanOrigin"));
}

// ---------------------------------------------------------------------------------------------
// The random world and the brute-force answers.

/// A fixed linear congruential sequence, so the world and the queries are reproducible.
struct Lcg(u32);

impl Lcg {
    /// In [0, 1).
    fn next(&mut self) -> f32 {
        self.0 = self.0.wrapping_mul(1664525).wrapping_add(1013904223);
        (self.0 >> 8) as f32 / (1u32 << 24) as f32
    }

    fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.next()
    }

    fn below(&mut self, n: usize) -> usize {
        ((self.next() * n as f32) as usize).min(n - 1)
    }

    /// A point of the region the world fills and a margin around it.
    fn point(&mut self) -> Vec3 {
        Vec3::new(
            self.range(-18.0, 18.0),
            self.range(-1.0, 12.0),
            self.range(-18.0, 18.0),
        )
    }

    fn direction(&mut self) -> Dir3 {
        loop {
            let v = Vec3::new(
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
            );
            if let Ok(d) = Dir3::new(v)
                && v.length() > 0.1
            {
                return d;
            }
        }
    }

    fn rotation(&mut self) -> Quat {
        Quat::from_euler(
            EulerRot::XYZ,
            self.range(-3.0, 3.0),
            self.range(-3.0, 3.0),
            self.range(-3.0, 3.0),
        )
    }

    fn collider(&mut self) -> Collider {
        let s = |r: &mut Lcg| r.range(0.15, 0.8);
        match self.below(8) {
            0 => Collider::sphere(s(self)),
            1 => Collider::cuboid(s(self), s(self), s(self)),
            2 => Collider::capsule(s(self) * 0.6, s(self)),
            3 => Collider::cylinder(s(self), 2.0 * s(self)),
            4 => Collider::cone(s(self), 2.0 * s(self)),
            5 => Collider::round_cuboid(s(self), s(self), s(self), 0.05),
            6 => {
                let points: Vec<Vec3> = (0..10)
                    .map(|_| {
                        Vec3::new(
                            self.range(-0.6, 0.6),
                            self.range(-0.6, 0.6),
                            self.range(-0.6, 0.6),
                        )
                    })
                    .collect();
                Collider::convex_hull(&points).unwrap_or_else(|| Collider::sphere(0.4))
            }
            _ => Collider::compound(vec![
                (
                    Vec3::new(0.5, 0.0, 0.0),
                    self.rotation(),
                    Collider::cuboid(0.4, 0.2, 0.3),
                ),
                (
                    Vec3::new(-0.4, 0.2, 0.0),
                    Quat::IDENTITY,
                    Collider::sphere(0.35),
                ),
            ]),
        }
    }
}

/// The ground (a half-space), a triangle-mesh ramp, a heightfield, and `n` random bodies: about
/// half dynamic (thrown), a quarter static, the rest kinematic; one in 20 a sensor, one in 25
/// with a disabled collider, layers 0, 1 or 2.
fn random_world(world: &mut World, rng: &mut Lcg, n: usize) {
    spawn_static(world, Collider::half_space(Vec3::Y), Transform::IDENTITY);
    spawn_static(
        world,
        quad([
            Vec3::new(-3.0, 0.0, -3.0),
            Vec3::new(3.0, 2.0, -3.0),
            Vec3::new(3.0, 2.0, 3.0),
            Vec3::new(-3.0, 0.0, 3.0),
        ]),
        Transform::from_xyz(-12.0, 0.0, -12.0),
    );
    let heights: Vec<Vec<f32>> = (0..9)
        .map(|i| (0..9).map(|j| 0.1 * ((i * 3 + j) % 5) as f32).collect())
        .collect();
    spawn_static(
        world,
        Collider::heightfield(heights, Vec3::new(8.0, 2.0, 8.0)),
        Transform::from_xyz(12.0, 0.0, 12.0),
    );
    for k in 0..n {
        let transform = Transform::from_translation(Vec3::new(
            rng.range(-15.0, 15.0),
            rng.range(0.8, 10.0),
            rng.range(-15.0, 15.0),
        ))
        .with_rotation(rng.rotation());
        let kind = match rng.below(4) {
            0 => RigidBody::Static,
            1 => RigidBody::Kinematic,
            _ => RigidBody::Dynamic,
        };
        let mut body = world.spawn((
            kind,
            rng.collider(),
            transform,
            LinearVelocity(Vec3::new(
                rng.range(-3.0, 3.0),
                rng.range(-3.0, 3.0),
                rng.range(-3.0, 3.0),
            )),
            AngularVelocity(Vec3::new(
                rng.range(-2.0, 2.0),
                rng.range(-2.0, 2.0),
                rng.range(-2.0, 2.0),
            )),
            CollisionLayers::new(1u32 << rng.below(3), LayerMask::ALL),
        ));
        if k % 20 == 7 {
            body.insert(Sensor);
        }
        if k % 25 == 11 {
            body.insert(ColliderDisabled);
        }
    }
}

/// `n` random static bodies on the ground (no motion: the same in any length unit).
fn random_static_world(world: &mut World, rng: &mut Lcg, n: usize) {
    spawn_static(world, Collider::half_space(Vec3::Y), Transform::IDENTITY);
    for _ in 0..n {
        let transform = Transform::from_translation(rng.point().with_y(rng.range(0.5, 8.0)))
            .with_rotation(rng.rotation());
        spawn_static(world, rng.collider(), transform);
    }
}

/// A collider as the brute force sees it: read from the components, at the pose of the
/// `Transform` (rotation normalised), as the next step would read it.
struct Body {
    entity: Entity,
    shape: SharedShape,
    pose: Pose,
    layers: CollisionLayers,
}

fn bodies(app: &mut App) -> Vec<Body> {
    let mut q = app
        .world_mut()
        .query_filtered::<(Entity, &Collider, &Transform, Option<&CollisionLayers>), (
            Without<ColliderDisabled>,
            Without<RigidBodyDisabled>,
            Without<Quarantined>,
        )>();
    let mut out: Vec<Body> = q
        .iter(app.world())
        .map(|(entity, c, t, layers)| Body {
            entity,
            shape: c.shape().clone(),
            pose: Pose::from_parts(t.translation, t.rotation.normalize()),
            layers: layers.copied().unwrap_or_default(),
        })
        .collect();
    out.sort_by_key(|b| b.entity);
    out
}

fn by_distance<T>(hits: &mut [T], key: impl Fn(&T) -> (f32, Entity)) {
    hits.sort_by(|a, b| {
        let (da, ea) = key(a);
        let (db, eb) = key(b);
        da.total_cmp(&db).then(ea.cmp(&eb))
    });
}

fn brute_ray_hits(
    bodies: &[Body],
    ray: &Ray,
    max: f32,
    solid: bool,
    filter: &SpatialQueryFilter,
) -> Vec<RayHitData> {
    let mut hits: Vec<RayHitData> = bodies
        .iter()
        .filter(|b| filter.test(b.entity, b.layers))
        .filter_map(|b| {
            let hit = exact::cast_ray(b.shape.as_ref(), &b.pose, ray, max, solid)?;
            Some(RayHitData {
                entity: b.entity,
                distance: hit.time_of_impact,
                normal: hit.normal,
                point: ray.point_at(hit.time_of_impact),
            })
        })
        .collect();
    by_distance(&mut hits, |h| (h.distance, h.entity));
    hits
}

#[allow(clippy::too_many_arguments)]
fn brute_shape_hits(
    bodies: &[Body],
    shape: &Collider,
    origin: Vec3,
    rotation: Quat,
    dir: Vec3,
    config: &ShapeCastConfig,
    filter: &SpatialQueryFilter,
) -> Vec<ShapeHitData> {
    let pose2 = Pose::from_parts(origin, rotation.normalize());
    let options = ShapeCastOptions {
        max_time_of_impact: config.max_distance,
        target_distance: config.target_distance,
        stop_at_penetration: !config.ignore_origin_penetration,
        compute_impact_geometry_on_penetration: config.compute_contact_on_penetration,
    };
    let mut hits: Vec<ShapeHitData> = bodies
        .iter()
        .filter(|b| filter.test(b.entity, b.layers))
        .filter_map(|b| {
            let hit = exact::cast_shape(
                &b.pose,
                b.shape.as_ref(),
                &pose2,
                dir,
                shape.shape().as_ref(),
                &options,
            )?;
            Some(ShapeHitData {
                entity: b.entity,
                distance: hit.distance,
                point1: hit.point1,
                point2: hit.point2,
                normal1: hit.normal1,
                normal2: hit.normal2,
            })
        })
        .collect();
    by_distance(&mut hits, |h| (h.distance, h.entity));
    hits
}

fn brute_projection(
    bodies: &[Body],
    point: Vec3,
    solid: bool,
    filter: &SpatialQueryFilter,
) -> Option<PointProjection> {
    let mut best: Option<(f32, PointProjection)> = None;
    for b in bodies.iter().filter(|b| filter.test(b.entity, b.layers)) {
        let p = b.shape.project_point(&b.pose, point, solid);
        let d = p.point.distance(point);
        if best.is_none_or(|(bd, bp)| d < bd || (d == bd && b.entity < bp.entity)) {
            best = Some((
                d,
                PointProjection {
                    entity: b.entity,
                    point: p.point,
                    is_inside: p.is_inside,
                },
            ));
        }
    }
    best.map(|(_, p)| p)
}

/// How many non-empty answers a comparison saw.
#[derive(Debug, Default)]
struct Counts {
    /// Bodies whose box at their pose had left their leaf's box in the broad phase's tree.
    stragglers: usize,
    ray_hits: usize,
    shape_hits: usize,
    points_inside: usize,
    shapes_overlapping: usize,
    boxes_overlapping: usize,
}

impl Counts {
    fn add(&mut self, o: Counts) {
        self.stragglers += o.stragglers;
        self.ray_hits += o.ray_hits;
        self.shape_hits += o.shape_hits;
        self.points_inside += o.points_inside;
        self.shapes_overlapping += o.shapes_overlapping;
        self.boxes_overlapping += o.boxes_overlapping;
    }
}

fn random_filter(rng: &mut Lcg, bodies: &[Body]) -> SpatialQueryFilter {
    let mask = [LayerMask::ALL, LayerMask(0b001), LayerMask(0b110)][rng.below(3)];
    let excluded: Vec<Entity> = (0..rng.below(4))
        .map(|_| bodies[rng.below(bodies.len())].entity)
        .collect();
    SpatialQueryFilter::from_mask(mask).with_excluded_entities(excluded)
}

/// The bodies whose box at their pose is not inside their leaf's box in the broad phase's tree
/// (they moved out of the box the step's broad phase gave them): a query must find them all
/// the same.
fn stragglers(app: &App, bodies: &[Body]) -> Vec<Vec3> {
    let tree = app.world().resource::<BroadPhaseTree>();
    bodies
        .iter()
        .filter_map(|b| {
            let leaf = tree.bvh().leaf_node(tree.leaf(b.entity)?)?.aabb();
            (!leaf.contains(&b.shape.compute_aabb(&b.pose))).then_some(b.pose.translation)
        })
        .collect()
}

fn compare_with_brute_force(app: &mut App, rng: &mut Lcg) -> Counts {
    let bodies = bodies(app);
    let mut counts = Counts::default();
    // Rays at the stragglers first, then random ones.
    let aimed = stragglers(app, &bodies);
    counts.stragglers = aimed.len();
    for k in 0..200 + aimed.len() {
        let (origin, dir) = match aimed.get(k) {
            Some(&at) => {
                let dir = rng.direction();
                (at - dir.as_vec3() * 3.0, dir)
            }
            None => (rng.point(), rng.direction()),
        };
        let max = if k % 5 == 0 {
            f32::MAX
        } else {
            rng.range(2.0, 40.0)
        };
        let solid = k % 3 != 0;
        let filter = random_filter(rng, &bodies);
        let expected = brute_ray_hits(
            &bodies,
            &Ray::new(origin, dir.as_vec3()),
            max,
            solid,
            &filter,
        );
        let (first, hits, three) = with_query(app, move |q| {
            (
                q.cast_ray(origin, dir, max, solid, &filter),
                q.ray_hits(origin, dir, max, u32::MAX, solid, &filter),
                q.ray_hits(origin, dir, max, 3, solid, &filter),
            )
        });
        assert_eq!(hits, expected, "ray {k} from {origin} along {dir:?}");
        assert_eq!(first, expected.first().copied(), "ray {k}");
        assert_eq!(three, expected[..expected.len().min(3)].to_vec());
        counts.ray_hits += expected.len();
    }
    for k in 0..60 {
        let (origin, dir, rotation) = (rng.point(), rng.direction(), rng.rotation());
        let shape = rng.collider();
        let config = ShapeCastConfig {
            max_distance: if k % 4 == 0 {
                f32::MAX
            } else {
                rng.range(2.0, 30.0)
            },
            target_distance: if k % 3 == 0 { 0.1 } else { 0.0 },
            compute_contact_on_penetration: true,
            ignore_origin_penetration: k % 5 == 0,
        };
        let filter = random_filter(rng, &bodies);
        let expected = brute_shape_hits(
            &bodies,
            &shape,
            origin,
            rotation,
            dir.as_vec3(),
            &config,
            &filter,
        );
        let (first, hits) = with_query(app, move |q| {
            (
                q.cast_shape(&shape, origin, rotation, dir, &config, &filter),
                q.shape_hits(&shape, origin, rotation, dir, u32::MAX, &config, &filter),
            )
        });
        assert_eq!(hits, expected, "shape cast {k} from {origin} along {dir:?}");
        assert_eq!(first, expected.first().copied(), "shape cast {k}");
        counts.shape_hits += expected.len();
    }
    for k in 0..100 + aimed.len() {
        // Points at the stragglers' origins, then half of them near a body's origin, where
        // they are often inside it.
        let point = if let Some(&at) = aimed.get(k) {
            at
        } else if k % 2 == 1 {
            bodies[rng.below(bodies.len())].pose.translation
                + rng.direction().as_vec3() * rng.range(0.0, 0.4)
        } else {
            rng.point()
        };
        let solid = k % 2 == 0;
        let filter = random_filter(rng, &bodies);
        let projection = brute_projection(&bodies, point, solid, &filter);
        let mut inside: Vec<Entity> = bodies
            .iter()
            .filter(|b| filter.test(b.entity, b.layers) && b.shape.contains_point(&b.pose, point))
            .map(|b| b.entity)
            .collect();
        inside.sort_unstable();
        let (got_projection, got_inside) = with_query(app, move |q| {
            (
                q.project_point(point, solid, &filter),
                q.point_intersections(point, &filter),
            )
        });
        assert_eq!(got_projection, projection, "point {k} at {point}");
        assert_eq!(got_inside, inside, "point {k} at {point}");
        counts.points_inside += inside.len();
    }
    for k in 0..40 {
        let (position, rotation) = (rng.point(), rng.rotation());
        let shape = Collider::cuboid(
            rng.range(0.3, 2.0),
            rng.range(0.3, 2.0),
            rng.range(0.3, 2.0),
        );
        let filter = random_filter(rng, &bodies);
        let pose = Pose::from_parts(position, rotation.normalize());
        let overlapping: Vec<Entity> = bodies
            .iter()
            .filter(|b| {
                filter.test(b.entity, b.layers)
                    && parry3d::query::intersection_test(
                        &b.pose,
                        b.shape.as_ref(),
                        &pose,
                        shape.shape().as_ref(),
                    )
                    .unwrap_or(false)
            })
            .map(|b| b.entity)
            .collect();
        let got = with_query(app, move |q| {
            q.shape_intersections(&shape, position, rotation, &filter)
        });
        assert_eq!(got, overlapping, "shape {k} at {position}");
        counts.shapes_overlapping += overlapping.len();

        let (center, half) = (
            rng.point(),
            Vec3::new(
                rng.range(0.1, 3.0),
                rng.range(0.1, 3.0),
                rng.range(0.1, 3.0),
            ),
        );
        let query = Aabb::new(center - half, center + half);
        let overlapping: Vec<Entity> = bodies
            .iter()
            .filter(|b| b.shape.compute_aabb(&b.pose).intersects(&query))
            .map(|b| b.entity)
            .collect();
        let got = with_query(app, move |q| {
            q.aabb_intersections_with_aabb(ColliderAabb::new(center, half))
        });
        assert_eq!(got, overlapping, "box {k} about {center}");
        counts.boxes_overlapping += overlapping.len();
    }
    counts
}
