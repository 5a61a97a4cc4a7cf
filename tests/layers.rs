//! Collision layers in whole-app scenes: a box falling onto a slab it is filtered from (one way
//! only, from either side) passes through in free fall and lands on the ground below; the same
//! box with the default layers lands on the slab.

mod common;

use bevy::prelude::*;
use common::{position, velocity};
use impact3d::pipeline::CandidatePairs;
use impact3d::prelude::*;
use impact3d::scenes::headless_app;

/// A game's layers, named by an enum (bit k for the k-th variant).
#[derive(Clone, Copy, Default)]
enum GameLayer {
    #[default]
    Default,
    Player,
    Ground,
}

impl PhysicsLayer for GameLayer {
    fn to_bits(&self) -> u32 {
        1 << *self as u32
    }
    fn all_bits() -> u32 {
        0b111
    }
}

const G: f32 = 9.81;
const DT: f32 = 1.0 / 60.0;
/// The box's start height (centre), m; its half extent is 0.5 m.
const Y0: f32 = 4.0;
/// The slab: a static box of half extents (2, 0.1, 2) centred at this height, m.
const SLAB_Y: f32 = 2.0;

struct Scene {
    app: App,
    cube: Entity,
    slab: Entity,
}

/// The ground (half-space y < 0), the slab, and a 1 m, 1 kg box above both, with the given
/// layers (`None`: no component).
fn scene(
    ground: Option<CollisionLayers>,
    slab: Option<CollisionLayers>,
    cube: Option<CollisionLayers>,
) -> Scene {
    let mut app = headless_app(60.0);
    let world = app.world_mut();
    let mut g = world.spawn((RigidBody::Static, Collider::half_space(Vec3::Y)));
    if let Some(l) = ground {
        g.insert(l);
    }
    let mut s = world.spawn((
        RigidBody::Static,
        Collider::cuboid(2.0, 0.1, 2.0),
        Transform::from_xyz(0.0, SLAB_Y, 0.0),
    ));
    if let Some(l) = slab {
        s.insert(l);
    }
    let slab = s.id();
    let mut c = world.spawn((
        RigidBody::Dynamic,
        Collider::cuboid(0.5, 0.5, 0.5),
        Mass(1.0),
        Transform::from_xyz(0.0, Y0, 0.0),
    ));
    if let Some(l) = cube {
        c.insert(l);
    }
    let cube = c.id();
    Scene { app, cube, slab }
}

/// Steps the scene for 3 s. For the first 45 steps (0.75 s: the box's bottom passes the slab's
/// top at 0.53 s and its top passes the slab's bottom at 0.73 s; the ground is still 0.74 m
/// below it) it asserts free fall and that the box and the slab are never a candidate pair.
/// Returns the box's height at the end.
fn falls_through(mut s: Scene) -> f32 {
    for step in 1..=45u32 {
        s.app.update();
        let t = step as f32 * DT;
        // Free fall gains g dt a step whatever the integrator: v = -g t. Tolerance 2e-4 m/s:
        // f32 rounding of 180 substep additions of about 7 m/s (half an ulp, 4.8e-7, each).
        let v = velocity(&s.app, s.cube).y;
        assert!(
            (v + G * t).abs() < 2e-4,
            "step {step}: v = {v}, free fall {}",
            -G * t
        );
        // The fall is g t^2 / 2 to within what a step's discretisation can add, g t dt / 2
        // (a semi-implicit Euler step of dt moves that much farther), plus f32 rounding.
        let fallen = Y0 - position(&s.app, s.cube).y;
        assert!(
            (fallen - 0.5 * G * t * t).abs() <= 0.5 * G * t * DT + 1e-4,
            "step {step}: fell {fallen}, free fall {}",
            0.5 * G * t * t
        );
        let key = (s.cube.min(s.slab), s.cube.max(s.slab));
        let pairs = s.app.world().resource::<CandidatePairs>().pairs();
        assert!(!pairs.contains(&key), "step {step}: box and slab paired");
    }
    for _ in 45..180 {
        s.app.update();
    }
    position(&s.app, s.cube).y
}

/// Rest height of the 1 m box on a surface at `top`: its half height above it, less the soft
/// contact's sink under its own weight, `g / (2 pi 30 Hz)^2` = 0.28 mm. Tolerance 1 mm: the
/// sink and the settling that remains after 2 s.
fn assert_rests_on(y: f32, top: f32) {
    assert!(
        (y - (top + 0.5)).abs() < 1e-3,
        "rests at {y}, expected {}",
        top + 0.5
    );
}

