//! Resting islands sleep (no solver work, no motion at all) and wake when touched.

mod common;

use bevy::prelude::*;
use common::*;
use impact3d::prelude::*;
use impact3d::scenes::{self, headless_app, run_steps};

fn asleep(app: &App, e: Entity) -> bool {
    app.world().get::<Sleeping>(e).is_some()
}

/// A dropped box lands (about 0.55 s), comes to rest, and sleeps 0.5 s later; asleep it costs
/// no contact work and does not move by a single bit.
#[test]
fn resting_box_sleeps_and_costs_nothing() {
    let mut app = headless_app(60.0);
    let (_, cube) = scenes::box_drop(app.world_mut());
    run_steps(&mut app, 150);
    assert!(asleep(&app, cube), "asleep after 2.5 s");
    assert_eq!(
        app.world().resource::<SolverStats>().contacts,
        0,
        "no contact work while asleep"
    );
    let before = (position(&app, cube), rotation(&app, cube));
    run_steps(&mut app, 600);
    assert_eq!((position(&app, cube), rotation(&app, cube)), before);
    assert!((before.0.y - 0.5).abs() < 0.01);
}

/// A frictionless stack of 10 cubes sleeps instead of creeping sideways: once settled (2 s),
/// the top cube does not move by a single bit over the next 18 s. Without sleeping the
/// frictionless column drifts sideways slowly, nothing resisting the f32 rounding of its
/// contact normals (1.5 mm in 20 s, see `tests/methods_resting.rs`).
#[test]
fn frictionless_stack_sleeps() {
    let mut app = headless_app(60.0);
    let cubes = scenes::stack(app.world_mut(), 10);
    let top = *cubes.last().unwrap();
    run_steps(&mut app, 120);
    assert!(cubes.iter().all(|&c| asleep(&app, c)));
    let settled = position(&app, top);
    run_steps(&mut app, 1080);
    assert_eq!(position(&app, top), settled);
}

/// A ball dropped on a sleeping box wakes it, and the impact is solved with the box's real mass
/// (case 1 in the vertical: a 1 kg ball at 3 m/s, e = 1, on a 1 kg box resting on the ground
/// moves the box's contact: the ball does not rebound at full speed as from a fixed body).
#[test]
fn touching_wakes_the_island() {
    let mut app = headless_app(60.0);
    let cubes = scenes::stack(app.world_mut(), 2);
    run_steps(&mut app, 90);
    assert!(cubes.iter().all(|&c| asleep(&app, c)));
    let ball = app
        .world_mut()
        .spawn((
            scenes::ball(
                0.25,
                1.0,
                Vec3::new(0.0, 2.6, 0.0),
                Vec3::new(0.0, -3.0, 0.0),
            ),
            Restitution(1.0),
        ))
        .id();
    // The ball's box, widened by its reach, meets the top cube's after about 6 steps.
    run_steps(&mut app, 8);
    assert!(
        cubes.iter().all(|&c| !asleep(&app, c)),
        "the whole island woke"
    );
    // The top cube took part in the impact with its real mass: it was pushed down into the
    // stack, and the ball rebounded slower than the 3 m/s a fixed body would give it.
    assert!(velocity(&app, ball).y < 2.9, "{}", velocity(&app, ball));
    run_steps(&mut app, 240);
    assert!(cubes.iter().all(|&c| asleep(&app, c)), "and sleeps again");
}

/// Setting a sleeping body's velocity wakes it; removing the body under a sleeping one wakes
/// the one on top, which falls.
#[test]
fn user_changes_and_lost_support_wake() {
    let mut app = headless_app(60.0);
    let (lower, upper) = scenes::cube_on_cube(app.world_mut(), 1.0);
    run_steps(&mut app, 90);
    assert!(asleep(&app, lower) && asleep(&app, upper));

    app.world_mut()
        .entity_mut(lower)
        .insert(LinearVelocity(Vec3::new(0.0, 0.0, 2.0)));
    run_steps(&mut app, 1);
    assert!(
        !asleep(&app, lower) && !asleep(&app, upper),
        "the user's velocity woke the island"
    );
    // The lower cube slides out from under the (frictionless) upper one, which falls.
    run_steps(&mut app, 120);
    assert!(
        (position(&app, upper).y - 0.5).abs() < 0.01,
        "fell: {}",
        position(&app, upper)
    );

    let mut app = headless_app(60.0);
    let (lower, upper) = scenes::cube_on_cube(app.world_mut(), 1.0);
    run_steps(&mut app, 90);
    app.world_mut().despawn(lower);
    run_steps(&mut app, 60);
    assert!(
        (position(&app, upper).y - 0.5).abs() < 0.01,
        "fell onto the ground: {}",
        position(&app, upper)
    );
}

/// With sleeping disabled nothing ever sleeps.
#[test]
fn sleeping_can_be_disabled() {
    let mut app = headless_app(60.0);
    app.world_mut().insert_resource(SleepConfig {
        enabled: false,
        ..default()
    });
    let (_, cube) = scenes::box_drop(app.world_mut());
    run_steps(&mut app, 300);
    assert!(!asleep(&app, cube));
    assert!(app.world().resource::<SolverStats>().contacts > 0);
}
