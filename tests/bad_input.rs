//! Bad input never panics the schedule and never spreads: each bad body is logged as an
//! error naming the entity, marked `Quarantined`, and left out of the solve, while the bodies
//! around it carry on with finite values.

mod common;

use bevy::ecs::message::MessageCursor;
use bevy::prelude::*;
use common::*;
use impact3d::prelude::*;
use impact3d::scenes::{self, headless_app, run_steps};

/// Runs a scene where `bad` rests on a healthy box on the ground, and checks that `bad` is
/// quarantined with an error naming it, that the healthy box stays finite and at rest, and
/// that nothing panics. Returns the app for further checks.
fn quarantined_scene(bad: impl Bundle, what: &str) -> (App, Entity, Entity) {
    capture_logs();
    let mut app = headless_app(60.0);
    let healthy = scenes::stack(app.world_mut(), 1)[0];
    let bad = app.world_mut().spawn(bad).id();
    run_steps(&mut app, 60);
    let quarantined = app.world().get::<Quarantined>(bad);
    assert!(quarantined.is_some(), "{what}: body not quarantined");
    let name = format!("{bad}");
    let errors: Vec<_> = take_logs()
        .into_iter()
        .filter(|(level, text)| *level == log::Level::Error && text.contains(&name))
        .collect();
    assert_eq!(
        errors.len(),
        1,
        "{what}: exactly one error naming {name}, got {errors:?}"
    );
    assert!(errors[0].1.contains("left out"), "{what}: {}", errors[0].1);
    let y = position(&app, healthy).y;
    assert!(
        (y - 0.5).abs() < 0.01 && velocity(&app, healthy).is_finite(),
        "{what}: healthy box disturbed: y = {y}"
    );
    (app, bad, healthy)
}

/// [`quarantined_scene`], for the checks alone.
fn assert_quarantined(bad: impl Bundle, what: &str) {
    let _ = quarantined_scene(bad, what);
}

/// A body resting on the healthy box at y = 1.5.
fn on_top(collider: Collider) -> (RigidBody, Collider, Transform) {
    (
        RigidBody::Dynamic,
        collider,
        Transform::from_xyz(0.0, 1.5, 0.0),
    )
}

#[test]
fn nan_velocity() {
    assert_quarantined(
        (
            on_top(Collider::sphere(0.5)),
            LinearVelocity(Vec3::new(f32::NAN, 0.0, 0.0)),
        ),
        "NaN linear velocity",
    );
    assert_quarantined(
        (
            on_top(Collider::sphere(0.5)),
            AngularVelocity(Vec3::new(0.0, f32::INFINITY, 0.0)),
        ),
        "infinite angular velocity",
    );
}

#[test]
fn non_finite_transform() {
    assert_quarantined(
        (
            RigidBody::Dynamic,
            Collider::sphere(0.5),
            Transform::from_xyz(f32::INFINITY, 1.5, 0.0),
        ),
        "infinite translation",
    );
    let nan_rotation = Transform {
        rotation: Quat::from_xyzw(f32::NAN, 0.0, 0.0, 1.0),
        ..Transform::from_xyz(0.0, 1.5, 0.0)
    };
    assert_quarantined(
        (RigidBody::Dynamic, Collider::sphere(0.5), nan_rotation),
        "NaN rotation",
    );
    let zero_rotation = Transform {
        rotation: Quat::from_xyzw(0.0, 0.0, 0.0, 0.0),
        ..Transform::from_xyz(0.0, 1.5, 0.0)
    };
    assert_quarantined(
        (RigidBody::Dynamic, Collider::sphere(0.5), zero_rotation),
        "zero rotation",
    );
}

#[test]
fn bad_mass_and_density() {
    for m in [0.0, -1.0, f32::NAN, f32::INFINITY] {
        assert_quarantined(
            (on_top(Collider::sphere(0.5)), Mass(m)),
            &format!("mass {m}"),
        );
    }
    for d in [0.0, -1000.0, f32::NAN] {
        assert_quarantined(
            (on_top(Collider::sphere(0.5)), Density(d)),
            &format!("density {d}"),
        );
    }
}

#[test]
fn degenerate_shapes() {
    assert_quarantined(on_top(Collider::cuboid(0.0, 0.5, 0.5)), "zero-size cuboid");
    assert_quarantined(on_top(Collider::sphere(-1.0)), "negative radius");
    assert_quarantined(on_top(Collider::capsule(0.5, f32::NAN)), "NaN capsule");
    assert_quarantined(
        on_top(Collider::half_space(Vec3::ZERO)),
        "zero half-space normal",
    );
    // A dynamic body needs volume: a triangle mesh has none.
    let mesh = Collider::trimesh(vec![Vec3::ZERO, Vec3::X, Vec3::Z], vec![[0, 1, 2]]);
    assert!(mesh.error().is_none());
    assert_quarantined(on_top(mesh), "dynamic trimesh");
    // Coplanar points have no hull.
    let square = [
        Vec3::ZERO,
        Vec3::X,
        Vec3::Z,
        Vec3::new(1.0, 0.0, 1.0),
        Vec3::new(0.5, 0.0, 0.5),
    ];
    assert!(Collider::convex_hull(&square).is_none());
    assert!(Collider::convex_hull(&[Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z]).is_some());
}

