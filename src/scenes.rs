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

use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;

use crate::prelude::*;

/// A headless app (`MinimalPlugins` + [`PhysicsPlugins`]) in which every `app.update()` runs
/// exactly one fixed step of `1/hz` s. The first update, which Bevy spends recording the start
/// instant, has already run.
pub fn headless_app(hz: f64) -> App {
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, PhysicsPlugins::default()))
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

/// A 1 m cube of 1 kg dropped from 2 m onto the ground (default gravity); it comes to rest with
/// its centre at y = 0.5. Returns (ground, cube).
pub fn box_drop(world: &mut World) -> (Entity, Entity) {
    let ground = ground(world);
    let cube = world
        .spawn(cuboid(Vec3::splat(0.5), 1.0, Vec3::new(0.0, 2.0, 0.0)))
        .id();
    (ground, cube)
}

/// Case 3: a ball of radius 0.1 m whose lowest point starts `h0` m above the ground, at rest,
/// restitution `e`, gravity 10 m/s^2. Impact speed `sqrt(2 g h0)`, k-th apex `e^(2k) h0`.
/// Returns (ground, ball).
pub fn bouncing_ball(world: &mut World, h0: f32, e: f32) -> (Entity, Entity) {
    world.insert_resource(Gravity(Vec3::new(0.0, -10.0, 0.0)));
    let ground = ground(world);
    let ball = world
        .spawn((
            ball(
                BOUNCE_RADIUS,
                1.0,
                Vec3::new(0.0, h0 + BOUNCE_RADIUS, 0.0),
                Vec3::ZERO,
            ),
            Restitution(e),
        ))
        .id();
    (ground, ball)
}

/// Radius of the ball of [`bouncing_ball`], m.
pub const BOUNCE_RADIUS: f32 = 0.1;

/// Case 1: head-on in 1D, no gravity: m1 = 1 kg at +2 m/s meets m2 = 3 kg at -1 m/s, spheres
/// of radius 0.5 just touching, restitution `e`. Returns (ball 1, ball 2).
pub fn head_on(world: &mut World, e: f32) -> (Entity, Entity) {
    world.insert_resource(Gravity(Vec3::ZERO));
    let a = world
        .spawn((
            ball(0.5, 1.0, Vec3::ZERO, Vec3::new(2.0, 0.0, 0.0)),
            Restitution(e),
        ))
        .id();
    let b = world
        .spawn((
            ball(0.5, 3.0, Vec3::X, Vec3::new(-1.0, 0.0, 0.0)),
            Restitution(e),
        ))
        .id();
    (a, b)
}

/// Case 2: oblique equal spheres (R = 0.5, 1 kg), no gravity: B at rest, A at (1, 0, 0) m/s
/// spinning (0, 0, 5) rad/s, the line of centres at 30 degrees. Returns (A, B).
pub fn oblique(world: &mut World, e: f32) -> (Entity, Entity) {
    world.insert_resource(Gravity(Vec3::ZERO));
    let angle = 30f32.to_radians();
    let a = world
        .spawn((
            ball(0.5, 1.0, Vec3::ZERO, Vec3::X),
            AngularVelocity(Vec3::new(0.0, 0.0, 5.0)),
            Restitution(e),
        ))
        .id();
    let b = world
        .spawn((
            ball(
                0.5,
                1.0,
                Vec3::new(angle.cos(), angle.sin(), 0.0),
                Vec3::ZERO,
            ),
            Restitution(e),
        ))
        .id();
    (a, b)
}

/// Case 8: Newton's cradle of `n` touching balls (R = 0.5, 1 kg) in a row along x, no gravity,
/// the first struck at `speed` m/s, restitution `e`.
pub fn cradle(world: &mut World, n: usize, speed: f32, e: f32) -> Vec<Entity> {
    world.insert_resource(Gravity(Vec3::ZERO));
    (0..n)
        .map(|i| {
            let v = if i == 0 {
                Vec3::new(speed, 0.0, 0.0)
            } else {
                Vec3::ZERO
            };
            world
                .spawn((
                    ball(0.5, 1.0, Vec3::new(i as f32, 0.0, 0.0), v),
                    Restitution(e),
                ))
                .id()
        })
        .collect()
}

