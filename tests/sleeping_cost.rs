//! Sleeping bodies are not searched by the broad phase: the pairs of two sleeping (or
//! unchanged static) bodies are carried over from the step before, so a sleeping pile keeps
//! exactly its pairs and its touching state, and still wakes when an awake body comes near.

mod common;

use bevy::ecs::message::MessageCursor;
use bevy::prelude::*;
use common::*;
use impact3d::collision::ContactPairs;
use impact3d::prelude::*;
use impact3d::scenes::{self, headless_app, run_steps};

/// The pairs as (a, b, touching).
fn pair_set(app: &App) -> Vec<(Entity, Entity, bool)> {
    app.world()
        .resource::<ContactPairs>()
        .iter()
        .map(|p| (p.a, p.b, p.touching))
        .collect()
}

/// A headless app with a pyramid of 10 cubes (base 4), stepped 1.5 s until every cube sleeps.
fn asleep_pyramid() -> (App, Vec<Entity>) {
    let mut app = headless_app(60.0);
    let cubes = scenes::pyramid(app.world_mut(), 4);
    run_steps(&mut app, 90);
    assert!(
        cubes
            .iter()
            .all(|&c| app.world().get::<Sleeping>(c).is_some()),
        "the pyramid fell asleep"
    );
    (app, cubes)
}

/// A pyramid of 10 cubes falls asleep; for 60 more steps its pairs, their touching state and
/// every pose stay exactly as they were, and no collision ends. A ball dropped onto it then
/// wakes it, and comes to rest on the top cube.
#[test]
fn sleeping_pile_keeps_its_pairs_and_wakes() {
    let (mut app, cubes) = asleep_pyramid();
    let pairs = pair_set(&app);
    // Ground under 4 cubes, 3 + 2 + 1 resting on two each, neighbours 0.05 m apart within
    // the margin-widened boxes: at least the 4 + 2 * 6 supporting pairs.
    assert!(pairs.len() >= 16, "{pairs:?}");
    let poses: Vec<Vec3> = cubes.iter().map(|&c| position(&app, c)).collect();
    let mut ended = MessageCursor::<CollisionEnded>::default();
    drain(&mut app, &mut ended);
    for _ in 0..60 {
        app.update();
        assert_eq!(pair_set(&app), pairs);
    }
    assert!(drain(&mut app, &mut ended).is_empty());
    let now: Vec<Vec3> = cubes.iter().map(|&c| position(&app, c)).collect();
    assert_eq!(now, poses);
    let top = *cubes.last().unwrap();
    let top_y = position(&app, top).y;
    let above = position(&app, top) + Vec3::Y * 2.0;
    let ball = app
        .world_mut()
        .spawn(scenes::ball(0.25, 1.0, above, Vec3::ZERO))
        .id();
    let mut woke = false;
    for _ in 0..180 {
        app.update();
        woke |= app.world().get::<Sleeping>(top).is_none();
    }
    assert!(woke, "the ball woke the pile");
    // At rest on the top cube: its centre 0.5 + 0.25 above the cube's (within 1 cm: the soft
    // contacts sink 0.28 mm each, and the cube may settle by as much again).
    let y = position(&app, ball).y;
    assert!((y - (top_y + 0.75)).abs() < 0.01, "{y} vs {}", top_y + 0.75);
}

/// A sleeping body sits the step out: once the pyramid sleeps, the step holds the ground
/// alone (1 body of 11), and the pile costs nothing until something comes near. The ball
/// dropped above it brings the pile back in: ground, ball and 10 cubes.
#[test]
fn sleeping_bodies_sit_the_step_out() {
    let (mut app, cubes) = asleep_pyramid();
    // Falling asleep at the end of a step, a body is read once more in the next (its marker
    // is new and its velocities were zeroed); from then on it sits out.
    run_steps(&mut app, 1);
    let bodies = |app: &App| app.world().resource::<SolverStats>().bodies;
    for _ in 0..30 {
        app.update();
        assert_eq!(bodies(&app), 1);
    }
    let top = *cubes.last().unwrap();
    let above = position(&app, top) + Vec3::Y * 2.0;
    app.world_mut()
        .spawn(scenes::ball(0.25, 1.0, above, Vec3::ZERO));
    let mut most = 0;
    for _ in 0..60 {
        app.update();
        most = most.max(bodies(&app));
    }
    assert_eq!(most, 12);
}

/// A box asleep on a static platform wakes when the platform is moved away from under it
/// (the pair ends, as a pair with a sleeping body ends when its other body is gone), and
/// falls freely, above the ground 10 m below.
#[test]
fn moving_the_support_away_wakes_a_sleeper() {
    let mut app = headless_app(60.0);
    let platform = app
        .world_mut()
        .spawn((
            Collider::cuboid(1.0, 0.5, 1.0),
            Transform::from_xyz(0.0, 9.5, 0.0),
        ))
        .id();
    let cube = app
        .world_mut()
        .spawn(scenes::cuboid(
            Vec3::splat(0.5),
            1.0,
            Vec3::new(0.0, 10.5, 0.0),
        ))
        .id();
    run_steps(&mut app, 90);
    assert!(app.world().get::<Sleeping>(cube).is_some());
    run_steps(&mut app, 30);
    let y0 = position(&app, cube).y;
    app.world_mut()
        .entity_mut(platform)
        .insert(Transform::from_xyz(10.0, 9.5, 0.0));
    run_steps(&mut app, 61);
    assert!(app.world().get::<Sleeping>(cube).is_none());
    let fall = y0 - position(&app, cube).y;
    // The first of the 61 steps detects the lost support (the box wakes at its end); then
    // 60 steps, 1 s, of free fall, which the default method integrates exactly (ballistic
    // motion with no contact): g t^2 / 2 = 4.905 m. Within 1 mm: f32 rounding of a position
    // near 10 m over 60 steps is about 1e-5 m; a missed or extra step would be 8 cm off.
    assert!((fall - 0.5 * 9.81).abs() < 1e-3, "{fall}");
}
