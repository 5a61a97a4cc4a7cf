//! Sensors, collision events and `CollidingEntities` in whole-app scenes. Contacts are computed
//! at the poses at the start of a step, so a pair starts touching in the first step whose start
//! poses overlap (or come within the 5 mm touch distance): step `k` starts from the poses after
//! `k - 1` steps. The kinematic scenes are placed so that no step starts within 5 mm of a
//! boundary: the answer does not depend on the touch distance.

mod common;

use bevy::ecs::message::MessageCursor;
use bevy::prelude::*;
use common::{drain, position, velocity};
use impact3d::collision::ContactPairs;
use impact3d::pipeline::{CandidatePairs, ContactRows};
use impact3d::prelude::*;
use impact3d::scenes::headless_app;

const G: f32 = 9.81;
const DT: f32 = 1.0 / 60.0;

/// The step being run (1 for the first), for the observers' records.
#[derive(Resource, Default)]
struct Step(u32);

/// What the observers heard: (step, observed entity, `collider1`, `collider2`, start?).
#[derive(Resource, Default)]
struct Heard(Vec<(u32, Entity, Entity, Entity, bool)>);

/// Adds observers on `entity` that record each `CollisionStart` and `CollisionEnd` it gets.
fn listen(app: &mut App, entity: Entity) {
    app.world_mut()
        .entity_mut(entity)
        .observe(
            move |ev: On<CollisionStart>, step: Res<Step>, mut heard: ResMut<Heard>| {
                heard
                    .0
                    .push((step.0, entity, ev.collider1, ev.collider2, true));
            },
        )
        .observe(
            move |ev: On<CollisionEnd>, step: Res<Step>, mut heard: ResMut<Heard>| {
                heard
                    .0
                    .push((step.0, entity, ev.collider1, ev.collider2, false));
            },
        );
}

/// Every step's messages, with the step they came in.
#[derive(Default)]
struct Log {
    start: Vec<(u32, CollisionStart)>,
    end: Vec<(u32, CollisionEnd)>,
    started: Vec<(u32, CollisionStarted)>,
    ended: Vec<(u32, CollisionEnded)>,
    cursors: (
        MessageCursor<CollisionStart>,
        MessageCursor<CollisionEnd>,
        MessageCursor<CollisionStarted>,
        MessageCursor<CollisionEnded>,
    ),
}

impl Log {
    /// Runs one step and records its messages.
    fn step(&mut self, app: &mut App) -> u32 {
        app.world_mut().resource_mut::<Step>().0 += 1;
        app.update();
        let step = app.world().resource::<Step>().0;
        let c = &mut self.cursors;
        self.start
            .extend(drain(app, &mut c.0).into_iter().map(|m| (step, m)));
        self.end
            .extend(drain(app, &mut c.1).into_iter().map(|m| (step, m)));
        self.started
            .extend(drain(app, &mut c.2).into_iter().map(|m| (step, m)));
        self.ended
            .extend(drain(app, &mut c.3).into_iter().map(|m| (step, m)));
        step
    }
}

fn app() -> App {
    let mut app = headless_app(60.0);
    app.init_resource::<Step>().init_resource::<Heard>();
    app
}

fn start(c1: Entity, c2: Entity) -> CollisionStart {
    CollisionStart {
        collider1: c1,
        collider2: c2,
        body1: Some(c1),
        body2: Some(c2),
    }
}

fn end(c1: Entity, c2: Entity) -> CollisionEnd {
    CollisionEnd {
        collider1: c1,
        collider2: c2,
        body1: Some(c1),
        body2: Some(c2),
    }
}

/// A kinematic 1 m cube at x0 = -3.0125 m moving at 1.5 m/s (0.025 m a step) through a static
/// sensor cube of half extent 1 m at the origin. Its leading face (x0 + 0.5 at the start) meets
/// the sensor's face at x = -1 after 1.5125 m, 60.5 steps: the start poses of step 61 are
/// 12.5 mm apart, those of step 62 overlap by 12.5 mm, so the pair starts in step 62. Its
/// trailing face passes x = 1 after 4.5125 m, 180.5 steps: step 181 starts 12.5 mm deep, step
/// 182 12.5 mm clear, so it ends in step 182.
const ENTRY: u32 = 62;
const EXIT: u32 = 182;

