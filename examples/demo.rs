//! A headless demo: balls and boxes fall on the ground and onto each other. Prints every
//! impact (the two bodies and the impulse j), collisions starting, and the final state.
//!
//! Run with `cargo run --release --example demo`.

use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use impact3d::prelude::*;

/// Simulated time, s.
const SECONDS: u32 = 4;

fn main() {
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, PhysicsPlugins::default()))
        // Step exactly one 1/60 s physics step per update, as fast as the machine allows.
        .insert_resource(Time::<Fixed>::from_hz(60.0))
        .insert_resource(TimeUpdateStrategy::FixedTimesteps(1))
        .add_systems(Startup, spawn_scene)
        // Right after each step, in the schedule that steps physics.
        .add_systems(FixedPostUpdate, report_impacts.in_set(PhysicsSystems::Last));

    // The first update only records the start time; each later one runs one fixed step.
    for _ in 0..=SECONDS * 60 {
        app.update();
    }

    println!("\nFinal state after {SECONDS} s:");
    let world = app.world_mut();
    let mut query = world.query::<(&Name, &Transform, &LinearVelocity, &RigidBody)>();
    for (name, transform, velocity, body) in query.iter(world) {
        if body.is_dynamic() {
            let p = transform.translation;
            println!(
                "  {name:<14} at ({:6.3}, {:6.3}, {:6.3}) m, speed {:.4} m/s",
                p.x,
                p.y,
                p.z,
                velocity.length()
            );
        }
    }
}

fn spawn_scene(mut commands: Commands) {
    // Friction is opt-in: the ground and the boxes have it, the balls do not.
    commands.spawn((
        Name::new("ground"),
        RigidBody::Static,
        Collider::half_space(Vec3::Y),
        Friction(0.5),
    ));
    // A bouncy ball dropped from 2 m.
    commands.spawn((
        Name::new("bouncy ball"),
        RigidBody::Dynamic,
        Collider::sphere(0.25),
        Restitution(0.8),
        Transform::from_xyz(-2.0, 2.0, 0.0),
    ));
    // A crate, and a heavier ball that lands on it.
    commands.spawn((
        Name::new("crate"),
        RigidBody::Dynamic,
        Collider::cuboid(0.5, 0.5, 0.5),
        Mass(20.0),
        Friction(0.5),
        Transform::from_xyz(0.0, 1.0, 0.0),
    ));
    commands.spawn((
        Name::new("heavy ball"),
        RigidBody::Dynamic,
        Collider::sphere(0.3),
        Mass(5.0),
        Restitution(0.3),
        Transform::from_xyz(0.1, 3.0, 0.0),
    ));
    // A small stack of boxes, and a ball thrown at it.
    for i in 0..3 {
        commands.spawn((
            Name::new(format!("stacked box {i}")),
            RigidBody::Dynamic,
            Collider::cuboid(0.3, 0.3, 0.3),
            Mass(2.0),
            Friction(0.5),
            Transform::from_xyz(2.5, 0.3 + 0.6 * i as f32, 0.0),
        ));
    }
    commands.spawn((
        Name::new("thrown ball"),
        RigidBody::Dynamic,
        Collider::sphere(0.2),
        Mass(3.0),
        Restitution(0.5),
        Transform::from_xyz(-1.0, 1.5, 0.0),
        LinearVelocity(Vec3::new(6.0, 1.0, 0.0)),
    ));
}

fn report_impacts(
    time: Res<Time<Fixed>>,
    mut impacts: MessageReader<Impact>,
    mut started: MessageReader<CollisionStarted>,
    names: Query<&Name>,
) {
    let name = |e: Entity| {
        names
            .get(e)
            .map_or_else(|_| format!("{e}"), |n| n.to_string())
    };
    for impact in impacts.read() {
        println!(
            "t = {:5.3} s  impact   {:<14} -> {:<14} j = {:8.4} N s at ({:6.3}, {:6.3}, {:6.3})",
            time.elapsed_secs(),
            name(impact.a),
            name(impact.b),
            impact.impulse,
            impact.point.x,
            impact.point.y,
            impact.point.z
        );
    }
    for CollisionStarted(a, b) in started.read() {
        println!(
            "t = {:5.3} s  touching {:<14} -- {}",
            time.elapsed_secs(),
            name(*a),
            name(*b)
        );
    }
}
