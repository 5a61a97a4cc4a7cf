//! Character movement (`KinematicCharacter`, `MoveAndSlide`) in whole apps under
//! `MinimalPlugins`, against answers worked out by hand from the geometry: steps climbed or
//! not, slopes walked or not, sliding along a wall, snapping down a ramp, no tunnelling, the
//! same bits on every run, and bad input.
//!
//! The character is a capsule of radius `R` = 0.3 m and half height `HALF` = 0.5 m (its centre
//! 0.8 m above its lowest point) with the default skin `SKIN` = 0.01 m, on the ground `y < 0`:
//! standing, its centre is at `STAND` = 0.81 m. Steps are 1/60 s.
//!
//! Tolerances. Each cast is exact to about 1e-6 m (`spatial_query::exact`), the skin is kept
//! exactly against planes (the pull-back is `skin / cos` of the angle to the plane), and the
//! depenetration stops once what is left is below 1e-4 m: so positions are checked to 1e-3 m
//! (a tenth of the skin) over a whole walk, and heights that must not change to 1e-4 m.

use bevy::ecs::schedule::SingleThreadedExecutor;
use bevy::ecs::system::RunSystemOnce;
use bevy::prelude::*;
use impact3d::prelude::*;
use impact3d::scenes::{headless_app, run_steps};

mod common;

const R: f32 = 0.3;
const HALF: f32 = 0.5;
const SKIN: f32 = 0.01;
/// The centre's height of a character standing on `y = 0`.
const STAND: f32 = HALF + R + SKIN;
const DT: f32 = 1.0 / 60.0;

/// A headless app with characters, the ground `y < 0`, stepped once per update.
fn new_app() -> App {
    let mut app = headless_app(60.0);
    app.add_plugins(CharacterPlugin::default());
    // One thread, the test's: the per-thread log capture sees the characters' errors.
    app.edit_schedule(FixedPostUpdate, |schedule| {
        schedule.set_executor(SingleThreadedExecutor::new());
    });
    app.world_mut()
        .spawn((RigidBody::Static, Collider::half_space(Vec3::Y)));
    app
}

/// A character spawned once the scene has been through a step (what queries see is what the
/// last step recorded: a collider spawned in the same frame as the character would not be
/// there for its first move).
fn character(app: &mut App, at: Vec3, velocity: Vec3, config: CharacterConfig) -> Entity {
    run_steps(app, 1);
    app.world_mut()
        .spawn((
            KinematicCharacter { velocity },
            config,
            Collider::capsule(R, HALF),
            Transform::from_translation(at),
        ))
        .id()
}

fn block(world: &mut World, center: Vec3, half: Vec3) -> Entity {
    world
        .spawn((
            RigidBody::Static,
            Collider::cuboid(half.x, half.y, half.z),
            Transform::from_translation(center),
        ))
        .id()
}

/// A slope rising along +x at `angle` from the crease `x = 1` on the ground: a 8 x 1 x 4 m box
/// turned about z, whose top face goes through (1, 0, 0), 1 m of it under the ground.
fn slope(world: &mut World, angle: f32) -> Entity {
    let turn = Quat::from_rotation_z(angle);
    let top_center = Vec3::new(1.0, 0.0, 0.0) + turn * Vec3::new(3.0, 0.0, 0.0);
    world
        .spawn((
            RigidBody::Static,
            Collider::cuboid(4.0, 0.5, 2.0),
            Transform::from_translation(top_center + turn * Vec3::new(0.0, -0.5, 0.0))
                .with_rotation(turn),
        ))
        .id()
}

/// The centre's height of a character resting on the slope of [`slope`] at `x`: its lower
/// hemisphere's centre `(x, y - HALF)` is `R + SKIN` from the slope's plane, whose normal is
/// `(-sin a, cos a, 0)` through (1, 0, 0): `-(x - 1) sin a + (y - HALF) cos a = R + SKIN`.
fn height_on_slope(x: f32, angle: f32) -> f32 {
    HALF + ((R + SKIN) + (x - 1.0) * angle.sin()) / angle.cos()
}

fn config(max_step_height: f32) -> CharacterConfig {
    CharacterConfig {
        max_step_height,
        max_slope_angle: 45f32.to_radians(),
        ..default()
    }
}