/// Spawns the sensor and the kinematic cube (with `CollidingEntities`); `events` says which of
/// (sensor, cube) have `CollisionEventsEnabled`. Returns (sensor, cube).
fn trigger_scene(app: &mut App, events: (bool, bool)) -> (Entity, Entity) {
    let world = app.world_mut();
    let mut s = world.spawn((RigidBody::Static, Collider::cuboid(1.0, 1.0, 1.0), Sensor));
    if events.0 {
        s.insert(CollisionEventsEnabled);
    }
    let sensor = s.id();
    let mut k = world.spawn((
        RigidBody::Kinematic,
        Collider::cuboid(0.5, 0.5, 0.5),
        Transform::from_xyz(-3.0125, 0.0, 0.0),
        LinearVelocity(Vec3::new(1.5, 0.0, 0.0)),
        CollidingEntities::default(),
    ));
    if events.1 {
        k.insert(CollisionEventsEnabled);
    }
    let cube = k.id();
    (sensor, cube)
}

/// The kinematic cube through the static sensor: exactly one start (step 62) and one end (step
/// 182), as one message each and to the observers on both bodies, each with itself as
/// `collider1`; `CollidingEntities` holds the sensor exactly from step 62 to step 181; the
/// kinematic cube keeps its velocity (the sensor pushes nothing).
#[test]
fn kinematic_body_through_a_static_sensor() {
    let mut app = app();
    let (sensor, cube) = trigger_scene(&mut app, (true, true));
    listen(&mut app, sensor);
    listen(&mut app, cube);
    let (a, b) = (sensor.min(cube), sensor.max(cube));
    let mut log = Log::default();
    for _ in 0..200 {
        let step = log.step(&mut app);
        let touching = app.world().get::<CollidingEntities>(cube).unwrap();
        let expected = (ENTRY..EXIT).contains(&step);
        assert_eq!(touching.contains(&sensor), expected, "step {step}");
        assert_eq!(touching.len(), expected as usize, "step {step}");
        assert_eq!(velocity(&app, cube), Vec3::new(1.5, 0.0, 0.0));
    }
    // The cube moved 200 steps at 0.025 m (f32 rounding of 200 additions: 1e-5 m).
    assert!((position(&app, cube).x - (-3.0125 + 5.0)).abs() < 1e-4);
    assert_eq!(log.start, vec![(ENTRY, start(a, b))]);
    assert_eq!(log.end, vec![(EXIT, end(a, b))]);
    assert_eq!(log.started, vec![(ENTRY, CollisionStarted(a, b))]);
    assert_eq!(log.ended, vec![(EXIT, CollisionEnded(a, b))]);
    let mut heard = app.world().resource::<Heard>().0.clone();
    heard.sort();
    let mut expected = vec![
        (ENTRY, sensor, sensor, cube, true),
        (ENTRY, cube, cube, sensor, true),
        (EXIT, sensor, sensor, cube, false),
        (EXIT, cube, cube, sensor, false),
    ];
    expected.sort();
    assert_eq!(heard, expected);
}

/// Only the sensor asks for events: the message is still written once each way, the sensor's
/// observer hears both, the cube's observer nothing (avian3d's rule: observers fire on the
/// bodies with `CollisionEventsEnabled`).
#[test]
fn observers_fire_only_where_events_are_enabled() {
    let mut app = app();
    let (sensor, cube) = trigger_scene(&mut app, (true, false));
    listen(&mut app, sensor);
    listen(&mut app, cube);
    let (a, b) = (sensor.min(cube), sensor.max(cube));
    let mut log = Log::default();
    for _ in 0..200 {
        log.step(&mut app);
    }
    assert_eq!(log.start, vec![(ENTRY, start(a, b))]);
    assert_eq!(log.end, vec![(EXIT, end(a, b))]);
    assert_eq!(
        app.world().resource::<Heard>().0,
        vec![
            (ENTRY, sensor, sensor, cube, true),
            (EXIT, sensor, sensor, cube, false)
        ]
    );
}

