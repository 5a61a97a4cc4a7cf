//! `PhysicsDebugPlugin` headless (feature `debug`): known scenes, and the lines the plugin
//! records counted against what each shape's wireframe must have.
//!
//! Run with `cargo test --features debug --test debug_draw`.

use std::any::TypeId;
use std::f32::consts::FRAC_PI_2;

use bevy::color::palettes::css;
use bevy::gizmos::{GizmoAsset, GizmoHandles, GizmoPlugin};
use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use impact3d::collision::ContactPairs;
use impact3d::debug::PhysicsGizmoGroup;
use impact3d::prelude::*;
use impact3d::scenes;

/// `MinimalPlugins` plus what gizmos need, impact3d and its debug plugin; each `update()` runs
/// one fixed step of 1/60 s (the first, start-recording update has run).
fn app(config: PhysicsGizmos) -> App {
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins,
        AssetPlugin::default(),
        TransformPlugin,
        bevy::mesh::MeshPlugin,
        GizmoPlugin,
        PhysicsPlugins::default(),
        PhysicsDebugPlugin,
    ))
    .insert_resource(config)
    .insert_resource(Time::<Fixed>::from_hz(60.0))
    .insert_resource(TimeUpdateStrategy::FixedTimesteps(1));
    app.update();
    app
}

/// Only the given layers on.
fn layers(colliders: bool, contacts: bool, impacts: bool, velocities: bool) -> PhysicsGizmos {
    PhysicsGizmos {
        colliders,
        aabbs: false,
        contacts,
        impacts,
        velocities,
        islands: false,
        ..default()
    }
}

/// The segments recorded in impact3d's gizmo group in the last update, as (start, end, colour
/// of start). The public route to them: `GizmoHandles` names the group's `GizmoAsset`.
fn segments(app: &App) -> Vec<(Vec3, Vec3, LinearRgba)> {
    let handles = app.world().resource::<GizmoHandles>();
    let Some(Some(handle)) = handles.handles().get(&TypeId::of::<PhysicsGizmoGroup>()) else {
        return Vec::new();
    };
    let asset = app
        .world()
        .resource::<Assets<GizmoAsset>>()
        .get(handle)
        .expect("the group's gizmo asset");
    let buffer = asset.buffer();
    assert!(
        buffer.strip_positions.is_empty(),
        "impact3d draws segments only"
    );
    assert_eq!(buffer.list_positions.len(), buffer.list_colors.len());
    buffer
        .list_positions
        .chunks(2)
        .zip(buffer.list_colors.chunks(2))
        .map(|(p, c)| (p[0], p[1], c[0]))
        .collect()
}

fn count_color(segments: &[(Vec3, Vec3, LinearRgba)], color: impl Into<Color>) -> usize {
    let c = color.into().to_linear();
    segments.iter().filter(|s| s.2 == c).count()
}

