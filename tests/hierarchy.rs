//! Colliders on child entities (compound bodies), bodies under non-physics parents, and
//! `Transform` scale (issue 12): mass properties against the parallel-axis theorem worked by
//! hand and against `Collider::compound`, resting heights from the geometry, trajectories
//! against the same body built as one compound, world poses against `parent * local`, and bad
//! scales contained.

mod common;

use bevy::math::DMat3;
use bevy::prelude::*;
use common::*;
use impact3d::prelude::*;
use impact3d::scenes::{self, headless_app, run_steps};
use std::f32::consts::PI;

/// Solid box of half extents `h` and mass `m`: its inertia about its centre, in its own axes.
fn box_inertia(m: f64, h: DVec3) -> DMat3 {
    DMat3::from_diagonal(
        m / 3.0
            * DVec3::new(
                h.y * h.y + h.z * h.z,
                h.x * h.x + h.z * h.z,
                h.x * h.x + h.y * h.y,
            ),
    )
}

use bevy::math::DVec3;

/// The parallel-axis shift of mass `m` at offset `d` from the centre of mass:
/// `m (|d|^2 E - d d^T)`.
fn shift(m: f64, d: DVec3) -> DMat3 {
    let outer = DMat3::from_cols(d * d.x, d * d.y, d * d.z);
    (DMat3::IDENTITY * d.length_squared() - outer) * m
}

/// The two boxes of the mass test: a slab of half extents (0.5, 0.25, 0.5) at the body's
/// origin and a bar of half extents (0.4, 0.1, 0.2) at (0.25, 0.6, 0.1), turned 30 degrees
/// about z.
fn two_boxes() -> [(Vec3, Quat, Vec3); 2] {
    [
        (Vec3::ZERO, Quat::IDENTITY, Vec3::new(0.5, 0.25, 0.5)),
        (
            Vec3::new(0.25, 0.6, 0.1),
            Quat::from_rotation_z(PI / 6.0),
            Vec3::new(0.4, 0.1, 0.2),
        ),
    ]
}

/// A body (no collider of its own) with the two boxes as child colliders, and the same body as
/// one `Collider::compound`, both density 1000: the mass, centre of mass and inertia tensor
/// are the parallel-axis sum worked out here in f64, and the two bodies agree bit for bit.
#[test]
fn child_boxes_sum_by_the_parallel_axis_theorem() {
    let mut app = headless_app(60.0);
    // Gravity off: the bodies stay where they are while the masses are read.
    app.insert_resource(Gravity(Vec3::ZERO));
    let boxes = two_boxes();
    let children = app
        .world_mut()
        .spawn((RigidBody::Dynamic, Transform::from_xyz(-5.0, 0.0, 0.0)))
        .with_children(|parent| {
            for (at, turn, h) in boxes {
                parent.spawn((
                    Collider::cuboid(h.x, h.y, h.z),
                    Transform::from_translation(at).with_rotation(turn),
                ));
            }
        })
        .id();
    let compound = app
        .world_mut()
        .spawn((
            RigidBody::Dynamic,
            Collider::compound(
                boxes
                    .iter()
                    .map(|&(at, turn, h)| (at, turn, Collider::cuboid(h.x, h.y, h.z)))
                    .collect(),
            ),
            Transform::from_xyz(5.0, 0.0, 0.0),
        ))
        .id();
    run_steps(&mut app, 1);

    // By hand: each box's mass rho 8 hx hy hz, its centre, its inertia R I R^T, shifted to
    // the common centre of mass.
    let rho = 1000.0;
    let parts: Vec<(f64, DVec3, DMat3)> = boxes
        .iter()
        .map(|&(at, turn, h)| {
            let h = h.as_dvec3();
            let m = rho * 8.0 * h.x * h.y * h.z;
            let r = DMat3::from_quat(turn.as_dquat());
            (m, at.as_dvec3(), r * box_inertia(m, h) * r.transpose())
        })
        .collect();
    let total: f64 = parts.iter().map(|p| p.0).sum();
    let com = parts.iter().map(|p| p.1 * p.0).sum::<DVec3>() / total;
    let inertia = parts
        .iter()
        .fold(DMat3::ZERO, |acc, &(m, at, i)| acc + i + shift(m, at - com));

    let computed = *app.world().get::<ComputedMass>(children).unwrap();
    // Tolerances: relative 1e-5 on the mass and centre (a few f32 roundings of products of
    // the half extents); 1e-4 of the largest entry on the tensor, which parry stores as
    // principal moments and axes (an f32 eigen-decomposition, then inverted here): measured
    // 2e-6.
    let mass = 1.0 / computed.inverse_mass as f64;
    assert!((mass - total).abs() <= 1e-5 * total, "{mass} vs {total}");
    let c = computed.local_center_of_mass.as_dvec3();
    assert!((c - com).length() <= 1e-5, "{c} vs {com}");
    let got = computed.local_inverse_inertia.as_dmat3().inverse();
    let scale = inertia
        .to_cols_array()
        .iter()
        .fold(0.0f64, |a, x| a.max(x.abs()));
    let error = (got - inertia)
        .to_cols_array()
        .iter()
        .fold(0.0f64, |a, x| a.max(x.abs()));
    assert!(error <= 1e-4 * scale, "{got} vs {inertia}: {error}");
    // The off-diagonal terms are there (the parts are offset in x and y, one is turned).
    assert!(inertia.x_axis.y.abs() > 1.0);

    // The same body as one compound: the same numbers, bit for bit (the same parts in the
    // same order, summed the same way).
    assert_eq!(
        computed,
        *app.world().get::<ComputedMass>(compound).unwrap()
    );
    assert_eq!(
        app.world()
            .get::<ColliderOf>(app.world().get::<Children>(children).unwrap()[0]),
        Some(&ColliderOf { body: children })
    );
}