/// Steps `steps` times, returning the character's translation and output after each.
fn walk(app: &mut App, who: Entity, steps: u32) -> Vec<(Vec3, CharacterOutput)> {
    (0..steps)
        .map(|_| {
            run_steps(app, 1);
            let at = app.world().get::<Transform>(who).unwrap().translation;
            (at, app.world().get::<CharacterOutput>(who).unwrap().clone())
        })
        .collect()
}

/// A character with `push_mass` pushes the dynamic body it runs into as an inelastic impact of
/// a body of that mass moving at its velocity, by the seed formula; without it, it pushes
/// nothing. Gravity 0; a sphere character (r 0.3, so the hit point is one point) at height 1
/// walks along +x at `v` = 2 m/s, `M` = 80 kg, into a body whose face or surface is 0.7 m
/// ahead. Closed form (`e = 0`, the character's rotation left out, `n = +x`):
/// `j = v / (1/M + 1/m + |r x n|^2 / I)`, the body's `dv = j n / m`, `dw = I^-1 (r x j n)`.
/// - A sphere of 20 kg centred on the path: `r x n = 0`, so `dv = M v / (M + m)` = 1.6 m/s, no
///   spin.
/// - A cube (half extent 0.5, 10 kg, `I = m / 6`) centred 0.3 m above the path: the hit is at
///   `r = (-0.5, -0.3, 0)` from its centre, `r x n = (0, 0, 0.3)`.
///
/// The body rests asleep before the hit: the push wakes it. Tolerance 1e-4 (relative): the
/// impulse is one evaluation of the formula in `f32`, and the step after it integrates a free
/// body (no gravity, no contact pushing: the character stops a skin short of it).
#[test]
fn pushes_dynamic_bodies_as_an_inelastic_impact_of_its_push_mass() {
    let (v, big) = (2.0f32, 80.0f32);
    let ball_of = |m: f32| (Collider::sphere(0.5), Mass(m), Vec3::new(1.5, 1.0, 0.0));
    // (collider, mass, centre, expected dv, expected dw)
    let cube_inertia = 10.0 / 6.0;
    let rn = 0.3f32;
    let j_cube = v / (1.0 / big + 1.0 / 10.0 + rn * rn / cube_inertia);
    let cases = [
        {
            let (collider, mass, at) = ball_of(20.0);
            (
                collider,
                mass,
                at,
                Vec3::new(big * v / (big + 20.0), 0.0, 0.0),
                Vec3::ZERO,
            )
        },
        (
            Collider::cuboid(0.5, 0.5, 0.5),
            Mass(10.0),
            Vec3::new(1.5, 1.3, 0.0),
            Vec3::new(j_cube / 10.0, 0.0, 0.0),
            Vec3::new(0.0, 0.0, j_cube * rn / cube_inertia),
        ),
    ];
    for (collider, mass, at, dv, dw) in cases {
        for push_mass in [Some(big), None] {
            let mut app = new_app();
            app.insert_resource(Gravity(Vec3::ZERO));
            let body = app
                .world_mut()
                .spawn((
                    RigidBody::Dynamic,
                    collider.clone(),
                    mass,
                    Transform::from_translation(at),
                ))
                .id();
            // Long enough for the body to fall asleep before the character arrives.
            run_steps(&mut app, 90);
            assert!(
                app.world().get::<Sleeping>(body).is_some(),
                "asleep before the hit"
            );
            let config = CharacterConfig {
                push_mass,
                ..default()
            };
            let who = app
                .world_mut()
                .spawn((
                    KinematicCharacter {
                        velocity: Vec3::new(v, 0.0, 0.0),
                    },
                    config,
                    Collider::sphere(0.3),
                    Transform::from_xyz(0.0, 1.0, 0.0),
                ))
                .id();
            let mut pushed = None;
            for _ in 0..60 {
                run_steps(&mut app, 1);
                let got = app.world().get::<LinearVelocity>(body).unwrap().0;
                if got != Vec3::ZERO {
                    pushed = Some((got, app.world().get::<AngularVelocity>(body).unwrap().0));
                    break;
                }
            }
            let hit = app.world().get::<CharacterOutput>(who).unwrap().hits.len();
            match push_mass {
                Some(_) => {
                    let (got_v, got_w) = pushed.expect("the body is pushed");
                    let tol = 1e-4 * dv.length();
                    assert!((got_v - dv).length() <= tol, "dv {got_v}, expected {dv}");
                    assert!(
                        (got_w - dw).length() <= tol.max(1e-4 * dw.length()),
                        "dw {got_w}, expected {dw}"
                    );
                }
                None => {
                    assert!(pushed.is_none(), "pushed without push_mass: {pushed:?}");
                    // It did run into the body and stopped a skin short of its face.
                    let x = app.world().get::<Transform>(who).unwrap().translation.x;
                    assert!(hit > 0 && x < 1.0 - 0.3, "x {x}");
                }
            }
        }
    }
}