/// Every shape impact3d has, in every state, far apart in zero gravity: the segment count is
/// the sum of each wireframe's count (sphere 3 circles x 24, cuboid 12, capsule 4 x 24 + 4,
/// tetrahedron hull 6 edges, two-triangle quad mesh 5 distinct edges, half-space patch 2 x 11
/// grid lines), and each state has its colour.
#[test]
fn every_shape_and_state_has_its_wireframe() {
    let mut app = app(layers(true, true, true, false));
    let world = app.world_mut();
    world.insert_resource(Gravity(Vec3::ZERO));
    let dynamic = |collider: Collider, x: f32| {
        (
            RigidBody::Dynamic,
            collider,
            Transform::from_xyz(x, 0.0, 0.0),
        )
    };
    world.spawn((
        RigidBody::Static,
        Collider::half_space(Vec3::Y),
        Transform::from_xyz(0.0, -50.0, 0.0),
    ));
    world.spawn(dynamic(Collider::sphere(0.5), 0.0));
    world.spawn(dynamic(Collider::cuboid(0.5, 0.5, 0.5), 5.0));
    world.spawn(dynamic(Collider::capsule(0.3, 0.5), 10.0));
    let tetrahedron = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z];
    world.spawn(dynamic(Collider::convex_hull(&tetrahedron).unwrap(), 15.0));
    world.spawn((
        RigidBody::Static,
        Collider::trimesh(
            vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 0.0, 1.0), Vec3::Z],
            vec![[0, 1, 2], [0, 2, 3]],
        ),
        Transform::from_xyz(20.0, 0.0, 0.0),
    ));
    world.spawn((
        RigidBody::Kinematic,
        Collider::cuboid(0.5, 0.5, 0.5),
        Transform::from_xyz(25.0, 0.0, 0.0),
    ));
    world.spawn((
        dynamic(Collider::cuboid(0.5, 0.5, 0.5), 30.0),
        Sleeping::default(),
    ));
    // A bad collider: quarantined in the first step, drawn as its placeholder (a unit sphere).
    world.spawn(dynamic(Collider::sphere(-1.0), 35.0));
    world.spawn((
        dynamic(Collider::cuboid(0.5, 0.5, 0.5), 40.0),
        DebugRender::hidden(),
    ));
    world.spawn((
        dynamic(Collider::cuboid(0.5, 0.5, 0.5), 45.0),
        DebugRender::colored(css::LIME),
    ));
    app.update();

    let s = segments(&app);
    let n = 24;
    let (sphere, cuboid, capsule, hull, quad, patch) = (3 * n, 12, 4 * n + 4, 6, 5, 2 * 11);
    let config = PhysicsGizmos::default();
    assert_eq!(
        count_color(&s, config.dynamic_color),
        sphere + cuboid + capsule + hull
    );
    assert_eq!(count_color(&s, config.static_color), patch + quad);
    assert_eq!(count_color(&s, config.kinematic_color), cuboid);
    assert_eq!(count_color(&s, config.sleeping_color), cuboid);
    assert_eq!(count_color(&s, config.quarantined_color), sphere);
    assert_eq!(count_color(&s, css::LIME), cuboid);
    assert_eq!(
        s.len(),
        sphere + cuboid + capsule + hull + patch + quad + cuboid + cuboid + sphere + cuboid,
        "nothing else is drawn (no contacts, no impacts, the hidden cube)"
    );
    // The lime cube's segments join its corners (45 +- 0.5, +-0.5, +-0.5), each an edge of
    // length 1 (tolerance 1e-6: f32 rounding of the pose transform).
    for (a, b, _) in s
        .iter()
        .filter(|x| x.2 == Color::from(css::LIME).to_linear())
    {
        for p in [a, b] {
            let d = (*p - Vec3::new(45.0, 0.0, 0.0)).abs();
            assert!((d - Vec3::splat(0.5)).abs().max_element() < 1e-6, "{p}");
        }
        assert!(((*a - *b).length() - 1.0).abs() < 1e-6);
    }
    // Sphere points lie on the sphere of radius 0.5 about the origin (tolerance 1e-6).
    let orange = config.dynamic_color.to_linear();
    for (a, _, _) in s.iter().filter(|x| x.2 == orange && x.0.x.abs() < 1.0) {
        assert!((a.length() - 0.5).abs() < 1e-6, "{a}");
    }
}

/// The shapes beyond the first six: cylinder (two rings of 24 and 4 side lines), cone (a ring
/// and 4 lines to the apex), rounded box (inner and outer box, 24), compound of two boxes
/// (each 12), heightfield of 3 x 3 samples (2 x 2 cells: 6 + 6 grid edges and 4 diagonals,
/// 16). Every point of the cylinder's wireframe lies on its surface: at radius 0.4 from its
/// axis and at +-0.5 (tolerance 1e-5, f32 rounding of sines and cosines times 0.4).
#[test]
fn new_shapes_have_their_wireframes() {
    let mut app = app(layers(true, false, false, false));
    let world = app.world_mut();
    world.insert_resource(Gravity(Vec3::ZERO));
    let dynamic = |collider: Collider, x: f32| {
        (
            RigidBody::Dynamic,
            collider,
            Transform::from_xyz(x, 0.0, 0.0),
        )
    };
    world.spawn(dynamic(Collider::cylinder(0.4, 1.0), 0.0));
    world.spawn(dynamic(Collider::cone(0.4, 1.0), 5.0));
    world.spawn(dynamic(Collider::round_cuboid(1.0, 1.0, 1.0, 0.1), 10.0));
    world.spawn(dynamic(
        Collider::compound(vec![
            (Vec3::ZERO, Quat::IDENTITY, Collider::cuboid(0.5, 0.5, 0.5)),
            (Vec3::Y, Quat::IDENTITY, Collider::cuboid(0.25, 0.25, 0.25)),
        ]),
        15.0,
    ));
    world.spawn((
        RigidBody::Static,
        Collider::heightfield(vec![vec![0.0; 3]; 3], Vec3::new(2.0, 1.0, 2.0)),
        Transform::from_xyz(20.0, 0.0, 0.0),
    ));
    app.update();
    let s = segments(&app);
    let n = 24;
    let config = PhysicsGizmos::default();
    assert_eq!(
        count_color(&s, config.dynamic_color),
        (2 * n + 4) + (n + 4) + 24 + 24
    );
    assert_eq!(count_color(&s, config.static_color), 16);
    for (a, b, _) in s.iter().filter(|x| x.0.x.abs() < 1.0 && x.1.x.abs() < 1.0) {
        for p in [a, b] {
            assert!((p.xz().length() - 0.4).abs() < 1e-5, "{p}");
            assert!((p.y.abs() - 0.5).abs() < 1e-5, "{p}");
        }
    }
}

