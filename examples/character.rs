//! A headless character walk: a capsule walks along +x up a 20 degree ramp onto a platform,
//! down two steps, up three, and into a wall, with its own gravity while in the air. Prints
//! where it is, whether it is on the ground, each step it climbs, and where it stops.
//!
//! Run with `cargo run --release --example character`.

use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use impact3d::prelude::*;

/// Simulated time, s.
const SECONDS: u32 = 8;
/// Walking speed, m/s.
const SPEED: f32 = 2.0;
const GRAVITY: f32 = 9.81;
/// The capsule: radius and half height of its cylinder, m.
const RADIUS: f32 = 0.3;
const HALF_HEIGHT: f32 = 0.5;
/// Where the wall's face is, m.
const WALL_X: f32 = 11.0;

#[derive(Component)]
struct Walker {
    /// Vertical speed, m/s: gravity's, while in the air.
    fall: f32,
    steps_climbed: u32,
    was_grounded: bool,
}

fn main() {
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins,
        PhysicsPlugins::default(),
        CharacterPlugin::default(),
    ))
    // One 1/60 s step per update, as fast as the machine allows.
    .insert_resource(Time::<Fixed>::from_hz(60.0))
    .insert_resource(TimeUpdateStrategy::FixedTimesteps(1))
    .add_systems(Startup, spawn_course)
    // Steer before the characters move; report after the step.
    .add_systems(FixedPostUpdate, steer.in_set(PhysicsSystems::First))
    .add_systems(FixedPostUpdate, report.in_set(PhysicsSystems::Last));

    println!("   t (s)      x (m)   feet (m)  grounded");
    // The first update only records the start time; each later one runs one fixed step.
    let started = std::time::Instant::now();
    for _ in 0..=SECONDS * 60 {
        app.update();
    }
    let elapsed = started.elapsed();

    let world = app.world_mut();
    let (at, out, walker) = world
        .query::<(&Transform, &CharacterOutput, &Walker)>()
        .single(world)
        .unwrap();
    let p = at.translation;
    println!(
        "\nStopped at x = {:.4} m (the wall's face at {WALL_X} m, less the radius {RADIUS} m and \
         the skin 0.01 m: {:.4} m), feet at {:.4} m, grounded: {}, {} steps climbed.",
        p.x,
        WALL_X - RADIUS - 0.01,
        p.y - RADIUS - HALF_HEIGHT,
        out.grounded,
        walker.steps_climbed
    );
    println!(
        "{} steps in {:.1} ms (physics, character and printing together).",
        SECONDS * 60,
        elapsed.as_secs_f64() * 1e3
    );
}

/// Walks along +x; falls while not on the ground.
fn steer(mut walkers: Query<(&mut KinematicCharacter, &mut Walker, &CharacterOutput)>) {
    let dt = 1.0 / 60.0;
    for (mut character, mut walker, out) in &mut walkers {
        walker.fall = if out.grounded {
            0.0
        } else {
            walker.fall - GRAVITY * dt
        };
        character.velocity = Vec3::new(SPEED, walker.fall, 0.0);
    }
}

/// Prints the walk every quarter second, each step climbed, and each change of ground.
fn report(mut walkers: Query<(&Transform, &CharacterOutput, &mut Walker)>, time: Res<Time>) {
    let t = time.elapsed_secs();
    for (at, out, mut walker) in &mut walkers {
        let feet = at.translation.y - RADIUS - HALF_HEIGHT;
        if out.stepped_up > 0.0 {
            walker.steps_climbed += 1;
            println!(
                "{t:8.3}  stepped up {:.3} m at x = {:.3} m",
                out.stepped_up, at.translation.x
            );
        }
        if out.grounded != walker.was_grounded {
            let now = if out.grounded {
                "lands"
            } else {
                "leaves the ground"
            };
            println!(
                "{t:8.3}  {now} at x = {:.3} m, feet {feet:.3} m",
                at.translation.x
            );
            walker.was_grounded = out.grounded;
        }
        let tick = (t * 60.0).round() as u32;
        if tick.is_multiple_of(15) {
            println!(
                "{t:8.3} {:10.3} {feet:10.3}  {}",
                at.translation.x, out.grounded
            );
        }
    }
}

/// The course along +x: ground; a 20 degree ramp from x = 2 up to a 0.6 m platform; two 0.2 m
/// steps down to the ground; three 0.2 m steps up to another 0.6 m platform; a wall at
/// x = 11.
fn spawn_course(mut commands: Commands) {
    commands.spawn((
        Name::new("ground"),
        RigidBody::Static,
        Collider::half_space(Vec3::Y),
    ));
    // The ramp: a box turned 20 degrees whose top face runs from under the ground up to the
    // platform's edge at (2 + 0.6 / tan 20, 0.6).
    let angle = 20f32.to_radians();
    let top = Vec3::new(2.0 + 0.6 / angle.tan(), 0.6, 0.0);
    let half_length = (0.6 / angle.sin() + 0.5) / 2.0;
    let turn = Quat::from_rotation_z(angle);
    let center = top - turn * Vec3::new(half_length, 0.25, 0.0);
    commands.spawn((
        Name::new("ramp"),
        RigidBody::Static,
        Collider::cuboid(half_length, 0.25, 1.5),
        Transform::from_translation(center).with_rotation(turn),
    ));
    let mut block = |name: &str, from_x: f32, to_x: f32, height: f32| {
        commands.spawn((
            Name::new(name.to_string()),
            RigidBody::Static,
            Collider::cuboid((to_x - from_x) / 2.0, height / 2.0, 1.5),
            Transform::from_xyz((from_x + to_x) / 2.0, height / 2.0, 0.0),
        ));
    };
    block("platform", top.x, 5.6, 0.6);
    block("step down 1", 5.6, 6.1, 0.4);
    block("step down 2", 6.1, 6.6, 0.2);
    block("step up 1", 8.0, 8.5, 0.2);
    block("step up 2", 8.5, 9.0, 0.4);
    block("upper platform", 9.0, WALL_X, 0.6);
    block("wall", WALL_X, WALL_X + 0.5, 3.0);
    commands.spawn((
        Name::new("walker"),
        Walker {
            fall: 0.0,
            steps_climbed: 0,
            was_grounded: false,
        },
        KinematicCharacter::default(),
        CharacterConfig {
            max_step_height: 0.25,
            ..default()
        },
        Collider::capsule(RADIUS, HALF_HEIGHT),
        Transform::from_xyz(0.0, RADIUS + HALF_HEIGHT + 0.01, 0.0),
    ));
}