/// Case 9: a box with half extents (1, 0.25, 0.5) and 1 kg falling flat at 1 m/s, no gravity,
/// its bottom 0.005 m above the ground, restitution `e`. Exact answer: it rebounds at `e` m/s
/// with no spin. Returns (ground, box).
pub fn box_landing_flat(world: &mut World, e: f32) -> (Entity, Entity) {
    world.insert_resource(Gravity(Vec3::ZERO));
    let ground = ground(world);
    let b = world
        .spawn((
            cuboid(Vec3::new(1.0, 0.25, 0.5), 1.0, Vec3::new(0.0, 0.255, 0.0)),
            LinearVelocity(Vec3::new(0.0, -1.0, 0.0)),
            Restitution(e),
        ))
        .id();
    (ground, b)
}

/// Case 10: ball 1 (`m1` kg, R = 0.5) under ball 2 (`m2` kg, R = 0.5), touching, both falling at
/// `v0` m/s, ball 1's bottom 0.005 m above the ground, no gravity, e = 1. Event by event, ball 2
/// leaves at `(3 m1 - m2) v0 / (m1 + m2)` upward. Returns (ground, ball 1, ball 2).
pub fn galilean_cannon(world: &mut World, m1: f32, m2: f32, v0: f32) -> (Entity, Entity, Entity) {
    world.insert_resource(Gravity(Vec3::ZERO));
    let ground = ground(world);
    let down = Vec3::new(0.0, -v0, 0.0);
    let b1 = world
        .spawn((
            ball(0.5, m1, Vec3::new(0.0, 0.505, 0.0), down),
            Restitution(1.0),
        ))
        .id();
    let b2 = world
        .spawn((
            ball(0.5, m2, Vec3::new(0.0, 1.505, 0.0), down),
            Restitution(1.0),
        ))
        .id();
    (ground, b1, b2)
}

/// A 1 m cube of `upper_mass` kg resting on a 1 m cube of 1 kg on the ground (default
/// gravity); with `upper_mass` 100 or 1000, case 12's heavy-on-light pair. Returns (lower,
/// upper).
pub fn cube_on_cube(world: &mut World, upper_mass: f32) -> (Entity, Entity) {
    ground(world);
    let lower = world
        .spawn(cuboid(Vec3::splat(0.5), 1.0, Vec3::new(0.0, 0.5, 0.0)))
        .id();
    let upper = world
        .spawn(cuboid(
            Vec3::splat(0.5),
            upper_mass,
            Vec3::new(0.0, 1.5, 0.0),
        ))
        .id();
    (lower, upper)
}

/// Case 11: a 1 m cube of 1 kg at rest on the ground (default gravity), restitution `e`.
/// Returns (ground, cube).
pub fn resting_box(world: &mut World, e: f32) -> (Entity, Entity) {
    let ground = ground(world);
    let cube = world
        .spawn((
            cuboid(Vec3::splat(0.5), 1.0, Vec3::new(0.0, 0.5, 0.0)),
            Restitution(e),
        ))
        .id();
    (ground, cube)
}

/// Case 12: a vertical stack of `n` 1 m cubes of 1 kg each, resting on the ground (default
/// gravity). Returns the cubes, bottom first.
pub fn stack(world: &mut World, n: usize) -> Vec<Entity> {
    ground(world);
    (0..n)
        .map(|i| {
            world
                .spawn(cuboid(
                    Vec3::splat(0.5),
                    1.0,
                    Vec3::new(0.0, 0.5 + i as f32, 0.0),
                ))
                .id()
        })
        .collect()
}

/// Case 12: a pyramid of 1 m cubes of 1 kg with `base` cubes in the bottom row (in the xy plane,
/// 0.05 m apart in a row), `base (base + 1) / 2` in all. Returns the cubes, bottom row first;
/// the last is the top.
pub fn pyramid(world: &mut World, base: usize) -> Vec<Entity> {
    ground(world);
    let mut cubes = Vec::new();
    for row in 0..base {
        let count = base - row;
        for i in 0..count {
            let x = (i as f32 - (count - 1) as f32 * 0.5) * 1.05;
            cubes.push(
                world
                    .spawn(cuboid(
                        Vec3::splat(0.5),
                        1.0,
                        Vec3::new(x, 0.5 + row as f32, 0.0),
                    ))
                    .id(),
            );
        }
    }
    cubes
}