/// The bounding-box layer adds 12 segments per bounded collider (half-spaces have none), each
/// of them along a world axis.
#[test]
fn aabbs_are_twelve_axis_aligned_segments_per_bounded_body() {
    let mut app = app(PhysicsGizmos {
        aabbs: true,
        ..layers(false, false, false, false)
    });
    let world = app.world_mut();
    world.insert_resource(Gravity(Vec3::ZERO));
    scenes::ground(world);
    for i in 0..3 {
        world.spawn((
            RigidBody::Dynamic,
            Collider::cuboid(0.5, 0.5, 0.5),
            Transform::from_xyz(3.0 * i as f32, 5.0, 0.0).with_rotation(Quat::from_rotation_z(0.3)),
        ));
    }
    app.update();
    let s = segments(&app);
    assert_eq!(s.len(), 3 * 12);
    for (a, b, _) in &s {
        let d = (*a - *b).abs();
        let nonzero = [d.x, d.y, d.z].iter().filter(|&&c| c > 1e-6).count();
        assert_eq!(nonzero, 1, "{a} -> {b} is along one axis");
    }
}

/// A 1 m cube resting on the ground has its four bottom corners as contact points: a cross
/// (3 segments) and a normal (1) each, the normals `normal_length` = 0.3 m long along y, from
/// the pair's first body to its second (up if the ground is the first).
#[test]
fn resting_box_draws_four_contacts() {
    let mut app = app(layers(false, true, false, false));
    let (ground, cube) = scenes::resting_box(app.world_mut(), 0.0);
    scenes::run_steps(&mut app, 10);
    let pair = app.world().resource::<ContactPairs>();
    let up = if pair.get(ground, cube).unwrap().a == ground {
        1.0
    } else {
        -1.0
    };
    let s = segments(&app);
    let config = PhysicsGizmos::default();
    assert_eq!(count_color(&s, config.contact_color), 4 * 3);
    let normals: Vec<_> = s
        .iter()
        .filter(|x| x.2 == config.normal_color.to_linear())
        .collect();
    assert_eq!(normals.len(), 4);
    for (a, b, _) in normals {
        // Corners at x, z = +-0.5, at the ground (the cube sinks 0.28 mm; tolerance 1 mm).
        assert!(
            (a.x.abs() - 0.5).abs() < 1e-3 && (a.z.abs() - 0.5).abs() < 1e-3,
            "{a}"
        );
        assert!(a.y.abs() < 1e-3, "{a}");
        assert!(
            (*b - *a - Vec3::new(0.0, 0.3 * up, 0.0)).length() < 1e-5,
            "{a} -> {b}"
        );
    }
    assert_eq!(s.len(), 16);
}

