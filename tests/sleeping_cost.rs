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

/// A pyramid of 10 cubes falls asleep; for 60 more steps its pairs, their touching state and
/// every pose stay exactly as they were, and no collision ends. A ball dropped onto it then
/// wakes it, and comes to rest on the top cube.
#[test]
fn sleeping_pile_keeps_its_pairs_and_wakes() {
    let mut app = headless_app(60.0);
    let cubes = scenes::pyramid(app.world_mut(), 4);
    run_steps(&mut app, 90);
    assert!(
        cubes
            .iter()
            .all(|&c| app.world().get::<Sleeping>(c).is_some()),
        "the pyramid fell asleep"
    );
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