/// Case 13: a sphere of radius 0.05 m at 100 m/s along +x towards a static wall 0.01 m thick
/// (its near face at x = 0), starting 1 m away, no gravity, e = 0. Returns (wall, sphere).
pub fn fast_thin_wall(world: &mut World) -> (Entity, Entity) {
    world.insert_resource(Gravity(Vec3::ZERO));
    let wall = world
        .spawn((
            RigidBody::Static,
            Collider::cuboid(0.005, 2.0, 2.0),
            Transform::from_xyz(0.005, 0.0, 0.0),
        ))
        .id();
    let sphere = world
        .spawn(ball(
            0.05,
            1.0,
            Vec3::new(-1.0, 0.0, 0.0),
            Vec3::new(100.0, 0.0, 0.0),
        ))
        .id();
    (wall, sphere)
}

/// A static open box (floor and four walls) of inner half width `half` m and height `height` m.
pub fn container(world: &mut World, half: f32, height: f32) -> Vec<Entity> {
    let t = 0.5;
    let mut spawn = |size: Vec3, at: Vec3| {
        world
            .spawn((
                RigidBody::Static,
                Collider::cuboid(size.x, size.y, size.z),
                Transform::from_translation(at),
            ))
            .id()
    };
    vec![
        spawn(Vec3::new(half + t, t, half + t), Vec3::new(0.0, -t, 0.0)),
        spawn(
            Vec3::new(t, height * 0.5, half + t),
            Vec3::new(-half - t, height * 0.5, 0.0),
        ),
        spawn(
            Vec3::new(t, height * 0.5, half + t),
            Vec3::new(half + t, height * 0.5, 0.0),
        ),
        spawn(
            Vec3::new(half, height * 0.5, t),
            Vec3::new(0.0, height * 0.5, -half - t),
        ),
        spawn(
            Vec3::new(half, height * 0.5, t),
            Vec3::new(0.0, height * 0.5, half + t),
        ),
    ]
}

/// Throughput: `n` spheres of radius 0.25 m on a jittered grid above a container sized for
/// them, falling in (default gravity). Returns the spheres.
pub fn pour(world: &mut World, n: usize) -> Vec<Entity> {
    let side = ((n as f32).sqrt().ceil() as usize).max(1);
    let half = side as f32 * 0.3;
    container(world, half, 4.0 + n as f32 / (side * side) as f32);
    let mut seed = 7u32;
    (0..n)
        .map(|i| {
            seed = seed.wrapping_mul(1664525).wrapping_add(1013904223);
            let jitter = ((seed >> 8) as f32 / (1u32 << 24) as f32 - 0.5) * 0.05;
            let (layer, k) = (i / (side * side), i % (side * side));
            let (gx, gz) = (k % side, k / side);
            let p = Vec3::new(
                (gx as f32 - (side - 1) as f32 * 0.5) * 0.55 + jitter,
                1.0 + layer as f32 * 0.6,
                (gz as f32 - (side - 1) as f32 * 0.5) * 0.55 - jitter,
            );
            world.spawn(ball(0.25, 1.0, p, Vec3::ZERO)).id()
        })
        .collect()
}

/// Throughput: `n` spheres of radius 0.25 m in free flight on a sparse 3D grid (2 m apart),
/// no gravity, moving slowly so that they rarely meet. Returns the spheres.
pub fn sparse_flight(world: &mut World, n: usize) -> Vec<Entity> {
    world.insert_resource(Gravity(Vec3::ZERO));
    let side = ((n as f32).cbrt().ceil() as usize).max(1);
    (0..n)
        .map(|i| {
            let (x, y, z) = (i % side, (i / side) % side, i / (side * side));
            let p = Vec3::new(x as f32, y as f32, z as f32) * 2.0;
            let v = Vec3::new(
                ((i * 7) % 5) as f32 - 2.0,
                ((i * 3) % 5) as f32 - 2.0,
                ((i * 11) % 5) as f32 - 2.0,
            ) * 0.1;
            world.spawn(ball(0.25, 1.0, p, v)).id()
        })
        .collect()
}