/// A table of child colliders (a top and two legs reaching 1 m below the body's origin)
/// dropped from 0.3 m above its resting height rests with its origin at 1 m (the legs' feet
/// on the ground), steps bit for bit as the same table built as one `Collider::compound`, and
/// falls asleep.
#[test]
fn child_colliders_rest_on_their_lowest_part_as_the_compound_does() {
    let parts = [
        (Vec3::new(0.0, 0.1, 0.0), Vec3::new(0.8, 0.1, 0.3)),
        (Vec3::new(0.6, -0.5, 0.0), Vec3::new(0.1, 0.5, 0.1)),
        (Vec3::new(-0.6, -0.5, 0.0), Vec3::new(0.1, 0.5, 0.1)),
    ];
    let run = |as_children: bool| {
        let mut app = headless_app(60.0);
        scenes::ground(app.world_mut());
        let start = Transform::from_xyz(0.0, 1.3, 0.0);
        let body = if as_children {
            app.world_mut()
                .spawn((RigidBody::Dynamic, start))
                .with_children(|table| {
                    for (at, h) in parts {
                        table.spawn((
                            Collider::cuboid(h.x, h.y, h.z),
                            Transform::from_translation(at),
                        ));
                    }
                })
                .id()
        } else {
            let compound = Collider::compound(
                parts
                    .iter()
                    .map(|&(at, h)| (at, Quat::IDENTITY, Collider::cuboid(h.x, h.y, h.z)))
                    .collect(),
            );
            app.world_mut()
                .spawn((RigidBody::Dynamic, compound, start))
                .id()
        };
        let mut trajectory = Vec::new();
        for _ in 0..120 {
            run_steps(&mut app, 1);
            trajectory.push(snapshot(&app, &[body])[0]);
        }
        (app, body, trajectory)
    };
    let (app, body, children) = run(true);
    let (_, _, compound) = run(false);
    // Tolerance 1 mm: the soft contact sinks 0.28 mm (as every resting shape in shapes.rs).
    let y = position(&app, body).y;
    assert!((y - 1.0).abs() < 1e-3, "rests at {y}, expected 1.0");
    assert!(rotation(&app, body).angle_between(Quat::IDENTITY) < 1e-3);
    assert!(velocity(&app, body).length() < 0.01);
    assert_eq!(
        children, compound,
        "child colliders and the compound step differently"
    );
    // At rest it falls asleep (0.5 s below the sleep threshold) and stays asleep: its parts,
    // unchanged, do not wake it.
    let mut app = app;
    run_steps(&mut app, 60);
    assert!(app.world().get::<Sleeping>(body).is_some(), "it sleeps");
    let still = *app.world().get::<Transform>(body).unwrap();
    run_steps(&mut app, 30);
    assert!(
        app.world().get::<Sleeping>(body).is_some(),
        "it stays asleep"
    );
    assert_eq!(*app.world().get::<Transform>(body).unwrap(), still);
}

/// A dumbbell (two child spheres of radius 0.2 m, 1 m apart along x, on a body without a
/// collider of its own) rolling along z on a rough floor: it steps bit for bit as the same
/// dumbbell built as one compound, and rolls without slipping (`v = w r`, within 1 %, once
/// friction has matched them).
#[test]
fn dumbbell_of_child_spheres_rolls_as_the_compound_does() {
    let run = |as_children: bool| {
        let mut app = headless_app(60.0);
        app.world_mut().spawn((
            RigidBody::Static,
            Collider::half_space(Vec3::Y),
            Friction(0.5),
        ));
        let start = (
            RigidBody::Dynamic,
            Transform::from_xyz(0.0, 0.2, 0.0),
            LinearVelocity(Vec3::new(0.0, 0.0, 2.0)),
            Friction(0.5),
        );
        let body = if as_children {
            app.world_mut()
                .spawn(start)
                .with_children(|bell| {
                    for x in [-0.5, 0.5] {
                        bell.spawn((Collider::sphere(0.2), Transform::from_xyz(x, 0.0, 0.0)));
                    }
                })
                .id()
        } else {
            let compound = Collider::compound(
                [-0.5, 0.5]
                    .iter()
                    .map(|&x| {
                        (
                            Vec3::new(x, 0.0, 0.0),
                            Quat::IDENTITY,
                            Collider::sphere(0.2),
                        )
                    })
                    .collect(),
            );
            app.world_mut().spawn((start, compound)).id()
        };
        let mut trajectory = Vec::new();
        for _ in 0..90 {
            run_steps(&mut app, 1);
            trajectory.push(snapshot(&app, &[body])[0]);
        }
        (app, body, trajectory)
    };
    let (app, body, children) = run(true);
    let (_, _, compound) = run(false);
    assert_eq!(
        children, compound,
        "child spheres and the compound step differently"
    );
    // Rolling: the contact point is at rest, v_z = w_x r.
    let (v, w) = (velocity(&app, body).z, spin(&app, body).x);
    assert!(v > 0.5, "it rolls on ({v} m/s)");
    assert!((v - w * 0.2).abs() < 0.01 * v, "v = {v}, w r = {}", w * 0.2);
}