/// Restitution outside [0, 1] is clamped, with one warning naming the entity: a ball with
/// e = 1.5 bounces like e = 1 (back to within 1 cm of its drop height: the integration error
/// of `bouncing_ball_apexes_match_case_3` is under 3 mm), and e = -0.5 like e = 0.
#[test]
fn restitution_outside_unit_interval_is_clamped() {
    for (e, expected_apex) in [(1.5f32, 0.5f32), (-0.5, 0.0)] {
        capture_logs();
        let mut app = headless_app(60.0);
        let (_, ball) = scenes::bouncing_ball(app.world_mut(), 0.5, 0.0);
        app.world_mut().entity_mut(ball).insert(Restitution(e));
        let mut apex = 0.0f32;
        for step in 0..60 {
            app.update();
            if step > 20 {
                apex = apex.max(position(&app, ball).y - scenes::BOUNCE_RADIUS);
            }
        }
        assert!((apex - expected_apex).abs() < 0.01, "e = {e}: apex {apex}");
        let name = format!("{ball}");
        let warnings: Vec<_> = take_logs()
            .into_iter()
            .filter(|(l, t)| *l == log::Level::Warn && t.contains(&name))
            .collect();
        assert_eq!(warnings.len(), 1, "e = {e}: {warnings:?}");
        assert!(warnings[0].1.contains("clamped"));
    }
}

/// Despawning a body in mid-contact: no panic, `CollisionEnded` is sent for the pair, and the
/// body it rested on carries on at rest (vertical speed under 1 mm/s; the frictionless
/// stack leaves it a sideways drift of a few mm/s, bounded here by 1 cm/s).
#[test]
fn despawn_in_mid_contact() {
    let mut app = headless_app(60.0);
    let (lower, upper) = scenes::cube_on_cube(app.world_mut(), 5.0);
    let mut ended = MessageCursor::<CollisionEnded>::default();
    run_steps(&mut app, 30);
    assert!(drain(&mut app, &mut ended).is_empty());
    app.world_mut().despawn(upper);
    run_steps(&mut app, 2);
    let ends = drain(&mut app, &mut ended);
    assert_eq!(
        ends,
        vec![CollisionEnded(lower.min(upper), lower.max(upper))]
    );
    run_steps(&mut app, 60);
    assert!(
        (position(&app, lower).y - 0.5).abs() < 0.01,
        "{}",
        position(&app, lower)
    );
    let v = velocity(&app, lower);
    assert!(v.y.abs() < 1e-3 && v.length() < 1e-2, "{v}");
}

/// A quarantined body rejoins the step once its input is fixed, with its marker removed.
#[test]
fn fixed_input_leaves_quarantine() {
    let (mut app, bad, _) = quarantined_scene(
        (
            on_top(Collider::sphere(0.5)),
            Mass(1.0),
            LinearVelocity(Vec3::NAN),
        ),
        "NaN velocity",
    );
    app.world_mut()
        .entity_mut(bad)
        .insert(LinearVelocity(Vec3::ZERO));
    run_steps(&mut app, 2);
    assert!(app.world().get::<Quarantined>(bad).is_none());
    run_steps(&mut app, 120);
    // It fell onto the box and rests there (radius 0.5 on the box top at y = 1).
    assert!(
        (position(&app, bad).y - 1.5).abs() < 0.01,
        "{}",
        position(&app, bad)
    );
}

/// Finite but absurd input that would overflow in the step (two balls closing at 3e38 m/s each:
/// the relative velocity is infinite): both are quarantined before the solve (their speed is
/// above `dynamics::validation::MAX_LINEAR_SPEED`), nothing non-finite is ever written, a body
/// elsewhere carries on untouched, and both rejoin on the step after their speeds are fixed.
#[test]
fn overflowing_velocity_never_writes_non_finite_values() {
    let mut app = headless_app(60.0);
    app.world_mut().insert_resource(Gravity(Vec3::ZERO));
    let left = app
        .world_mut()
        .spawn(scenes::ball(
            0.5,
            1.0,
            Vec3::ZERO,
            Vec3::new(3e38, 0.0, 0.0),
        ))
        .id();
    let right = app
        .world_mut()
        .spawn(scenes::ball(
            0.5,
            1.0,
            Vec3::new(1.5, 0.0, 0.0),
            Vec3::new(-3e38, 0.0, 0.0),
        ))
        .id();
    let bystander = app
        .world_mut()
        .spawn(scenes::ball(0.5, 1.0, Vec3::new(0.0, 50.0, 0.0), Vec3::Y))
        .id();
    run_steps(&mut app, 5);
    for e in [left, right, bystander] {
        let t = app.world().get::<Transform>(e).unwrap();
        assert!(
            t.translation.is_finite() && velocity(&app, e).is_finite(),
            "{e}: non-finite value written"
        );
    }
    assert!(app.world().get::<Quarantined>(left).is_some());
    assert!(app.world().get::<Quarantined>(right).is_some());
    assert_eq!(velocity(&app, bystander), Vec3::Y);
    for e in [left, right] {
        app.world_mut()
            .entity_mut(e)
            .insert(LinearVelocity(Vec3::ZERO));
    }
    app.update();
    assert!(app.world().get::<Quarantined>(left).is_none());
    assert!(app.world().get::<Quarantined>(right).is_none());
}