/// Touching is counted in the world's length unit, as the physics step counts it: with
/// `PhysicsLengthUnit(1e-3)` (touch distance 5 um, contact margin 20 um), a 1 mm die held 2 um
/// above the ground (no gravity) draws its four bottom corners, one 10 um above draws none,
/// though parry reports its corners (within the margin).
#[test]
fn contacts_touch_in_the_length_unit() {
    for (gap, drawn) in [(2e-6, 4), (1e-5, 0)] {
        let mut app = app(layers(false, true, false, false));
        app.insert_resource(PhysicsLengthUnit(1e-3))
            .insert_resource(Gravity(Vec3::ZERO));
        scenes::ground(app.world_mut());
        let die = app
            .world_mut()
            .spawn((
                RigidBody::Dynamic,
                Collider::cuboid(5e-4, 5e-4, 5e-4),
                Transform::from_xyz(0.0, 5e-4 + gap, 0.0),
            ))
            .id();
        app.update();
        let pair = app.world().resource::<ContactPairs>();
        let reported: usize = pair
            .iter()
            .filter(|p| p.a == die || p.b == die)
            .map(|p| p.manifolds.iter().map(|m| m.points.len()).sum::<usize>())
            .sum();
        assert!(reported >= 4, "gap {gap}: parry reports {reported} points");
        let s = segments(&app);
        let config = PhysicsGizmos::default();
        assert_eq!(
            count_color(&s, config.contact_color),
            drawn * 3,
            "gap {gap}"
        );
    }
}

/// Head-on impact (case 1, e = 1): m1 = 1 kg at 2 m/s meets m2 = 3 kg at -1 m/s, so
/// `j = (1 + e) 3 / (1/1 + 1/3) = 4.5 N s`, drawn as an arrow (3 segments) of `0.1 x 4.5` m
/// from the contact point (x = 0.5) along the line of centres (x), its alpha `1 - age`; it is
/// gone after a second.
/// The velocities afterwards (-2.5 and 0.5 m/s) are arrows of `0.1 x |v|`.
#[test]
fn impact_arrow_fades_and_velocities_are_drawn() {
    let mut app = app(PhysicsGizmos {
        impulse_scale: 0.1,
        ..layers(false, false, true, true)
    });
    scenes::head_on(app.world_mut(), 1.0);
    app.update();
    let s = segments(&app);
    let config = PhysicsGizmos::default();
    let impact: Vec<_> = s
        .iter()
        .filter(|x| x.2.with_alpha(1.0) == config.impact_color.to_linear())
        .collect();
    assert_eq!(impact.len(), 3, "one impact, one arrow");
    let (a, b, c) = impact[0];
    // Tolerance 1e-4 m: the solver's f32 impulse and the contact midpoint.
    assert!((*a - Vec3::new(0.5, 0.0, 0.0)).length() < 1e-4, "{a}");
    assert!(((b.x - a.x).abs() - 0.45).abs() < 1e-4, "{a} -> {b}");
    assert!(
        (b.y - a.y).abs() < 1e-6 && (b.z - a.z).abs() < 1e-6,
        "{a} -> {b}"
    );
    assert_eq!(c.alpha, 1.0);
    let shafts: Vec<f32> = s
        .iter()
        .filter(|x| x.2 == config.velocity_color.to_linear())
        .map(|x| (x.1 - x.0).length())
        .collect();
    assert_eq!(shafts.len(), 2 * 3, "two linear arrows, no angular ones");
    let mut lengths = vec![shafts[0], shafts[3]];
    lengths.sort_by(f32::total_cmp);
    assert!(
        (lengths[0] - 0.05).abs() < 1e-4 && (lengths[1] - 0.25).abs() < 1e-4,
        "{lengths:?}"
    );

    // 30 steps (0.5 s) later the arrow is at half alpha (tolerance 1e-3, f32 sums of 1/60).
    scenes::run_steps(&mut app, 30);
    let fading: Vec<_> = segments(&app)
        .into_iter()
        .filter(|x| x.2.with_alpha(1.0) == config.impact_color.to_linear())
        .collect();
    assert_eq!(fading.len(), 3);
    assert!(
        (fading[0].2.alpha - 0.5).abs() < 1e-3,
        "{}",
        fading[0].2.alpha
    );
    // After 1 s (the edge at exactly 60 steps is left alone: f32 sums of 1/60), nothing.
    scenes::run_steps(&mut app, 32);
    let left = segments(&app)
        .into_iter()
        .filter(|x| x.2.with_alpha(1.0) == config.impact_color.to_linear())
        .count();
    assert_eq!(left, 0);
}