/// A 0.3 m step is climbed with `max_step_height` 0.35 m; a 0.5 m one is not.
#[test]
fn climbs_a_step_lower_than_max_step_height_only() {
    for (height, climbs) in [(0.3, true), (0.5, false)] {
        let mut app = new_app();
        let w = app.world_mut();
        // The step's riser at x = 1, 2 m deep.
        block(
            w,
            Vec3::new(2.0, height / 2.0, 0.0),
            Vec3::new(1.0, height / 2.0, 2.0),
        );
        let who = character(
            &mut app,
            Vec3::new(0.0, STAND, 0.0),
            Vec3::X * 2.0,
            config(0.35),
        );
        // 60 steps at 2 m/s: 2 m asked for.
        let path = walk(&mut app, who, 60);
        let (end, out) = path.last().unwrap();
        if climbs {
            // On top, the same skin above it, having walked the whole 2 m (stepping up takes
            // nothing from the walk).
            assert!(
                (end.y - (height + STAND)).abs() < 1e-3,
                "{height} m: ended at {end}"
            );
            assert!((end.x - 2.0).abs() < 1e-3, "{height} m: ended at {end}");
            assert!(out.grounded && (out.ground_normal - Vec3::Y).length() < 1e-4);
            let stepped: f32 = path.iter().map(|(_, o)| o.stepped_up).sum();
            assert!(
                (stepped - height).abs() < 1e-3,
                "stepped up {stepped} m in all"
            );
        } else {
            // Never rose; stopped with the skin between it and the riser: x = 1 - R - SKIN.
            let highest = path.iter().map(|(at, _)| at.y).fold(f32::MIN, f32::max);
            assert!(highest - STAND < 1e-4, "{height} m: rose to {highest}");
            assert!(
                (end.x - (1.0 - R - SKIN)).abs() < 1e-3,
                "{height} m: ended at {end}"
            );
            assert!(path.iter().all(|(_, o)| o.stepped_up == 0.0 && o.grounded));
        }
    }
}

/// With a steepest slope of 45 degrees: up a 30 degree ramp, resting on it all the way; not up
/// a 60 degree slope, which stops it where its hemisphere is the skin from the slope.
#[test]
fn walks_up_a_30_degree_ramp_and_not_a_60_degree_slope() {
    let (ramp, steep) = (30f32.to_radians(), 60f32.to_radians());
    // 30 degrees: 90 steps at 2 m/s from x = 0 (the crease at 1 m).
    let mut app = new_app();
    slope(app.world_mut(), ramp);
    let who = character(
        &mut app,
        Vec3::new(0.0, STAND, 0.0),
        Vec3::X * 2.0,
        config(0.35),
    );
    let path = walk(&mut app, who, 90);
    let (end, out) = path.last().unwrap();
    // On the ramp the horizontal motion is projected on its plane, keeping cos^2 30 = 3/4 of
    // its horizontal progress: from the crease (reached after about 0.4 s) 1.1 s at 1.5 m/s.
    assert!(end.x > 2.3, "walked only to {end}");
    assert!(out.grounded && (out.ground_normal.angle_between(Vec3::Y) - ramp).abs() < 1e-3);
    // Every step once past the crease's reach rests on the ramp at the height of the geometry.
    for (at, o) in path.iter().filter(|(at, _)| at.x > 1.2) {
        let expected = height_on_slope(at.x, ramp);
        assert!(
            (at.y - expected).abs() < 1e-3,
            "at {at}: expected y = {expected}"
        );
        assert!(o.grounded, "not grounded at {at}");
    }

    // 60 degrees: against the slope at x = 1 - ((R + SKIN) - (R + SKIN) cos 60) / sin 60
    // (its hemisphere's centre, at height R + SKIN, is R + SKIN from the plane).
    let mut app = new_app();
    slope(app.world_mut(), steep);
    let who = character(
        &mut app,
        Vec3::new(0.0, STAND, 0.0),
        Vec3::X * 2.0,
        config(0.35),
    );
    let path = walk(&mut app, who, 90);
    let highest = path.iter().map(|(at, _)| at.y).fold(f32::MIN, f32::max);
    assert!(
        highest - STAND <= SKIN,
        "rose to {highest} on the 60 degree slope"
    );
    assert!(
        highest - STAND < 1e-4,
        "rose to {highest}: it did not climb at all"
    );
    let stop = 1.0 - ((R + SKIN) - (R + SKIN) * steep.cos()) / steep.sin();
    let (end, out) = path.last().unwrap();
    assert!(
        (end.x - stop).abs() < 1e-3,
        "stopped at {end}, expected x = {stop}"
    );
    assert!(out.grounded && (out.ground_normal - Vec3::Y).length() < 1e-4);
}

