//! Reference scenes and a headless test harness, shared by the tests, the examples and the lab,
//! so that each scene is written once. The numbers refer to the reference scenes with known
//! answers (`SCENES.md` in the project's shared notes; each builder's doc restates what it
//! needs).
//!
//! # Examples
//!
//! ```
//! use bevy::prelude::*;
//! use impact3d::prelude::*;
//! use impact3d::scenes;
//!
//! let mut app = scenes::headless_app(60.0);
//! let (_, ball) = scenes::bouncing_ball(app.world_mut(), 1.0, 0.8);
//! scenes::run_steps(&mut app, 30);
//! let y = app.world().get::<Transform>(ball).unwrap().translation.y;
//! assert!(y < 1.5, "the ball fell");
//! ```

use bevy::app::Plugins;
use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;

use crate::prelude::*;

mod impacts;
mod pour;
mod resting;

pub use impacts::*;
pub use pour::*;
pub use resting::*;

/// A headless app (`MinimalPlugins` + [`PhysicsPlugins`]) in which every `app.update()` runs
/// exactly one fixed step of `1/hz` s. The first update, which Bevy spends recording the start
/// instant, has already run.
pub fn headless_app(hz: f64) -> App {
    headless_app_with(hz, (MinimalPlugins, PhysicsPlugins::default()))
}

/// [`headless_app`] with other `plugins` in place of `MinimalPlugins` + [`PhysicsPlugins`]:
/// `MinimalPlugins` set up otherwise (e.g. its task pools' threads), a physics plugin group
/// with a stage replaced. They must bring the time plugins and a fixed-step schedule, as
/// `MinimalPlugins` does.
///
/// # Examples
///
/// ```
/// use bevy::prelude::*;
/// use impact3d::prelude::*;
/// use impact3d::scenes;
///
/// let app = scenes::headless_app_with(60.0, (MinimalPlugins, PhysicsPlugins::default()));
/// assert!(app.world().contains_resource::<Gravity>());
/// ```
pub fn headless_app_with<M>(hz: f64, plugins: impl Plugins<M>) -> App {
    let mut app = App::new();
    app.add_plugins(plugins)
        .insert_resource(Time::<Fixed>::from_hz(hz))
        .insert_resource(TimeUpdateStrategy::FixedTimesteps(1));
    app.update();
    app
}

/// Runs `steps` fixed steps.
pub fn run_steps(app: &mut App, steps: u32) {
    for _ in 0..steps {
        app.update();
    }
}

/// A hash of the bits of every translation and rotation of `bodies` (in that order): two runs
/// agree bit for bit when their hashes do (the determinism tests and `examples/hash_probe.rs`).
/// A body without a `Transform` is skipped.
pub fn pose_hash(world: &World, bodies: &[Entity]) -> u64 {
    use std::hash::{Hash, Hasher};
    let mut hasher = std::collections::hash_map::DefaultHasher::new();
    for t in bodies.iter().filter_map(|&e| world.get::<Transform>(e)) {
        for x in t
            .translation
            .to_array()
            .into_iter()
            .chain(t.rotation.to_array())
        {
            x.to_bits().hash(&mut hasher);
        }
    }
    hasher.finish()
}

/// A dynamic sphere of `radius` m and `mass` kg at `position` moving at `velocity`.
pub fn ball(radius: f32, mass: f32, position: Vec3, velocity: Vec3) -> impl Bundle {
    (
        RigidBody::Dynamic,
        Collider::sphere(radius),
        Mass(mass),
        Transform::from_translation(position),
        LinearVelocity(velocity),
    )
}

/// A dynamic box with half extents `half` (m) and `mass` kg at `position`.
pub fn cuboid(half: Vec3, mass: f32, position: Vec3) -> impl Bundle {
    (
        RigidBody::Dynamic,
        Collider::cuboid(half.x, half.y, half.z),
        Mass(mass),
        Transform::from_translation(position),
    )
}

/// Static ground: the half-space `y < 0`.
pub fn ground(world: &mut World) -> Entity {
    world
        .spawn((
            RigidBody::Static,
            Collider::half_space(Vec3::Y),
            Transform::IDENTITY,
        ))
        .id()
}