/// A 1 m cube scaled (2, 1, 1) and turned a quarter turn about z (its long side up) rests with
/// its centre at 1 m, and has mass `rho x 2 m^3` and the inertia of a 2 x 1 x 1 m box.
#[test]
fn scaled_cuboid_rests_at_its_scaled_height_with_its_scaled_mass() {
    let (mut app, body) = on_ground((
        RigidBody::Dynamic,
        Collider::cuboid(0.5, 0.5, 0.5),
        Transform::from_xyz(0.0, 1.1, 0.0)
            .with_rotation(Quat::from_rotation_z(PI / 2.0))
            .with_scale(Vec3::new(2.0, 1.0, 1.0)),
    ));
    run_steps(&mut app, 120);
    let y = position(&app, body).y;
    // 1 mm: the soft contact's sink, as above.
    assert!((y - 1.0).abs() < 1e-3, "rests at {y}, expected 1.0");
    let computed = *app.world().get::<ComputedMass>(body).unwrap();
    let m = 1000.0 * 2.0;
    // Relative 1e-5: a few f32 roundings.
    assert!((1.0 / computed.inverse_mass - m).abs() <= 1e-5 * m);
    let expected = Vec3::new(m / 3.0 * 0.5, m / 3.0 * 1.25, m / 3.0 * 1.25);
    let i = computed.local_inverse_inertia;
    let got = Vec3::new(i.x_axis.x, i.y_axis.y, i.z_axis.z).recip();
    assert!(
        ((got - expected) / expected).abs().max_element() <= 1e-5,
        "{got} vs {expected}"
    );
    // The scale is the body's: the written Transform keeps it.
    assert_eq!(
        app.world().get::<Transform>(body).unwrap().scale,
        Vec3::new(2.0, 1.0, 1.0)
    );
}

/// A sphere of radius 0.5 m scaled by 2 is a sphere of radius 1 m: it rests at 1 m with mass
/// `rho 4/3 pi` and inertia `2/5 m r^2`; with `Mass(3.0)` its mass stays 3 kg (inertia
/// `2/5 x 3 x 1^2`).
#[test]
fn uniformly_scaled_sphere_rests_and_weighs_as_the_bigger_sphere() {
    let mut app = headless_app(60.0);
    scenes::ground(app.world_mut());
    let spawn = |app: &mut App, x: f32, mass: Option<f32>| {
        let mut e = app.world_mut().spawn((
            RigidBody::Dynamic,
            Collider::sphere(0.5),
            Transform::from_xyz(x, 1.2, 0.0).with_scale(Vec3::splat(2.0)),
        ));
        if let Some(m) = mass {
            e.insert(Mass(m));
        }
        e.id()
    };
    let dense = spawn(&mut app, 0.0, None);
    let light = spawn(&mut app, 5.0, Some(3.0));
    run_steps(&mut app, 120);
    for body in [dense, light] {
        let y = position(&app, body).y;
        assert!((y - 1.0).abs() < 1e-3, "rests at {y}, expected 1.0");
    }
    // Relative 1e-5: a few f32 roundings.
    let close = |a: f32, b: f32| (a - b).abs() <= 1e-5 * b;
    let m = 1000.0 * 4.0 / 3.0 * PI;
    assert!(close(mass(&app, dense), m), "{}", mass(&app, dense));
    let inertia = |e| {
        1.0 / app
            .world()
            .get::<ComputedMass>(e)
            .unwrap()
            .local_inverse_inertia
            .x_axis
            .x
    };
    assert!(close(inertia(dense), 0.4 * m), "{}", inertia(dense));
    assert!(close(mass(&app, light), 3.0));
    assert!(close(inertia(light), 0.4 * 3.0), "{}", inertia(light));
}

/// A sphere scaled (2, 1, 1) cannot be an ellipsoid: one warning names it, however many steps
/// run, and it is the sphere of the nearest uniform scale, `2^(1/3)`, resting at `0.5 x 2^(1/3)`.
#[test]
fn non_uniformly_scaled_sphere_warns_once_and_takes_the_nearest_scale() {
    capture_logs();
    let (mut app, body) = on_ground((
        Name::new("Egg"),
        RigidBody::Dynamic,
        Collider::sphere(0.5),
        Transform::from_xyz(0.0, 0.8, 0.0).with_scale(Vec3::new(2.0, 1.0, 1.0)),
    ));
    run_steps(&mut app, 120);
    let warnings: Vec<_> = take_logs()
        .into_iter()
        .filter(|(level, text)| *level == log::Level::Warn && text.contains("\"Egg\""))
        .collect();
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    let r = 0.5 * 2f32.cbrt();
    let y = position(&app, body).y;
    assert!((y - r).abs() < 1e-3, "rests at {y}, expected {r}");
    assert!(app.world().get::<Quarantined>(body).is_none());
}