/// Into a wall at 45 degrees at 3 m/s: the tangential component goes on, 3 cos 45 m/s, every
/// step; the character never gets closer to the wall than the skin.
#[test]
fn slides_along_a_wall_hit_at_45_degrees() {
    let mut app = new_app();
    // The wall's face at x = 2.
    block(
        app.world_mut(),
        Vec3::new(2.5, 2.0, 0.0),
        Vec3::new(0.5, 2.0, 10.0),
    );
    let speed = 3.0;
    let angle = 45f32.to_radians();
    let velocity = speed * Vec3::new(angle.cos(), 0.0, angle.sin());
    let who = character(&mut app, Vec3::new(0.0, STAND, 0.0), velocity, config(0.35));
    let path = walk(&mut app, who, 60);
    // Contact at x = 2 - R - SKIN, after 1.69 / (3 cos 45) = 0.797 s: step 48.
    let touching = 2.0 - R - SKIN;
    let mut previous = Vec3::new(0.0, STAND, 0.0);
    let mut sliding_steps = 0;
    for (k, (at, _)) in path.iter().enumerate() {
        // The gap to the wall's face, less the radius: never negative (within 1e-5 m, the
        // casts' accuracy).
        assert!(
            2.0 - (at.x + R) >= -1e-5,
            "step {k}: inside the wall at {at}"
        );
        // The tangential speed, every step, against |v| cos 45 = 2.1213 m/s, within 1e-3 m/s
        // (6e-5 m over a 1/60 s step: a tenth of what depenetration may leave).
        let tangential = (at.z - previous.z) / DT;
        assert!(
            (tangential - speed * angle.cos()).abs() < 1e-3,
            "step {k}: tangential speed {tangential}"
        );
        if (at.x - touching).abs() < 1e-3 {
            sliding_steps += 1;
            // Against the wall, the normal component is gone.
            assert!((at.x - previous.x).abs() < 1e-4 || previous.x < touching - 1e-3);
        }
        assert!((at.y - STAND).abs() < 1e-4, "step {k}: y = {}", at.y);
        previous = *at;
    }
    assert!(sliding_steps >= 12, "slid for {sliding_steps} steps only");
    let end = path.last().unwrap().0;
    // Over the whole second, the tangential part was never lost: z = 3 sin 45.
    assert!((end.z - speed * angle.sin()).abs() < 1e-3, "ended at {end}");
}