/// A kinematic cube through a static cube, neither a sensor nor asking for anything: the pair
/// is never a candidate, has no contact pair and sends nothing (it costs nothing past the
/// broad phase). `CollidingEntities` inserted on the kinematic cube mid-way (before step 100,
/// the cubes overlapping since step 62) makes the step track the pair from then on: it starts
/// in step 100, the component is filled with the static cube, and it ends in step 182.
#[test]
fn kinematic_static_pairs_cost_nothing_until_asked_for() {
    let mut app = app();
    let wall = app
        .world_mut()
        .spawn((RigidBody::Static, Collider::cuboid(1.0, 1.0, 1.0)))
        .id();
    let cube = app
        .world_mut()
        .spawn((
            RigidBody::Kinematic,
            Collider::cuboid(0.5, 0.5, 0.5),
            Transform::from_xyz(-3.0125, 0.0, 0.0),
            LinearVelocity(Vec3::new(1.5, 0.0, 0.0)),
        ))
        .id();
    let (a, b) = (wall.min(cube), wall.max(cube));
    let mut log = Log::default();
    for _ in 0..99 {
        let step = log.step(&mut app);
        assert!(
            app.world().resource::<CandidatePairs>().pairs().is_empty(),
            "step {step}"
        );
        assert!(app.world().resource::<ContactPairs>().get(a, b).is_none());
    }
    assert!(log.started.is_empty() && log.start.is_empty());
    app.world_mut()
        .entity_mut(cube)
        .insert(CollidingEntities::default());
    for _ in 99..200 {
        let step = log.step(&mut app);
        let touching = app.world().get::<CollidingEntities>(cube).unwrap();
        assert_eq!(touching.contains(&wall), step < EXIT, "step {step}");
        assert_eq!(
            app.world().resource::<ContactRows>().contacts().len(),
            0,
            "step {step}: a pair of non-dynamic bodies has no rows"
        );
    }
    assert_eq!(log.started, vec![(100, CollisionStarted(a, b))]);
    assert_eq!(log.ended, vec![(EXIT, CollisionEnded(a, b))]);
    // Neither body has `CollisionEventsEnabled`: no avian-style events.
    assert!(log.start.is_empty() && log.end.is_empty());
}

/// Two kinematic cubes passing through each other, one with `CollisionEventsEnabled`: they
/// start at x = -2.00625 and 2.00625 m at 1.5 m/s towards each other (closing 0.05 m a step),
/// centres 4.0125 m apart. They overlap when that is under 1 m: after 60.25 steps (step 61
/// starts 12.5 mm apart, step 62 overlapping), until it is under -1 m: after 100.25 steps (step
/// 101 starts 12.5 mm deep, step 102 37.5 mm clear).
#[test]
fn kinematic_kinematic_pair_reports() {
    let mut app = app();
    let mut spawn = |x: f32, v: f32| {
        app.world_mut()
            .spawn((
                RigidBody::Kinematic,
                Collider::cuboid(0.5, 0.5, 0.5),
                Transform::from_xyz(x, 0.0, 0.0),
                LinearVelocity(Vec3::new(v, 0.0, 0.0)),
            ))
            .id()
    };
    let left = spawn(-2.00625, 1.5);
    let right = spawn(2.00625, -1.5);
    app.world_mut()
        .entity_mut(right)
        .insert(CollisionEventsEnabled);
    listen(&mut app, left);
    listen(&mut app, right);
    let (a, b) = (left.min(right), left.max(right));
    let mut log = Log::default();
    for _ in 0..150 {
        log.step(&mut app);
    }
    assert_eq!(log.start, vec![(62, start(a, b))]);
    assert_eq!(log.end, vec![(102, end(a, b))]);
    assert_eq!(
        app.world().resource::<Heard>().0,
        vec![
            (62, right, right, left, true),
            (102, right, right, left, false)
        ]
    );
}

/// A ball (r = 0.25 m) dropped from 3 m through a static sensor slab (half extents 1, 0.5, 1 at
/// the origin), under the default method and under one that rewinds fast bodies to their
/// first contact: it keeps the free-fall velocity every step (the sensor neither pushes nor
/// stops it), the pair never has a contact row, and it starts touching in the first step whose
/// start pose has the ball within 5 mm of the slab and stops in the first whose start pose has
/// it 5 mm clear below, once each.
#[test]
fn dynamic_body_falls_through_a_sensor_unslowed() {
    for method in [SolverMethod::Hybrid, SolverMethod::SequentialImpulses] {
        let mut app = app();
        app.insert_resource(SolverConfig::for_method(method));
        let slab = app
            .world_mut()
            .spawn((
                RigidBody::Static,
                Collider::cuboid(1.0, 0.5, 1.0),
                Sensor,
                CollisionEventsEnabled,
            ))
            .id();
        let ball = app
            .world_mut()
            .spawn((
                RigidBody::Dynamic,
                Collider::sphere(0.25),
                Mass(1.0),
                Transform::from_xyz(0.0, 3.0, 0.0),
            ))
            .id();
        let (a, b) = (slab.min(ball), slab.max(ball));
        let mut log = Log::default();
        let (mut entry, mut exit) = (None, None);
        for _ in 0..60 {
            // The gap between the ball and the slab at the start of the step (the ball stays
            // on the slab's axis, so it is a vertical distance to a face).
            let y = position(&app, ball).y;
            let gap = (y - 0.25 - 0.5).max(-0.5 - (y + 0.25));
            let step = log.step(&mut app);
            if entry.is_none() && gap <= 0.005 {
                entry = Some(step);
            }
            if entry.is_some() && exit.is_none() && gap > 0.005 {
                exit = Some(step);
            }
            let t = step as f32 * DT;
            // Free fall: v = -g t; tolerance 2e-4 m/s for f32 rounding over 240 substeps.
            let v = velocity(&app, ball);
            assert!(
                (v - Vec3::new(0.0, -G * t, 0.0)).length() < 2e-4,
                "{method:?} step {step}: v = {v}, free fall {}",
                -G * t
            );
            assert!(app.world().resource::<ContactRows>().contacts().is_empty());
        }
        let (entry, exit) = (entry.unwrap(), exit.unwrap());
        // By free fall the ball's bottom reaches 0.5 m after 2.25 m (0.677 s, step 41-42) and
        // its top passes -0.5 m after 3.75 m (0.874 s, step 53-54).
        assert!(
            (41..=43).contains(&entry) && (53..=55).contains(&exit),
            "{entry} {exit}"
        );
        assert_eq!(log.start, vec![(entry, start(a, b))], "{method:?}");
        assert_eq!(log.end, vec![(exit, end(a, b))], "{method:?}");
    }
}