/// A body under a non-physics parent that is turned a quarter turn about y and moved 5 cm
/// along x before every step: the body is carried by its parent and falls in the world, so
/// after each step `parent * local` is where a top-level body falling from the same world
/// point is, plus the parent's travel so far.
#[test]
fn body_under_a_moving_parent_is_at_parent_times_local() {
    let mut app = headless_app(60.0);
    let turn = Quat::from_rotation_y(PI / 2.0);
    let parent = app
        .world_mut()
        .spawn(Transform::from_xyz(1.0, 2.0, 3.0).with_rotation(turn))
        .id();
    let local = Transform::from_xyz(0.0, 5.0, 1.0);
    let child = app
        .world_mut()
        .spawn((
            RigidBody::Dynamic,
            Collider::sphere(0.1),
            local,
            ChildOf(parent),
        ))
        .id();
    let start = app
        .world()
        .get::<Transform>(parent)
        .unwrap()
        .mul_transform(local);
    let free = app
        .world_mut()
        .spawn((
            RigidBody::Dynamic,
            Collider::sphere(0.1),
            Transform::from_translation(start.translation + Vec3::new(0.0, 0.0, 10.0)),
        ))
        .id();
    let step = Vec3::new(0.05, 0.0, 0.0);
    for n in 1..=60 {
        app.world_mut()
            .get_mut::<Transform>(parent)
            .unwrap()
            .translation += step;
        run_steps(&mut app, 1);
        let frame = *app.world().get::<Transform>(parent).unwrap();
        let local = *app.world().get::<Transform>(child).unwrap();
        let world = frame.mul_transform(local);
        let expected = position(&app, free) - Vec3::new(0.0, 0.0, 10.0) + step * n as f32;
        // Tolerance 1e-4 m: each step turns the world pose into a local one under a parent
        // turned by an f32 quarter turn and back, a few roundings of coordinates up to 7 m
        // (about 5e-7 m each) a step; measured at most 7.5e-6 m over the 60 steps.
        assert!(
            (world.translation - expected).length() < 1e-4,
            "step {n}: {} vs {expected}",
            world.translation
        );
        // It keeps its world orientation (it does not spin): the parent's turn times the local
        // rotation stays the turn it started with (within 1e-5 rad, the rounding of the
        // quaternion products; measured 0).
        let dq = (world.rotation * turn.inverse()).xyz().length() * 2.0;
        assert!(dq < 1e-5, "step {n}: turned {dq} rad");
        assert_eq!(velocity(&app, child), velocity(&app, free));
    }
}

/// A body with a 1 m cube of its own: a child ball (radius 0.5 m at 2 m along x) added mid-run
/// raises its mass from the cube's 1000 kg by the ball's `4/3 pi 0.125 x 1000` and moves its
/// centre of mass to the weighted mean; removed again, the mass is the cube's, bit for bit.
#[test]
fn adding_and_removing_a_child_collider_changes_the_mass() {
    let mut app = headless_app(60.0);
    app.insert_resource(Gravity(Vec3::ZERO));
    let body = app
        .world_mut()
        .spawn((RigidBody::Dynamic, Collider::cuboid(0.5, 0.5, 0.5)))
        .id();
    run_steps(&mut app, 1);
    let alone = *app.world().get::<ComputedMass>(body).unwrap();
    assert!((1.0 / alone.inverse_mass - 1000.0).abs() < 1e-2);
    let ball = app
        .world_mut()
        .spawn((
            Collider::sphere(0.5),
            Transform::from_xyz(2.0, 0.0, 0.0),
            ChildOf(body),
        ))
        .id();
    run_steps(&mut app, 1);
    let m_ball = 1000.0 * 4.0 / 3.0 * PI * 0.125;
    let total = 1000.0 + m_ball;
    // Relative 1e-5: a few f32 roundings.
    assert!(
        (mass(&app, body) - total).abs() <= 1e-5 * total,
        "{}",
        mass(&app, body)
    );
    let com = app
        .world()
        .get::<ComputedMass>(body)
        .unwrap()
        .local_center_of_mass;
    let expected = Vec3::X * 2.0 * m_ball / total;
    assert!((com - expected).length() <= 1e-5, "{com} vs {expected}");
    assert_eq!(
        app.world().get::<ColliderOf>(ball),
        Some(&ColliderOf { body })
    );
    // Moving the child moves the centre of mass.
    app.world_mut()
        .get_mut::<Transform>(ball)
        .unwrap()
        .translation
        .x = 4.0;
    run_steps(&mut app, 1);
    let com = app
        .world()
        .get::<ComputedMass>(body)
        .unwrap()
        .local_center_of_mass;
    assert!((com - expected * 2.0).length() <= 1e-5, "{com}");
    app.world_mut().entity_mut(ball).despawn();
    run_steps(&mut app, 1);
    assert_eq!(*app.world().get::<ComputedMass>(body).unwrap(), alone);
}

/// A zero, negative or NaN scale, on a body or on a child collider, is bad input: one error
/// naming the entity, the body left out (quarantined, not moving), no panic; once the scale is
/// fixed the body rejoins and falls.
#[test]
fn bad_scales_are_contained_and_rejoin() {
    for (bad, on_child) in [
        (Vec3::new(0.0, 1.0, 1.0), false),
        (Vec3::new(1.0, -1.0, 1.0), false),
        (Vec3::new(1.0, 1.0, f32::NAN), false),
        (Vec3::new(0.0, 1.0, 1.0), true),
        (Vec3::new(-2.0, -2.0, -2.0), true),
    ] {
        capture_logs();
        let mut app = headless_app(60.0);
        let body = app
            .world_mut()
            .spawn((
                Name::new("Crate"),
                RigidBody::Dynamic,
                Collider::cuboid(0.5, 0.5, 0.5),
                Transform::from_xyz(0.0, 5.0, 0.0),
            ))
            .id();
        let child = app
            .world_mut()
            .spawn((
                Name::new("Lid"),
                Collider::cuboid(0.5, 0.1, 0.5),
                Transform::from_xyz(0.0, 0.6, 0.0),
                ChildOf(body),
            ))
            .id();
        let target = if on_child { child } else { body };
        app.world_mut().get_mut::<Transform>(target).unwrap().scale = bad;
        run_steps(&mut app, 10);
        let name = if on_child { "\"Lid\"" } else { "\"Crate\"" };
        let errors: Vec<_> = take_logs()
            .into_iter()
            .filter(|(level, text)| *level == log::Level::Error && text.contains(name))
            .collect();
        assert_eq!(errors.len(), 1, "{bad} on child {on_child}: {errors:?}");
        assert!(app.world().get::<Quarantined>(body).is_some());
        assert_eq!(position(&app, body), Vec3::new(0.0, 5.0, 0.0), "{bad}");
        app.world_mut().get_mut::<Transform>(target).unwrap().scale = Vec3::ONE;
        run_steps(&mut app, 10);
        assert!(app.world().get::<Quarantined>(body).is_none(), "{bad}");
        assert!(position(&app, body).y < 5.0, "{bad}: it falls again");
    }
}

