//! A stage of the physics step can be replaced from outside the crate: the broad phase's plugin
//! is left out and an all-pairs broad phase, written here against the stage's public state,
//! takes its place in the same system set. The all-pairs answer also checks the built-in
//! broad phase's tree as bodies leave (despawned, collider removed) and arrive, awake and
//! asleep.

mod common;

use bevy::prelude::*;
use common::mixed_pour;
use impact3d::collision::BroadPhaseTree;
use impact3d::pipeline::{BroadPhasePlugin, CandidatePairs, PhysicsState, update_broad_phase};
use impact3d::prelude::*;
use impact3d::scenes;
use parry3d::bounding_volume::BoundingVolume;

/// Every pair of bodies, at least one of them active, whose boxes overlap: the answer a broad
/// phase must give, found the slow way. Boxes overlap when they overlap on every axis, faces
/// touching included (parry's `Aabb::intersects`, as the built-in broad phase tests them).
fn all_pairs(state: Res<PhysicsState>, mut candidates: ResMut<CandidatePairs>) {
    candidates.set(&state, overlapping_with_active(&state));
}

/// The body index pairs of `state` whose boxes overlap, at least one body active.
fn overlapping_with_active(state: &PhysicsState) -> Vec<(usize, usize)> {
    let (aabbs, active) = (state.aabbs(), state.active());
    let mut overlapping = Vec::new();
    for i in 0..aabbs.len() {
        for j in i + 1..aabbs.len() {
            if (active[i] || active[j]) && aabbs[i].intersects(&aabbs[j]) {
                overlapping.push((i, j));
            }
        }
    }
    overlapping
}

/// The all-pairs broad phase as a plugin.
struct AllPairsBroadPhase;

impl Plugin for AllPairsBroadPhase {
    fn build(&self, app: &mut App) {
        app.init_resource::<CandidatePairs>().add_systems(
            PhysicsSchedule,
            all_pairs.in_set(PhysicsSystems::BroadPhase),
        );
    }
}

/// The mixed pour twice: with the built-in broad phase, and with the all-pairs one in its
/// place. Each app with its bodies.
fn pours_with_each_broad_phase() -> ((App, Vec<Entity>), (App, Vec<Entity>)) {
    let built_in = mixed_pour((MinimalPlugins, PhysicsPlugins::default()));
    let replaced = mixed_pour((
        MinimalPlugins,
        PhysicsPlugins::default()
            .build()
            .disable::<BroadPhasePlugin>()
            .add(AllPairsBroadPhase),
    ));
    (built_in, replaced)
}

/// Steps both apps once and asserts that their broad phases found the same candidate pairs;
/// returns how many.
fn step_both(built_in: &mut App, replaced: &mut App, step: u32) -> usize {
    built_in.update();
    replaced.update();
    let pairs = |app: &App| app.world().resource::<CandidatePairs>().pairs().to_vec();
    let (p, q) = (pairs(built_in), pairs(replaced));
    assert_eq!(p, q, "step {step}: the candidate pairs differ");
    p.len()
}

/// The same pour with the built-in broad phase and with the all-pairs one: the same candidate
/// pairs every step, and bit-identical poses and velocities after 2 s (the landing and the
/// pile forming), since the solve sees the same pairs in the same order. Sleeping is off: the
/// built-in stage also wakes sleeping islands an awake body's box reaches, which this
/// replacement leaves out.
#[test]
fn all_pairs_broad_phase_replaces_the_built_in_one() {
    let ((mut built_in, a), (mut replaced, b)) = pours_with_each_broad_phase();
    let mut most = 0;
    for step in 0..120 {
        most = most.max(step_both(&mut built_in, &mut replaced, step));
    }
    // The pour must have made pairs for the comparison to mean something: 300 bodies in a
    // pile are each near several others.
    assert!(most > 300, "only {most} candidate pairs");
    for (&ea, &eb) in a.iter().zip(&b) {
        let state = |app: &App, e: Entity| {
            let w = app.world();
            (
                *w.get::<Transform>(e).unwrap(),
                w.get::<LinearVelocity>(e).unwrap().0,
                w.get::<AngularVelocity>(e).unwrap().0,
            )
        };
        assert_eq!(state(&built_in, ea), state(&replaced, eb));
    }
}