/// Walking down a 30 degree ramp at 2 m/s the ground falls 2/60 tan 30 = 19 mm a step: with
/// the default snap distance (0.2 m) the character is on the ground after every step, at the
/// ramp's height; without snapping it leaves the ground.
#[test]
fn snaps_to_the_ground_going_down_a_ramp() {
    let ramp = 30f32.to_radians();
    for snap in [0.2, 0.0] {
        let mut app = new_app();
        slope(app.world_mut(), ramp);
        let start = Vec3::new(4.0, height_on_slope(4.0, ramp), 0.0);
        let config = CharacterConfig {
            snap_to_ground: snap,
            ..config(0.35)
        };
        let who = character(&mut app, start, Vec3::NEG_X * 2.0, config);
        let path = walk(&mut app, who, 150);
        if snap > 0.0 {
            for (k, (at, out)) in path.iter().enumerate() {
                assert!(out.grounded, "step {k}: not grounded at {at}");
                if at.x > 1.2 {
                    let expected = height_on_slope(at.x, ramp);
                    assert!(
                        (at.y - expected).abs() < 1e-3,
                        "step {k}: {at}, y = {expected}"
                    );
                }
            }
            // 5 m: 4 m down the slope and 1 m on along the ground.
            let end = path.last().unwrap().0;
            assert!(
                (end.y - STAND).abs() < 1e-3 && end.x < 0.0,
                "ended at {end}"
            );
        } else {
            let airborne = path.iter().filter(|(_, out)| !out.grounded).count();
            assert!(
                airborne > 60,
                "without snapping it was airborne {airborne} steps only"
            );
        }
    }
}

/// One move of 100 m (6,000 m/s for one step) at a wall 1 cm thick 5 m away: it stops at the
/// wall, the skin before it.
#[test]
fn does_not_pass_through_a_thin_wall_in_one_large_move() {
    let mut app = new_app();
    block(
        app.world_mut(),
        Vec3::new(5.0, 2.0, 0.0),
        Vec3::new(0.005, 2.0, 5.0),
    );
    let who = character(
        &mut app,
        Vec3::new(0.0, STAND, 0.0),
        Vec3::X * 6000.0,
        config(0.35),
    );
    let path = walk(&mut app, who, 1);
    let (end, out) = &path[0];
    assert!((out.desired_translation.x - 100.0).abs() < 1e-2);
    let expected = 5.0 - 0.005 - R - SKIN;
    assert!(
        (end.x - expected).abs() < 1e-3,
        "ended at {end}, expected x = {expected}"
    );
}

/// A walk over a ramp, a step and into a wall, with the velocity changing every step: the same
/// bits, every position and output, on two runs.
#[test]
fn a_sequence_of_moves_is_bit_identical_run_after_run() {
    let run = || {
        let mut app = new_app();
        let w = app.world_mut();
        slope(w, 20f32.to_radians());
        block(w, Vec3::new(-2.0, 0.1, 0.0), Vec3::new(1.0, 0.1, 1.0));
        block(w, Vec3::new(0.0, 1.0, -3.0), Vec3::new(4.0, 1.0, 0.2));
        let who = character(
            &mut app,
            Vec3::new(-1.0, 1.5, 1.0),
            Vec3::ZERO,
            config(0.35),
        );
        let mut trace = Vec::new();
        for k in 0..240 {
            let t = k as f32 * DT;
            let v = Vec3::new(2.5 * (0.7 * t).sin(), -1.0, -2.0 * (1.3 * t).cos());
            app.world_mut()
                .get_mut::<KinematicCharacter>(who)
                .unwrap()
                .velocity = v;
            run_steps(&mut app, 1);
            let at = app.world().get::<Transform>(who).unwrap().translation;
            let out = app.world().get::<CharacterOutput>(who).unwrap();
            trace.push((
                at.to_array().map(f32::to_bits),
                out.grounded,
                out.stepped_up.to_bits(),
            ));
        }
        trace
    };
    let (a, b) = (run(), run());
    assert_eq!(a, b);
    // It went somewhere: the scene was exercised.
    let moved = a.first().unwrap().0 != a.last().unwrap().0;
    assert!(moved && a.iter().any(|s| s.1));
}

/// Runs `f` with a `MoveAndSlide` of `app`'s world, as a system between steps would.
fn with_move_and_slide<T: Send + 'static>(
    app: &mut App,
    f: impl FnOnce(&MoveAndSlide) -> T + Send + Sync + 'static,
) -> T {
    let mut f = Some(f);
    app.world_mut()
        .run_system_once(move |m: MoveAndSlide| (f.take().unwrap())(&m))
        .unwrap()
}