/// A collider under a parent with no `RigidBody` anywhere up the tree is a static collider at
/// its world pose (avian3d's rule): a ball dropped on a 1 m cube whose parent stands at
/// (3, 1, 0) rests on the cube's top at y = 1.5 + r. The same holds once a body loses its
/// `RigidBody`: its child collider stays where it is, static, and holds a ball up.
#[test]
fn colliders_without_a_body_above_them_are_static_at_their_world_pose() {
    let mut app = headless_app(60.0);
    let parent = app
        .world_mut()
        .spawn(Transform::from_xyz(3.0, 1.0, 0.0))
        .id();
    let block = app
        .world_mut()
        .spawn((Collider::cuboid(0.5, 0.5, 0.5), ChildOf(parent)))
        .id();
    let ball = app
        .world_mut()
        .spawn(scenes::ball(
            0.25,
            1.0,
            Vec3::new(3.0, 2.5, 0.0),
            Vec3::ZERO,
        ))
        .id();
    // A body whose RigidBody is removed after a step: its child plate, 1 m up, turns static.
    let table = app
        .world_mut()
        .spawn((RigidBody::Dynamic, Transform::from_xyz(-3.0, 0.0, 0.0)))
        .id();
    let plate = app
        .world_mut()
        .spawn((
            Collider::cuboid(1.0, 0.1, 1.0),
            Transform::from_xyz(0.0, 1.0, 0.0),
            ChildOf(table),
        ))
        .id();
    app.insert_resource(Gravity(Vec3::ZERO));
    run_steps(&mut app, 1);
    assert_eq!(
        app.world().get::<ColliderOf>(plate),
        Some(&ColliderOf { body: table })
    );
    app.world_mut().entity_mut(table).remove::<RigidBody>();
    app.insert_resource(Gravity::default());
    let cup = app
        .world_mut()
        .spawn(scenes::ball(
            0.25,
            1.0,
            Vec3::new(-3.0, 1.6, 0.0),
            Vec3::ZERO,
        ))
        .id();
    run_steps(&mut app, 120);
    assert!(app.world().get::<ColliderOf>(plate).is_none());
    assert!(app.world().get::<ColliderOf>(block).is_none());
    // 1 mm: the soft contact's sink.
    let y = position(&app, ball).y;
    assert!((y - 1.75).abs() < 1e-3, "ball rests at {y}, expected 1.75");
    let y = position(&app, cup).y;
    assert!(
        (y - 1.35).abs() < 1e-3,
        "ball on the plate rests at {y}, expected 1.35"
    );
}

/// Collision events of a compound body name the collider and its body, as avian3d's do: a
/// body with `CollisionEventsEnabled` whose only collider is on a child lands on the ground,
/// and `CollisionStart` names the child as `collider1` and the body as `body1`.
#[test]
fn collision_start_of_a_child_collider_names_it_and_its_body() {
    let mut app = headless_app(60.0);
    let ground = scenes::ground(app.world_mut());
    let body = app
        .world_mut()
        .spawn((
            RigidBody::Dynamic,
            CollisionEventsEnabled,
            Transform::from_xyz(0.0, 1.0, 0.0),
        ))
        .id();
    let child = app
        .world_mut()
        .spawn((
            Collider::sphere(0.25),
            Transform::from_xyz(0.0, -0.5, 0.0),
            ChildOf(body),
        ))
        .id();
    let mut cursor = bevy::ecs::message::MessageCursor::<CollisionStart>::default();
    let mut starts = Vec::new();
    for _ in 0..60 {
        run_steps(&mut app, 1);
        starts.extend(drain(&mut app, &mut cursor));
    }
    assert_eq!(starts.len(), 1, "{starts:?}");
    let s = starts[0];
    let (mine, other) = if s.collider1 == child {
        ((s.collider1, s.body1), (s.collider2, s.body2))
    } else {
        ((s.collider2, s.body2), (s.collider1, s.body1))
    };
    assert_eq!(mine, (child, Some(body)));
    assert_eq!(other, (ground, Some(ground)));
}

/// Spawns a dynamic body at `at` with `children`: each a box of half extent `h` at its offset,
/// with the components of its bundle.
fn body_with_children<B: Bundle>(
    app: &mut App,
    body: impl Bundle,
    children: Vec<(Vec3, f32, B)>,
) -> (Entity, Vec<Entity>) {
    let body = app.world_mut().spawn(body).id();
    let children = children
        .into_iter()
        .map(|(at, h, extra)| {
            app.world_mut()
                .spawn((
                    Collider::cuboid(h, h, h),
                    Transform::from_translation(at),
                    ChildOf(body),
                    extra,
                ))
                .id()
        })
        .collect();
    (body, children)
}