/// The mixed pour with each broad phase, through bodies leaving and arriving mid-run (sleeping
/// off, as above): at step 40, 20 bodies are despawned; at step 60, 20 others lose their
/// collider; at step 80, 30 balls are dropped in; at step 100, the 20 get their collider back.
/// The built-in broad phase's tree removes and inserts them, and its candidate pairs stay the
/// all-pairs ones every step, so poses and velocities stay bit-identical.
#[test]
fn all_pairs_broad_phase_matches_as_bodies_leave_and_arrive() {
    let ((mut built_in, a), (mut replaced, b)) = pours_with_each_broad_phase();
    let shape = |k: usize| match k % 3 {
        0 => Collider::sphere(0.5),
        1 => Collider::cuboid(0.5, 0.5, 0.5),
        _ => Collider::capsule(0.3, 0.3),
    };
    let mut most = 0;
    for step in 0..140 {
        for (app, bodies) in [(&mut built_in, &a), (&mut replaced, &b)] {
            let world = app.world_mut();
            match step {
                40 => {
                    for &e in bodies.iter().step_by(15) {
                        world.despawn(e);
                    }
                }
                60 => {
                    for &e in bodies.iter().skip(7).step_by(15) {
                        world.entity_mut(e).remove::<Collider>();
                    }
                }
                80 => {
                    for k in 0..30 {
                        let at = Vec3::new(k as f32 % 6.0 * 1.5 - 4.0, 8.0, (k / 6) as f32 - 2.0);
                        world.spawn(scenes::ball(0.4, 1.0, at, Vec3::ZERO));
                    }
                }
                100 => {
                    for (k, &e) in bodies.iter().enumerate().skip(7).step_by(15) {
                        world.entity_mut(e).insert(shape(k));
                    }
                }
                _ => {}
            }
        }
        most = most.max(step_both(&mut built_in, &mut replaced, step));
    }
    assert!(most > 300, "only {most} candidate pairs");
    let bodies = |app: &mut App| {
        let mut q = app.world_mut().query_filtered::<Entity, With<Collider>>();
        let mut all: Vec<Entity> = q.iter(app.world()).collect();
        all.sort();
        all
    };
    let (ea, eb) = (bodies(&mut built_in), bodies(&mut replaced));
    // 300 bodies and the box (a floor and 4 walls), less 20 despawned, plus 30 balls.
    assert_eq!(ea.len(), 300 + 5 - 20 + 30);
    assert_eq!(ea, eb);
    for e in ea {
        let state = |app: &App| {
            let w = app.world();
            (
                *w.get::<Transform>(e).unwrap(),
                w.get::<LinearVelocity>(e).map(|v| v.0),
                w.get::<AngularVelocity>(e).map(|w| w.0),
            )
        };
        assert_eq!(state(&built_in), state(&replaced));
    }
}

/// What [`check_against_all_pairs`] saw.
#[derive(Resource, Default)]
struct Checked {
    steps: u32,
    pairs_with_active: usize,
    most_sleepers_out: usize,
}

