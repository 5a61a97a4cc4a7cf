//! A stage of the physics step can be replaced from outside the crate: the broad phase's plugin
//! is left out and an all-pairs broad phase, written here against the stage's public state,
//! takes its place in the same system set.

use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use impact3d::pipeline::{BroadPhasePlugin, CandidatePairs, PhysicsState};
use impact3d::prelude::*;
use impact3d::scenes::{self, Pour, PourBodies};
use parry3d::bounding_volume::BoundingVolume;

/// Every pair of bodies, at least one of them active, whose boxes overlap: the answer a broad
/// phase must give, found the slow way. Boxes overlap when they overlap on every axis, faces
/// touching included (parry's `Aabb::intersects`, as the built-in sweep and prune tests them).
fn all_pairs(state: Res<PhysicsState>, mut candidates: ResMut<CandidatePairs>) {
    let (aabbs, active) = (state.aabbs(), state.active());
    let mut overlapping = Vec::new();
    for i in 0..aabbs.len() {
        for j in i + 1..aabbs.len() {
            if (active[i] || active[j]) && aabbs[i].intersects(&aabbs[j]) {
                overlapping.push((i, j));
            }
        }
    }
    candidates.set(&state, overlapping);
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

/// A headless app at 60 Hz, sleeping off, with `plugins`, and 300 mixed bodies (spheres,
/// boxes, capsules, hulls) poured into a walled box with friction 0.5.
fn pour(plugins: impl PluginGroup) -> (App, Vec<Entity>) {
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, plugins))
        .insert_resource(Time::<Fixed>::from_hz(60.0))
        .insert_resource(TimeUpdateStrategy::FixedTimesteps(1))
        .insert_resource(SleepConfig {
            enabled: false,
            ..default()
        });
    app.update();
    let spawned = scenes::pour_into(
        app.world_mut(),
        &Pour::walled_box(300, PourBodies::Mixed, 1.0, 0.5),
    );
    (app, spawned.bodies)
}

/// The same pour with the built-in broad phase and with the all-pairs one: the same candidate
/// pairs every step, and bit-identical poses and velocities after 2 s (the landing and the
/// pile forming), since the solve sees the same pairs in the same order. Sleeping is off: the
/// built-in stage also wakes sleeping islands an awake body's box reaches, which this
/// replacement leaves out.
#[test]
fn all_pairs_broad_phase_replaces_the_built_in_one() {
    let (mut built_in, a) = pour(PhysicsPlugins::default());
    let (mut replaced, b) = pour(
        PhysicsPlugins::default()
            .build()
            .disable::<BroadPhasePlugin>()
            .add(AllPairsBroadPhase),
    );
    let mut most = 0;
    for step in 0..120 {
        built_in.update();
        replaced.update();
        let pairs = |app: &App| app.world().resource::<CandidatePairs>().pairs().to_vec();
        let (p, q) = (pairs(&built_in), pairs(&replaced));
        assert_eq!(p, q, "step {step}: the candidate pairs differ");
        most = most.max(p.len());
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