/// avian3d's `move_and_slide` itself: a ball (r = 0.5 m) at 4 m/s into a wall at 45 degrees,
/// no ground, for 1 s: it ends the skin from the wall, having kept the velocity's tangential
/// part (x: 4 cos 45 = 2.828 m), and its projected velocity is that tangential part alone; the
/// `on_hit` callback sees the wall with its normal.
#[test]
fn move_and_slide_keeps_the_tangential_velocity_along_a_wall() {
    let mut app = new_app();
    // The wall's face at z = -1, facing +z.
    let wall = block(
        app.world_mut(),
        Vec3::new(0.0, 5.0, -1.5),
        Vec3::new(10.0, 2.0, 0.5),
    );
    run_steps(&mut app, 1);
    let v = 4.0 * Vec3::new(45f32.to_radians().cos(), 0.0, -45f32.to_radians().sin());
    let (out, hits) = with_move_and_slide(&mut app, move |m| {
        let mut hits = Vec::new();
        let out = m.move_and_slide(
            &Collider::sphere(0.5),
            Vec3::new(0.0, 5.0, 0.0),
            Quat::IDENTITY,
            v,
            std::time::Duration::from_secs(1),
            &MoveAndSlideConfig::default(),
            &SpatialQueryFilter::default(),
            |hit| {
                hits.push((hit.entity, hit.normal.as_vec3()));
                MoveAndSlideHitResponse::Accept
            },
        );
        (out, hits)
    });
    // Tolerance 1e-4: the cast's 1e-6 plus depenetration's error bound, 1e-4 m.
    let expected = Vec3::new(4.0 * 45f32.to_radians().cos(), 5.0, -1.0 + 0.5 + SKIN);
    assert!(
        (out.position - expected).length() < 1e-4,
        "{} against {expected}",
        out.position
    );
    let tangential = Vec3::new(v.x, 0.0, 0.0);
    assert!(
        (out.projected_velocity - tangential).length() < 1e-4,
        "{}",
        out.projected_velocity
    );
    assert!(
        !hits.is_empty()
            && hits
                .iter()
                .all(|(e, n)| *e == wall && (*n - Vec3::Z).length() < 1e-4)
    );
}

/// A character spawned 0.2 m into the ground, or into the corner of the ground and a wall, is
/// pushed out to the skin's distance from each (`depenetrate`), and `move_character` with no
/// motion does that and stands it there, grounded.
#[test]
fn depenetration_pushes_out_of_the_ground_and_a_wall_to_the_skin() {
    let mut app = new_app();
    // A wall's face at x = 1.
    block(
        app.world_mut(),
        Vec3::new(1.5, 2.0, 0.0),
        Vec3::new(0.5, 2.0, 2.0),
    );
    run_steps(&mut app, 1);
    let (offset, out) = with_move_and_slide(&mut app, |m| {
        let capsule = Collider::capsule(R, HALF);
        let at = Vec3::new(1.0 - R + 0.1, STAND - 0.2, 0.0);
        let filter = SpatialQueryFilter::default();
        let offset = m.depenetrate(&capsule, at, Quat::IDENTITY, &default(), &filter);
        let out = m
            .move_character(
                &capsule,
                at,
                Quat::IDENTITY,
                Vec3::ZERO,
                &default(),
                &filter,
            )
            .unwrap();
        (offset, out)
    });
    // Out by 0.1 + skin along -x and 0.2 along +y (the two normals are orthogonal, so one
    // Gauss-Seidel pass is exact).
    assert!(
        (offset - Vec3::new(-0.1 - SKIN, 0.2, 0.0)).length() < 1e-4,
        "{offset}"
    );
    let stands = Vec3::new(1.0 - R - SKIN, STAND, 0.0);
    assert!((out.position - stands).length() < 1e-4, "{}", out.position);
    assert!(out.grounded && (out.ground_normal - Vec3::Y).length() < 1e-4);
}

/// The errors logged on this thread since the last call.
fn take_errors() -> Vec<String> {
    common::take_logs()
        .into_iter()
        .filter(|(level, _)| *level == log::Level::Error)
        .map(|(_, message)| message)
        .collect()
}