/// A dynamic sensor box dropped onto the ground falls through it under gravity, and reports
/// touching it: free-fall velocity after 1 s, below the ground, one start.
#[test]
fn dynamic_sensor_falls_under_gravity() {
    let mut app = app();
    let ground = app
        .world_mut()
        .spawn((RigidBody::Static, Collider::half_space(Vec3::Y)))
        .id();
    let cube = app
        .world_mut()
        .spawn((
            RigidBody::Dynamic,
            Collider::cuboid(0.5, 0.5, 0.5),
            Transform::from_xyz(0.0, 1.0, 0.0),
            Sensor,
            CollisionEventsEnabled,
        ))
        .id();
    let mut log = Log::default();
    for _ in 0..60 {
        log.step(&mut app);
    }
    // v = -g t after 1 s; tolerance as above. The box fell g t^2 / 2 = 4.9 m (to within the
    // g t dt / 2 = 8 cm a step's discretisation can add).
    assert!((velocity(&app, cube).y + G).abs() < 2e-4);
    let y = position(&app, cube).y;
    assert!((1.0 - y - 0.5 * G).abs() < 0.5 * G * DT + 1e-4, "y = {y}");
    let (a, b) = (ground.min(cube), ground.max(cube));
    // The box's bottom starts 0.5 m up: it touches the ground from the step whose start has
    // fallen 0.5 m - 5 mm (t = 0.318 s), and a half-space never lets go.
    assert_eq!(log.start.len(), 1);
    assert_eq!(log.start[0].1, start(a, b));
    assert!((19..=21).contains(&log.start[0].0), "{}", log.start[0].0);
    assert!(log.end.is_empty());
}

/// `CollidingEntities` holds exactly the bodies touching now: box A rests on the ground, box B
/// is dropped onto A, box C rests on the ground apart. After 2 s (all of them asleep): A
/// touches the ground and B, B touches A, C the ground, the ground A and C. B despawned: A and
/// the ground lose it. The ground's component removed and inserted again while its contacts
/// rest: it is filled again with A and C.
#[test]
fn colliding_entities_hold_the_touching_set() {
    let mut app = app();
    let set = |app: &App, e: Entity| {
        let mut v: Vec<Entity> = app
            .world()
            .get::<CollidingEntities>(e)
            .unwrap()
            .iter()
            .copied()
            .collect();
        v.sort();
        v
    };
    let sorted = |mut v: Vec<Entity>| {
        v.sort();
        v
    };
    let ground = app
        .world_mut()
        .spawn((
            RigidBody::Static,
            Collider::half_space(Vec3::Y),
            CollidingEntities::default(),
        ))
        .id();
    let mut cube = |x: f32, y: f32| {
        app.world_mut()
            .spawn((
                RigidBody::Dynamic,
                Collider::cuboid(0.5, 0.5, 0.5),
                Transform::from_xyz(x, y, 0.0),
                CollidingEntities::default(),
            ))
            .id()
    };
    let (a, b, c) = (cube(0.0, 0.5), cube(0.0, 1.6), cube(5.0, 0.5));
    for _ in 0..120 {
        app.update();
    }
    assert!(app.world().get::<Sleeping>(b).is_some(), "B is asleep");
    assert_eq!(set(&app, a), sorted(vec![ground, b]));
    assert_eq!(set(&app, b), vec![a]);
    assert_eq!(set(&app, c), vec![ground]);
    assert_eq!(set(&app, ground), sorted(vec![a, c]));
    app.world_mut().despawn(b);
    app.update();
    assert_eq!(set(&app, a), vec![ground]);
    assert_eq!(set(&app, ground), sorted(vec![a, c]));
    app.world_mut()
        .entity_mut(ground)
        .remove::<CollidingEntities>();
    app.update();
    app.world_mut()
        .entity_mut(ground)
        .insert(CollidingEntities::default());
    app.update();
    assert_eq!(set(&app, ground), sorted(vec![a, c]));
    assert_eq!(set(&app, c), vec![ground]);
}