/// Three cubes stacked on the ground fall asleep as one island: the island layer draws a line
/// from each sleeper to the one the island is named after, two lines.
#[test]
fn sleeping_island_links() {
    let mut app = app(PhysicsGizmos {
        islands: true,
        ..layers(false, false, false, false)
    });
    let cubes = scenes::stack(app.world_mut(), 3);
    scenes::run_steps(&mut app, 120);
    for &c in &cubes {
        assert!(
            app.world().get::<Sleeping>(c).is_some(),
            "precondition: asleep"
        );
    }
    let s = segments(&app);
    assert_eq!(count_color(&s, PhysicsGizmos::default().island_color), 2);
    assert_eq!(s.len(), 2);
}

/// Every layer off: nothing recorded.
#[test]
fn all_layers_off_draw_nothing() {
    let mut app = app(layers(false, false, false, false));
    scenes::resting_box(app.world_mut(), 0.0);
    scenes::run_steps(&mut app, 3);
    assert!(segments(&app).is_empty());
}

/// Colliders are drawn where the physics has them: a child collider at its world pose (its
/// body at (10, 0, 0) turned 90 degrees about y, the child cube 2 m along the body's x: centred
/// at (10, 0, -2), `R x = (0, 0, -1)`), in its body's colour unless it has its own; and a
/// collider scaled with its `Transform` (a cube of half extent 0.5 scaled (2, 1, 1): half
/// extents (1, 0.5, 0.5) about (20, 0, 0)). Each cube's 12 segments join its corners
/// (tolerance 1e-5: f32 rounding of the composed poses).
#[test]
fn child_and_scaled_colliders_are_drawn_where_the_physics_has_them() {
    let mut app = app(layers(true, false, false, false));
    let world = app.world_mut();
    world.insert_resource(Gravity(Vec3::ZERO));
    let body = world
        .spawn((
            RigidBody::Dynamic,
            Transform::from_xyz(10.0, 0.0, 0.0).with_rotation(Quat::from_rotation_y(FRAC_PI_2)),
        ))
        .id();
    world.spawn((
        Collider::cuboid(0.5, 0.5, 0.5),
        Transform::from_xyz(2.0, 0.0, 0.0),
        DebugRender::colored(css::LIME),
        ChildOf(body),
    ));
    world.spawn((
        Collider::cuboid(0.5, 0.5, 0.5),
        Transform::from_xyz(-2.0, 0.0, 0.0),
        ChildOf(body),
    ));
    world.spawn((
        RigidBody::Dynamic,
        Collider::cuboid(0.5, 0.5, 0.5),
        Transform::from_xyz(20.0, 0.0, 0.0).with_scale(Vec3::new(2.0, 1.0, 1.0)),
        DebugRender::colored(css::AQUA),
    ));
    app.update();
    app.update();

    let s = segments(&app);
    let corners_of = |color: Srgba, center: Vec3, half: Vec3| {
        let c = Color::from(color).to_linear();
        let drawn: Vec<_> = s.iter().filter(|x| x.2 == c).collect();
        assert_eq!(drawn.len(), 12, "a cube's 12 edges in {color:?}");
        for (a, b, _) in drawn {
            for p in [a, b] {
                let d = (*p - center).abs();
                assert!(
                    (d - half).abs().max_element() < 1e-5,
                    "{p} is no corner of the box about {center}"
                );
            }
        }
    };
    corners_of(css::LIME, Vec3::new(10.0, 0.0, -2.0), Vec3::splat(0.5));
    corners_of(
        css::AQUA,
        Vec3::new(20.0, 0.0, 0.0),
        Vec3::new(1.0, 0.5, 0.5),
    );
    // The other child is its dynamic body's colour, about (10, 0, 2).
    let config = PhysicsGizmos::default();
    let orange = config.dynamic_color.to_linear();
    let other: Vec<_> = s.iter().filter(|x| x.2 == orange).collect();
    assert_eq!(other.len(), 12);
    for (a, _, _) in other {
        let d = (*a - Vec3::new(10.0, 0.0, 2.0)).abs();
        assert!((d - Vec3::splat(0.5)).abs().max_element() < 1e-5, "{a}");
    }
}