/// After the built-in broad phase: its candidate pairs with an active body are exactly the
/// all-pairs ones of the step's bodies (the pairs of two inactive bodies are carried over from
/// the last step, which the first test covers), and its tree holds exactly the bodies with a
/// collider, with the step's boxes: the sleeping bodies that sat the step out among them.
fn check_against_all_pairs(
    state: Res<PhysicsState>,
    candidates: Res<CandidatePairs>,
    tree: Res<BroadPhaseTree>,
    colliders: Query<Entity, With<Collider>>,
    mut checked: ResMut<Checked>,
) {
    let active = state.active();
    let with_active: Vec<(Entity, Entity)> = candidates
        .pairs()
        .iter()
        .zip(candidates.indices())
        .filter(|&(_, &(i, j))| active[i] || active[j])
        .map(|(&p, _)| p)
        .collect();
    let mut expected = CandidatePairs::default();
    expected.set(&state, overlapping_with_active(&state));
    assert_eq!(with_active, expected.pairs(), "step {}", checked.steps);
    let unbounded: Vec<Entity> = tree.unbounded().map(|(e, _)| e).collect();
    for (&e, aabb) in state.entities().iter().zip(state.aabbs()) {
        assert_eq!(tree.aabb(e), Some(*aabb));
    }
    for e in &colliders {
        assert!(tree.leaf(e).is_some() || unbounded.contains(&e));
    }
    assert_eq!(
        tree.bvh().leaf_count() as usize + unbounded.len(),
        colliders.iter().count()
    );
    checked.steps += 1;
    checked.pairs_with_active += with_active.len();
    checked.most_sleepers_out = checked
        .most_sleepers_out
        .max(colliders.iter().count() - state.entities().len());
}

/// 64 cubes resting on the ground in an 8 x 8 grid (1.05 m apart) and 16 stacked on them fall
/// asleep and sit steps out in the built-in broad phase's tree; then sleepers are despawned
/// (step 60), one loses its collider (step 70), 8 balls dropped on the grid's third row wake
/// the cubes they land on (step 80), and a cube is spawned beside a sleeper (step 120). Every step the
/// built-in pairs with an active body are the all-pairs ones and the tree holds exactly the
/// bodies with a collider.
#[test]
fn built_in_broad_phase_is_all_pairs_with_sleepers_coming_and_going() {
    let mut app = scenes::headless_app(60.0);
    app.init_resource::<Checked>().add_systems(
        PhysicsSchedule,
        check_against_all_pairs
            .in_set(PhysicsSystems::BroadPhase)
            .after(update_broad_phase),
    );
    let world = app.world_mut();
    scenes::ground(world);
    let mut grid = Vec::new();
    for k in 0..80 {
        let (x, z) = ((k % 8) as f32 * 1.05, (k / 8 % 8) as f32 * 1.05);
        let y = if k < 64 { 0.5 } else { 1.5 };
        grid.push(
            world
                .spawn(scenes::cuboid(Vec3::splat(0.5), 1.0, Vec3::new(x, y, z)))
                .id(),
        );
    }
    let asleep = |app: &mut App| {
        let mut q = app
            .world_mut()
            .query_filtered::<(), (With<Sleeping>, With<Collider>)>();
        q.iter(app.world()).count()
    };
    scenes::run_steps(&mut app, 60);
    let settled = asleep(&mut app);
    assert_eq!(settled, 80, "every cube asleep after 1 s");
    let world = app.world_mut();
    for &e in grid.iter().take(64).step_by(9) {
        world.despawn(e);
    }
    scenes::run_steps(&mut app, 10);
    app.world_mut().entity_mut(grid[20]).remove::<Collider>();
    scenes::run_steps(&mut app, 10);
    for k in 0..8 {
        let at = Vec3::new(k as f32 * 1.05, 1.8, 2.1);
        app.world_mut()
            .spawn(scenes::ball(0.3, 1.0, at, Vec3::new(0.0, -3.0, 0.0)));
    }
    scenes::run_steps(&mut app, 20);
    // Of the 71 cubes left, the 7 of the third row (one was despawned) the balls land on woke.
    let woken = asleep(&mut app);
    assert!(woken <= 71 - 7, "the balls woke islands: {woken} asleep");
    scenes::run_steps(&mut app, 20);
    app.world_mut().spawn(scenes::cuboid(
        Vec3::splat(0.5),
        1.0,
        Vec3::new(7.0 * 1.05, 0.5, 8.0 * 1.05 - 0.02),
    ));
    scenes::run_steps(&mut app, 60);
    let checked = app.world().resource::<Checked>();
    assert_eq!(checked.steps, 180);
    assert!(
        checked.pairs_with_active > 1000,
        "{}",
        checked.pairs_with_active
    );
    assert!(
        checked.most_sleepers_out >= 70,
        "{}",
        checked.most_sleepers_out
    );
}