/// `CollidingEntities` is a collider's, as avian3d's: on a body with two child colliders, a
/// box resting on the ground (its bottom at y = 0) and a box 2 m above it, only the lower
/// child lists the ground, the upper child lists nothing, and the ground lists the lower
/// child, not the body. Also with the components inserted after the body has settled (filled
/// from the pairs touching then). Sleeping off, so the pairs stay awake.
#[test]
fn colliding_entities_of_child_colliders_name_colliders() {
    for insert_late in [false, true] {
        let mut app = app();
        app.insert_resource(SleepConfig {
            enabled: false,
            ..default()
        });
        let ground = app
            .world_mut()
            .spawn((RigidBody::Static, Collider::half_space(Vec3::Y)))
            .id();
        let body = app
            .world_mut()
            .spawn((RigidBody::Dynamic, Transform::from_xyz(0.0, 0.5, 0.0)))
            .id();
        let child = |app: &mut App, y: f32| {
            app.world_mut()
                .spawn((
                    Collider::cuboid(0.5, 0.5, 0.5),
                    Transform::from_xyz(0.0, y, 0.0),
                    ChildOf(body),
                ))
                .id()
        };
        let (lower, upper) = (child(&mut app, 0.0), child(&mut app, 2.0));
        let watched = [ground, lower, upper, body];
        if !insert_late {
            for e in watched {
                app.world_mut()
                    .entity_mut(e)
                    .insert(CollidingEntities::default());
            }
        }
        for _ in 0..60 {
            app.update();
        }
        if insert_late {
            for e in watched {
                app.world_mut()
                    .entity_mut(e)
                    .insert(CollidingEntities::default());
            }
            app.update();
        }
        let set = |app: &App, e: Entity| -> Vec<Entity> {
            app.world()
                .get::<CollidingEntities>(e)
                .unwrap()
                .iter()
                .copied()
                .collect()
        };
        assert_eq!(set(&app, lower), vec![ground], "late {insert_late}");
        assert_eq!(set(&app, upper), vec![], "late {insert_late}");
        assert_eq!(set(&app, ground), vec![lower], "late {insert_late}");
        // The body has no collider of its own: it touches nothing itself.
        assert_eq!(set(&app, body), vec![], "late {insert_late}");
    }
}

/// A box resting on the ground inside a static sensor falls asleep as it would without it (a
/// sensor's touch joins no island), and stays asleep, unmoved, when the sensor is despawned (a
/// sensor held nothing up: losing it wakes no one); its `CollidingEntities` loses the sensor.
#[test]
fn a_sensor_neither_keeps_awake_nor_wakes() {
    let mut app = app();
    let ground = app
        .world_mut()
        .spawn((RigidBody::Static, Collider::half_space(Vec3::Y)))
        .id();
    let sensor = app
        .world_mut()
        .spawn((
            RigidBody::Static,
            Collider::cuboid(1.0, 1.0, 1.0),
            Transform::from_xyz(0.0, 0.5, 0.0),
            Sensor,
        ))
        .id();
    let cube = app
        .world_mut()
        .spawn((
            RigidBody::Dynamic,
            Collider::cuboid(0.5, 0.5, 0.5),
            Transform::from_xyz(0.0, 0.5, 0.0),
            CollidingEntities::default(),
        ))
        .id();
    let touching = |app: &App| {
        let mut v: Vec<Entity> = app
            .world()
            .get::<CollidingEntities>(cube)
            .unwrap()
            .iter()
            .copied()
            .collect();
        v.sort();
        v
    };
    // Time to sleep is 0.5 s: asleep well within 1 s.
    for _ in 0..60 {
        app.update();
    }
    assert!(app.world().get::<Sleeping>(cube).is_some(), "asleep");
    let mut both = vec![ground, sensor];
    both.sort();
    assert_eq!(touching(&app), both);
    let rest = position(&app, cube);
    app.world_mut().despawn(sensor);
    for _ in 0..5 {
        app.update();
        assert!(app.world().get::<Sleeping>(cube).is_some(), "still asleep");
    }
    assert_eq!(position(&app, cube), rest);
    assert_eq!(touching(&app), vec![ground]);
}