/// A child's own restitution is its contacts': a body (no collider, restitution or rotation of
/// its own: `LockedAxes::ROTATION_LOCKED`, so that it moves as a particle and every point of a
/// landing face meets the ground at the body's speed) with a bouncy child box (`Restitution(1)`)
/// and a dead one (`Restitution(0)`), 0.3 m apart in height, is dropped twice: upright, so that
/// the bouncy child lands first, and turned half a turn about z, so that the dead one does;
/// the lowest child's bottom starts 0.5 m above the ground. The impulse formula for a particle
/// of mass `m` landing at `v` on the ground (restitution `e`, the max of the two: the ground
/// has 0) is `j = (1 + e) m v`, so it leaves at `e v`: the bouncy landing rebounds to the drop
/// height (`e^2 h = 0.5` m), the dead one stops on the ground (its bottom within 1 mm of it,
/// never rising).
#[test]
fn child_restitution_is_its_own_contacts() {
    let mut app = headless_app(60.0);
    scenes::ground(app.world_mut());
    let h = 0.2;
    let spawn = |app: &mut App, x: f32, y: f32, turned: bool| {
        let rotation = if turned {
            Quat::from_rotation_z(PI)
        } else {
            Quat::IDENTITY
        };
        body_with_children(
            app,
            (
                RigidBody::Dynamic,
                LockedAxes::ROTATION_LOCKED,
                Transform::from_xyz(x, y, 0.0).with_rotation(rotation),
            ),
            vec![
                (Vec3::new(-0.5, -0.3, 0.0), h, Restitution(1.0)),
                (Vec3::new(0.5, 0.0, 0.0), h, Restitution(0.0)),
            ],
        )
        .0
    };
    // Upright: the bouncy child's bottom at y - 0.5; turned: the dead child's at y - 0.2.
    let bouncy_first = spawn(&mut app, 0.0, 1.0, false);
    let dead_first = spawn(&mut app, 5.0, 0.7, true);
    let bottom = |app: &App, body: Entity, below: f32| position(app, body).y - below;
    let (mut apex, mut dead_max, mut landed) = (0.0f32, f32::MIN, false);
    for step in 0..72 {
        run_steps(&mut app, 1);
        let b = bottom(&app, bouncy_first, 0.5);
        // Past the first landing (0.32 s, step 19) and before the second (0.96 s).
        if step > 25 {
            apex = apex.max(b);
        }
        let d = bottom(&app, dead_first, 0.2);
        if landed {
            dead_max = dead_max.max(d);
        }
        landed |= d < 0.01;
    }
    println!("bouncy apex {apex}, dead after landing: max {dead_max}");
    // 1 cm: the integration error of a bouncing ball's apex is under 3 mm
    // (`bouncing_ball_apexes_match_case_3`; bad_input.rs uses the same bound).
    assert!((apex - 0.5).abs() < 0.01, "bouncy child rebounds to {apex}");
    // 1 mm: the soft contact's sink (0.28 mm) and no rebound at all.
    let rest = bottom(&app, dead_first, 0.2);
    assert!(rest.abs() < 1e-3, "dead child rests at {rest}");
    assert!(
        dead_max < 1e-3,
        "dead child rose to {dead_max} after landing"
    );
    assert!(velocity(&app, dead_first).length() < 0.01);
}

