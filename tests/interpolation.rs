//! Transform interpolation: it changes nothing in the simulation, wakes no sleeper, and draws a
//! body where it was one step ago plus the elapsed fraction of the step.

use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use impact3d::interpolation::InterpolationState;
use impact3d::prelude::*;
use impact3d::scenes;

const HZ: f64 = 60.0;

/// A headless app whose updates are render frames `1 / (HZ x frames_per_step)` s long (several
/// frames per fixed step), with interpolation for all bodies if `all`.
fn frame_app(frames_per_step: u32, all: bool) -> App {
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins,
        PhysicsPlugins::default().set(InterpolationPlugin { all }),
    ));
    let step = Time::<Fixed>::from_hz(HZ).timestep();
    app.insert_resource(Time::<Fixed>::from_hz(HZ))
        .insert_resource(TimeUpdateStrategy::ManualDuration(step / frames_per_step));
    app.update();
    app
}

/// Fixed steps run so far.
fn steps(app: &App) -> u128 {
    let fixed = app.world().resource::<Time<Fixed>>();
    fixed.elapsed().as_nanos() / fixed.timestep().as_nanos()
}

/// Updates until `n` fixed steps have run in all.
fn run_to_step(app: &mut App, n: u128) {
    while steps(app) < n {
        app.update();
    }
}

/// The physics state of every body, bit for bit: pose (the one the physics wrote: the
/// interpolation end for interpolated bodies), velocities, asleep or not.
fn physics_state(app: &mut App, bodies: &[Entity]) -> Vec<([u32; 7], [u32; 6], bool)> {
    let world = app.world();
    bodies
        .iter()
        .map(|&e| {
            let t = world.get::<Transform>(e).unwrap();
            let (p, r) = world
                .get::<InterpolationState>(e)
                .filter(|s| s.valid)
                .map_or((t.translation, t.rotation), |s| s.end);
            let v = world.get::<LinearVelocity>(e).unwrap().0;
            let w = world.get::<AngularVelocity>(e).unwrap().0;
            let bits = |x: &[f32]| x.iter().map(|f| f.to_bits()).collect::<Vec<_>>();
            let pose = bits(&[p.x, p.y, p.z, r.x, r.y, r.z, r.w]);
            let vel = bits(&[v.x, v.y, v.z, w.x, w.y, w.z]);
            (
                pose.try_into().unwrap(),
                vel.try_into().unwrap(),
                world.get::<Sleeping>(e).is_some(),
            )
        })
        .collect()
}

/// A pour of 64 spheres and a box dropped beside it, stepped 300 times (5 s, long enough for
/// bodies to fall asleep): without interpolation one update per step; with interpolation of
/// every body and 3 frames per step; with interpolation of every other body (the component)
/// and 5 frames per step. Every pose, velocity and sleep state is bit-identical at every 30th
/// step, and the run without interpolation ends with sleeping bodies (so sleep is covered).
#[test]
fn interpolation_does_not_change_the_simulation() {
    let build = |app: &mut App| {
        let world = app.world_mut();
        let mut bodies = scenes::pour(world, 64);
        bodies.push(
            world
                .spawn(scenes::cuboid(
                    Vec3::splat(0.5),
                    1.0,
                    Vec3::new(8.0, 2.0, 0.0),
                ))
                .id(),
        );
        bodies
    };
    let mut plain = scenes::headless_app(HZ);
    let bodies = build(&mut plain);
    let mut all = frame_app(3, true);
    assert_eq!(build(&mut all), bodies);
    let mut some = frame_app(5, false);
    assert_eq!(build(&mut some), bodies);
    for &e in bodies.iter().step_by(2) {
        some.world_mut()
            .entity_mut(e)
            .insert(TransformInterpolation);
    }
    let mut compared = 0;
    for n in (30..=300).step_by(30) {
        scenes::run_steps(&mut plain, 30);
        run_to_step(&mut all, n);
        run_to_step(&mut some, n);
        let reference = physics_state(&mut plain, &bodies);
        assert_eq!(physics_state(&mut all, &bodies), reference, "all, step {n}");
        assert_eq!(
            physics_state(&mut some, &bodies),
            reference,
            "some, step {n}"
        );
        compared += 1;
    }
    assert_eq!(compared, 10);
    let asleep = physics_state(&mut plain, &bodies)
        .iter()
        .filter(|s| s.2)
        .count();
    assert!(asleep > 0, "precondition: some bodies sleep by the end");
    // And interpolation was on: an interpolated body has a valid state.
    assert!(
        all.world()
            .get::<InterpolationState>(bodies[0])
            .unwrap()
            .valid
    );
}

/// A box resting on the ground falls asleep, then runs 2 s of frames at 4 per step with
/// interpolation: it stays asleep at every frame (interpolation never wakes it). Moving it by
/// hand still wakes it.
#[test]
fn interpolation_wakes_no_sleeper() {
    let mut app = frame_app(4, false);
    let (_, cube) = scenes::resting_box(app.world_mut(), 0.0);
    app.world_mut()
        .entity_mut(cube)
        .insert(TransformInterpolation);
    run_to_step(&mut app, 60);
    assert!(
        app.world().get::<Sleeping>(cube).is_some(),
        "precondition: asleep after 1 s"
    );
    let pose = *app.world().get::<Transform>(cube).unwrap();
    while steps(&app) < 180 {
        app.update();
        assert!(
            app.world().get::<Sleeping>(cube).is_some(),
            "woken at step {}",
            steps(&app)
        );
        assert_eq!(*app.world().get::<Transform>(cube).unwrap(), pose);
    }
    app.world_mut()
        .get_mut::<Transform>(cube)
        .unwrap()
        .translation
        .y += 1.0;
    let n = steps(&app);
    run_to_step(&mut app, n + 1);
    assert!(
        app.world().get::<Sleeping>(cube).is_none(),
        "a teleport wakes it"
    );
}

/// A body in free flight at 1 m/s along x (no gravity), interpolated, 4 frames per step: at
/// every frame it is drawn at `x0 + v (t - dt)` (one step behind the simulation, `t` the
/// elapsed virtual time), not at the last step's pose. Tolerance 1e-5 m: f32 positions near
/// 1 m and the f32 overstep fraction.
#[test]
fn interpolated_body_moves_every_frame() {
    let mut app = frame_app(4, false);
    app.world_mut().insert_resource(Gravity(Vec3::ZERO));
    let body = app
        .world_mut()
        .spawn((
            scenes::ball(0.1, 1.0, Vec3::ZERO, Vec3::X),
            TransformInterpolation,
        ))
        .id();
    let dt = 1.0 / HZ;
    run_to_step(&mut app, 2);
    let mut last = f32::NEG_INFINITY;
    let mut frames = 0;
    while steps(&app) < 30 {
        app.update();
        let t = app.world().resource::<Time<Virtual>>().elapsed_secs_f64();
        let x = app.world().get::<Transform>(body).unwrap().translation.x;
        let expected = (t - dt) as f32;
        assert!(
            (x - expected).abs() < 1e-5,
            "x {x}, expected {expected} at t {t}"
        );
        assert!(x > last, "moves every frame");
        last = x;
        frames += 1;
    }
    assert!(frames >= 4 * 27, "{frames} frames");
}