/// The slab's filters leave out the box's layer (the box's filters take every layer): the box
/// falls through the slab in free fall and rests on the ground.
#[test]
fn filtered_by_the_slab_passes_through_it() {
    let s = scene(
        None,
        Some(CollisionLayers::new(LayerMask::DEFAULT, LayerMask::DEFAULT)),
        Some(CollisionLayers::new(0b10, LayerMask::ALL)),
    );
    assert_rests_on(falls_through(s), 0.0);
}

/// The box's filters leave out the slab's layer (the slab's take every layer), with the layers
/// named by a `PhysicsLayer` enum: the box is a player that touches only the ground.
#[test]
fn filtered_by_the_box_passes_through_the_slab() {
    let s = scene(
        Some(CollisionLayers::new(GameLayer::Ground, LayerMask::ALL)),
        None,
        Some(CollisionLayers::new(GameLayer::Player, [GameLayer::Ground])),
    );
    assert_rests_on(falls_through(s), 0.0);
}

/// Control: layers that interact both ways (the box on two layers, the slab filtering one of
/// them), and no layers at all: the box lands on the slab, whose top is at 2.1 m.
#[test]
fn interacting_layers_land_on_the_slab() {
    for (slab, cube) in [
        (
            Some(CollisionLayers::new(LayerMask::DEFAULT, 0b10)),
            Some(CollisionLayers::new(
                [GameLayer::Default, GameLayer::Player],
                LayerMask::ALL,
            )),
        ),
        (None, None),
    ] {
        let mut s = scene(None, slab, cube);
        for _ in 0..180 {
            s.app.update();
        }
        assert_rests_on(position(&s.app, s.cube).y, SLAB_Y + 0.1);
    }
}

/// Layers inserted on a body resting on the slab take effect in the next step, though both
/// the box (asleep) and the slab sit still: the box then falls through.
#[test]
fn new_layers_take_effect_on_a_sleeping_body() {
    let mut s = scene(None, None, None);
    for _ in 0..180 {
        s.app.update();
    }
    assert!(
        s.app.world().get::<Sleeping>(s.cube).is_some(),
        "the box is asleep on the slab"
    );
    s.app
        .world_mut()
        .entity_mut(s.cube)
        .insert(CollisionLayers::new(0b10, 0b01));
    s.app
        .world_mut()
        .entity_mut(s.slab)
        .insert(CollisionLayers::new(0b100, 0b100));
    for _ in 0..120 {
        s.app.update();
    }
    assert_rests_on(position(&s.app, s.cube).y, 0.0);
}

/// A box filtered from a sleeping one falls through it without waking it: the broad phase
/// wakes a sleeping island only for a pair that would be solved. The falling box, dropped from
/// 2 m above the sleeper (on the slab), is on a layer nothing else accepts, so it falls freely
/// through the sleeper, the slab and the ground (its speed after 4 s is `g t` within 1e-3 m/s,
/// f32 rounding of 240 additions); the sleeper stays asleep every step, bit for bit where it
/// was. (Before the broad phase asked `PhysicsState::pair_kind`, the box's passage woke it.)
#[test]
fn a_filtered_body_passes_a_sleeper_without_waking_it() {
    let mut s = scene(None, None, None);
    for _ in 0..180 {
        s.app.update();
    }
    assert!(
        s.app.world().get::<Sleeping>(s.cube).is_some(),
        "the box is asleep on the slab"
    );
    let rest = position(&s.app, s.cube);
    // A second box straight above, on a layer nothing accepts (it filters in only `Ground`,
    // which no body is on).
    let ghost = s
        .app
        .world_mut()
        .spawn((
            RigidBody::Dynamic,
            Collider::cuboid(0.4, 0.4, 0.4),
            Transform::from_xyz(0.0, rest.y + 2.0, 0.0),
            CollisionLayers::new(GameLayer::Player, GameLayer::Ground),
        ))
        .id();
    s.app
        .world_mut()
        .entity_mut(s.slab)
        .insert(CollisionLayers::new(GameLayer::Default, GameLayer::Default));
    for _ in 0..240 {
        s.app.update();
        assert!(
            s.app.world().get::<Sleeping>(s.cube).is_some(),
            "the sleeper was woken"
        );
    }
    assert_eq!(position(&s.app, s.cube), rest);
    let fall = velocity(&s.app, ghost).y + G * 240.0 * DT;
    assert!(
        fall.abs() < 1e-3,
        "the ghost box fell freely: off by {fall} m/s"
    );
}