/// A child's `Sensor` is its own: a body with a wide solid child (a slab of half extents
/// (1.5, 0.2, 0.5) centred 1 m along x) and a sensor child (a 0.4 m cube at (3.5, 0.5, 0), off
/// the slab's end, with `CollisionEventsEnabled`), dropped from y = 1.5: the sensor passes
/// through a static slab under it (top at y = 1.1, bottom at 1.0, beside the solid child's
/// path) without slowing the body, and the body comes to rest on its solid child at y = 0.2.
/// The sensor reports one start and one end with the slab, naming itself and its body. Free
/// fall from rest: the sensor's bottom (1.8 m) meets the slab's top after
/// `sqrt(2 * 0.7 / g)` = 0.378 s, its top (2.2 m) leaves the slab's bottom after
/// `sqrt(2 * 1.2 / g)` = 0.495 s, and the solid child lands after `sqrt(2 * 1.3 / g)` =
/// 0.515 s.
#[test]
fn sensor_child_passes_through_while_its_body_rests() {
    let mut app = headless_app(60.0);
    scenes::ground(app.world_mut());
    let slab = spawn_static(
        app.world_mut(),
        Collider::cuboid(0.3, 0.05, 0.3),
        Transform::from_xyz(3.5, 1.05, 0.0),
    );
    let body = app
        .world_mut()
        .spawn((RigidBody::Dynamic, Transform::from_xyz(0.0, 1.5, 0.0)))
        .id();
    app.world_mut().spawn((
        Collider::cuboid(1.5, 0.2, 0.5),
        Transform::from_xyz(1.0, 0.0, 0.0),
        ChildOf(body),
    ));
    let sensor = app
        .world_mut()
        .spawn((
            Collider::cuboid(0.2, 0.2, 0.2),
            Transform::from_xyz(3.5, 0.5, 0.0),
            Sensor,
            CollisionEventsEnabled,
            ChildOf(body),
        ))
        .id();
    let mut starts = bevy::ecs::message::MessageCursor::<CollisionStart>::default();
    let mut ends = bevy::ecs::message::MessageCursor::<CollisionEnd>::default();
    let (mut started, mut ended) = (Vec::new(), Vec::new());
    let mut speed_through = Vec::new();
    for step in 1..=120u32 {
        run_steps(&mut app, 1);
        started.extend(drain(&mut app, &mut starts).into_iter().map(|s| (step, s)));
        ended.extend(drain(&mut app, &mut ends).into_iter().map(|e| (step, e)));
        // While the sensor is inside the slab (0.38 s to 0.49 s), the body falls freely.
        if (24..=29).contains(&step) {
            speed_through.push((step, velocity(&app, body).y));
        }
    }
    println!("starts {started:?}\nends {ended:?}\nspeeds {speed_through:?}");
    let with_slab = |(_, s): &&(u32, CollisionStart)| s.collider1 == slab || s.collider2 == slab;
    let starts: Vec<_> = started.iter().filter(with_slab).collect();
    assert_eq!(starts.len(), 1, "{started:?}");
    let ends: Vec<_> = ended
        .iter()
        .filter(|(_, e)| e.collider1 == slab || e.collider2 == slab)
        .collect();
    assert_eq!(ends.len(), 1, "{ended:?}");
    let (start_step, s) = *starts[0];
    let (end_step, e) = *ends[0];
    let named = |c1: Entity, c2: Entity, b1: Option<Entity>, b2: Option<Entity>| {
        if c1 == sensor {
            (c1, b1, c2, b2)
        } else {
            (c2, b2, c1, b1)
        }
    };
    let expected = (sensor, Some(body), slab, Some(slab));
    assert_eq!(named(s.collider1, s.collider2, s.body1, s.body2), expected);
    assert_eq!(named(e.collider1, e.collider2, e.body1, e.body2), expected);
    // The steps of the free-fall times above (0.378 s: step 22.7; 0.495 s: step 29.7), plus
    // one (touching is read at the poses the step starts from, so a crossing in one step is
    // seen in the next), within one step (the poses are sampled once a step; the touching
    // distance is 5 mm).
    let step_of = |t: f32| t * 60.0 + 1.0;
    assert!(
        (start_step as f32 - step_of(0.378)).abs() <= 1.0,
        "start at step {start_step}"
    );
    assert!(
        (end_step as f32 - step_of(0.495)).abs() <= 1.0,
        "end at step {end_step}"
    );
    // Falling freely through the slab: each step gains g dt = 0.1635 m/s, within 1 mm/s
    // (the f32 velocity, and no contact impulse at all).
    for w in speed_through.windows(2) {
        let gained = w[0].1 - w[1].1;
        assert!((gained - 9.81 / 60.0).abs() < 1e-3, "{speed_through:?}");
    }
    // At rest on the solid child, 1 mm: the soft contact's sink.
    let y = position(&app, body).y;
    assert!((y - 0.2).abs() < 1e-3, "body rests at {y}, expected 0.2");
    assert!(velocity(&app, body).length() < 0.01);
}

/// A child's `CollisionLayers` are its own: with the ground on layer 1 (`LayerMask(1)`) and a
/// child on layer 2 interacting only with layer 2, a body whose only collider is that child
/// falls through the ground as in free fall (`y = y0 - g t^2 / 2`, the body's whole path past
/// the ground: nothing touched it); and a body with that child 1 m below a plain child sinks
/// the first into the ground and rests on the second, at its height (0.2 m).
#[test]
fn child_layers_are_its_own_contacts() {
    let mut app = headless_app(60.0);
    let ground = scenes::ground(app.world_mut());
    app.world_mut()
        .entity_mut(ground)
        .insert(CollisionLayers::new(LayerMask(1), LayerMask::ALL));
    let apart = || CollisionLayers::new(LayerMask(2), LayerMask(2));
    let (alone, _) = body_with_children(
        &mut app,
        (RigidBody::Dynamic, Transform::from_xyz(0.0, 1.0, 0.0)),
        vec![(Vec3::ZERO, 0.2, apart())],
    );
    let body = app
        .world_mut()
        .spawn((RigidBody::Dynamic, Transform::from_xyz(5.0, 1.5, 0.0)))
        .id();
    app.world_mut().spawn((
        Collider::cuboid(0.2, 0.2, 0.2),
        Transform::from_xyz(0.0, -1.0, 0.0),
        apart(),
        ChildOf(body),
    ));
    app.world_mut()
        .spawn((Collider::cuboid(0.2, 0.2, 0.2), ChildOf(body)));
    let steps = 60;
    run_steps(&mut app, steps);
    // Free fall for t = 1 s: y = y0 - g t^2 / 2 = -3.905 m, v = -g t, worked out here in f64,
    // within 1 mm and 1 mm/s (f32 rounding over 60 steps; the step integrates constant gravity
    // exactly).
    let (g, t) = (9.81f64, steps as f64 / 60.0);
    let y = position(&app, alone).y as f64;
    let expected = 1.0 - g * t * t / 2.0;
    assert!(
        (y - expected).abs() < 1e-3,
        "alone at {y}, expected {expected}"
    );
    let v = velocity(&app, alone).y as f64;
    assert!((v + g * t).abs() < 1e-3, "alone falls at {v}");
    // At rest on the plain child, 1 mm: the soft contact's sink.
    let y = position(&app, body).y;
    assert!((y - 0.2).abs() < 1e-3, "body rests at {y}, expected 0.2");
    assert!(velocity(&app, body).length() < 0.01);
    assert!(rotation(&app, body).angle_between(Quat::IDENTITY) < 1e-3);
}