/// NaN and infinite velocities and settings: one logged error naming each character (by its
/// `Name`, else its entity), not repeated while the input stays bad, no movement, no panic; a
/// good character beside them walks on; fixed, a character moves, and broken again it is
/// logged again.
#[test]
fn bad_input_is_logged_once_per_character_and_moves_nothing() {
    common::capture_logs();
    let mut app = new_app();
    run_steps(&mut app, 1);
    let at = |z: f32| Vec3::new(0.0, STAND, z);
    let mut spawn = |name: Option<&str>, z: f32, velocity: Vec3, config: CharacterConfig| {
        let mut e = app.world_mut().spawn((
            KinematicCharacter { velocity },
            config,
            Collider::capsule(R, HALF),
            Transform::from_translation(at(z)),
        ));
        if let Some(name) = name {
            e.insert(Name::new(name.to_string()));
        }
        e.id()
    };
    let nan = spawn(
        Some("NanVelocity"),
        0.0,
        Vec3::new(f32::NAN, 0.0, 0.0),
        config(0.35),
    );
    let inf = spawn(
        Some("InfiniteVelocity"),
        2.0,
        Vec3::new(0.0, 0.0, f32::INFINITY),
        config(0.35),
    );
    let bad_step = spawn(Some("InfiniteStep"), 4.0, Vec3::X, config(f32::INFINITY));
    let nan_slope = CharacterConfig {
        max_slope_angle: f32::NAN,
        ..config(0.35)
    };
    let unnamed = spawn(None, 6.0, Vec3::X, nan_slope);
    let good = spawn(Some("Good"), 8.0, Vec3::X, config(0.35));
    // A scale of NaN (the cast would use the collider unscaled: refused for any scale but 1).
    let scaled = spawn(Some("NanScale"), 10.0, Vec3::X, config(0.35));
    // An invalid collider (a negative radius; the step quarantines the body too, and says so).
    let bad_shape = spawn(Some("NegativeRadius"), 12.0, Vec3::X, config(0.35));
    app.world_mut().get_mut::<Transform>(scaled).unwrap().scale = Vec3::new(f32::NAN, 1.0, 1.0);
    app.world_mut()
        .entity_mut(bad_shape)
        .insert(Collider::sphere(-1.0));
    take_errors();
    run_steps(&mut app, 10);
    // The characters' own errors (the physics step logs the quarantined body on its own).
    let errors: Vec<String> = take_errors()
        .into_iter()
        .filter(|m| m.contains("does not move"))
        .collect();
    let named = |who: &str| errors.iter().filter(|m| m.contains(who)).count();
    for who in [
        "\"NanVelocity\"",
        "\"InfiniteVelocity\"",
        "\"InfiniteStep\"",
        &format!("character {unnamed}"),
        "\"NanScale\"",
        "\"NegativeRadius\"",
    ] {
        assert_eq!(named(who), 1, "{who}: {errors:#?}");
    }
    assert_eq!(errors.len(), 6, "{errors:#?}");
    let bad = [
        (nan, 0.0),
        (inf, 2.0),
        (bad_step, 4.0),
        (unnamed, 6.0),
        (scaled, 10.0),
        (bad_shape, 12.0),
    ];
    for (e, z) in bad {
        let t = app.world().get::<Transform>(e).unwrap().translation;
        assert_eq!(t, at(z), "a bad character moved");
    }
    let walked = app.world().get::<Transform>(good).unwrap().translation;
    assert!(
        (walked.x - 10.0 * DT).abs() < 1e-4,
        "the good character walked to {walked}"
    );

    // Fixed: it moves, silently; broken again: logged again, once.
    app.world_mut()
        .get_mut::<KinematicCharacter>(nan)
        .unwrap()
        .velocity = Vec3::X;
    run_steps(&mut app, 2);
    assert!(!take_errors().iter().any(|m| m.contains("NanVelocity")));
    assert!(app.world().get::<Transform>(nan).unwrap().translation.x > 0.0);
    app.world_mut()
        .get_mut::<KinematicCharacter>(nan)
        .unwrap()
        .velocity = Vec3::NAN;
    run_steps(&mut app, 3);
    let again: Vec<String> = take_errors()
        .into_iter()
        .filter(|m| m.contains("NanVelocity"))
        .collect();
    assert_eq!(again.len(), 1, "{again:#?}");
    assert!(again[0].contains("NanVelocity"));
}