/// Collision events name the child collider: a body (no collider of its own) on two child
/// boxes, one of them (`a`) with `CollisionEventsEnabled`, lands flat on the ground, is thrown
/// up and lands again. Each landing starts, and the throw ends, exactly one contact of `a`
/// with the ground, named as `(a, body)` against `(ground, ground)`, both as messages and to an
/// observer on `a`, which hears it as `collider1`; the other child, without the component,
/// has no events (an observer on it hears nothing), though it lands at the same step.
#[test]
fn events_name_the_child_collider_and_reach_its_observer() {
    #[derive(Resource, Default)]
    struct Heard(Vec<(Entity, String, Entity, Option<Entity>, Entity)>);
    let mut app = headless_app(60.0);
    app.init_resource::<Heard>();
    let ground = scenes::ground(app.world_mut());
    let body = app
        .world_mut()
        .spawn((RigidBody::Dynamic, Transform::from_xyz(0.0, 0.5, 0.0)))
        .id();
    let mut leg = |x: f32, events: bool| {
        let mut e = app.world_mut().spawn((
            Collider::cuboid(0.2, 0.2, 0.2),
            Transform::from_xyz(x, 0.0, 0.0),
            ChildOf(body),
        ));
        if events {
            e.insert(CollisionEventsEnabled);
        }
        let id = e.id();
        e.observe(move |s: On<CollisionStart>, mut heard: ResMut<Heard>| {
            heard
                .0
                .push((id, "start".into(), s.collider1, s.body1, s.collider2));
        })
        .observe(move |s: On<CollisionEnd>, mut heard: ResMut<Heard>| {
            heard
                .0
                .push((id, "end".into(), s.collider1, s.body1, s.collider2));
        });
        id
    };
    let a = leg(-0.5, true);
    let b = leg(0.5, false);
    let mut starts = bevy::ecs::message::MessageCursor::<CollisionStart>::default();
    let mut ends = bevy::ecs::message::MessageCursor::<CollisionEnd>::default();
    let mut run = |app: &mut App, steps: u32| {
        let (mut started, mut ended) = (Vec::new(), Vec::new());
        for _ in 0..steps {
            run_steps(app, 1);
            started.extend(drain(app, &mut starts));
            ended.extend(drain(app, &mut ends));
        }
        (started, ended)
    };
    // Lands (0.3 m: 0.25 s) and settles.
    let (landed, none) = run(&mut app, 60);
    assert!(none.is_empty(), "{none:?}");
    // Thrown up at 2 m/s: 0.41 s in the air.
    app.world_mut()
        .entity_mut(body)
        .insert(LinearVelocity(Vec3::new(0.0, 2.0, 0.0)));
    let (relanded, thrown) = run(&mut app, 60);
    let named = |c1: Entity, b1: Option<Entity>, c2: Entity, b2: Option<Entity>| {
        if c1 == a {
            ((c1, b1), (c2, b2))
        } else {
            ((c2, b2), (c1, b1))
        }
    };
    let expected = ((a, Some(body)), (ground, Some(ground)));
    for starts in [&landed, &relanded] {
        assert_eq!(starts.len(), 1, "{starts:?}");
        let s = starts[0];
        assert_eq!(named(s.collider1, s.body1, s.collider2, s.body2), expected);
    }
    assert_eq!(thrown.len(), 1, "{thrown:?}");
    let e = thrown[0];
    assert_eq!(named(e.collider1, e.body1, e.collider2, e.body2), expected);
    let heard = &app.world().resource::<Heard>().0;
    let kinds: Vec<&str> = heard.iter().map(|h| h.1.as_str()).collect();
    assert_eq!(kinds, ["start", "end", "start"], "{heard:?}");
    for (on, _, collider1, body1, collider2) in heard {
        assert_eq!(
            (*on, *collider1, *body1, *collider2),
            (a, a, Some(body), ground)
        );
    }
    assert!(heard.iter().all(|h| h.0 != b));
}

/// A child collider's bad restitution follows the bodies' rule: NaN is replaced by 0 with one
/// warning naming the child by its `Name`, and the body steps on (it lands and rests, 1 mm: the
/// soft contact's sink), no panic.
#[test]
fn child_nan_restitution_is_clamped_with_one_warning() {
    capture_logs();
    let mut app = headless_app(60.0);
    scenes::ground(app.world_mut());
    let body = app
        .world_mut()
        .spawn((RigidBody::Dynamic, Transform::from_xyz(0.0, 1.0, 0.0)))
        .id();
    app.world_mut().spawn((
        Name::new("bad leg"),
        Collider::cuboid(0.2, 0.2, 0.2),
        Restitution(f32::NAN),
        ChildOf(body),
    ));
    run_steps(&mut app, 90);
    let warnings: Vec<_> = take_logs()
        .into_iter()
        .filter(|(l, t)| *l == log::Level::Warn && t.contains("bad leg"))
        .collect();
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    assert!(warnings[0].1.contains("clamped to 0"), "{warnings:?}");
    let y = position(&app, body).y;
    assert!((y - 0.2).abs() < 1e-3, "rests at {y}");
    assert!(velocity(&app, body).length() < 0.01);
}
