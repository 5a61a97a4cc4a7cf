//! The prepare stage: validates the settings and every body (quarantining bad input, logging
//! an error that names the entity), keeps mass properties up to date, and packs the solver
//! bodies; sleeping bodies sit the step out until something may touch them.
//!
//! One concern a file, in the order a step meets them:
//! - this file: the plugin, the system [`prepare_bodies`] that runs the stage, and the start of
//!   a step's arrays;
//! - `query`: what the stage reads (the body components, the settings, the removals);
//! - `hierarchy`: colliders on child entities, parented bodies and their world poses;
//! - `scale`: the shape built for a body with child colliders or a scale;
//! - `bodies`: gathering one body into the step's arrays, step by step;
//! - `validation`: the checks of a body's input and its mass properties;
//! - `motion`: forces, accelerations, damping and speed caps, and what wakes a sleeper;
//! - `sleepers`: which sleeping bodies are read, what becomes of them, and how a sleeping body
//!   enters the step.

mod bodies;
mod hierarchy;
mod motion;
mod parts;
mod query;
mod scale;
mod sleepers;
mod validation;

use bevy::ecs::system::SystemChangeTick;
use bevy::prelude::*;

use crate::schedule::{PhysicsSchedule, PhysicsSystems};

use super::{PhysicsState, init_stage_state, mark_awake_active, validate_settings, wake_islands};
use bodies::{Gathered, gather_body};
use sleepers::{gather_sleeper, sleepers_to_read};

pub use hierarchy::HierarchyData;
pub(super) use hierarchy::{HierarchyState, resolve_hierarchy};
use query::{AwakeBodies, SleepingBodies};
pub use query::{
    BodyData, BodyDataItem, BodyDataReadOnly, BodyDataReadOnlyItem, BodyRemovals, MotionData,
    MotionDataItem, MotionDataReadOnly, MotionDataReadOnlyItem, MotionRemovals, StepSettings,
};

/// Adds [`prepare_bodies`] to [`PhysicsSystems::Prepare`].
pub struct PreparePlugin;

impl Plugin for PreparePlugin {
    fn build(&self, app: &mut App) {
        init_stage_state(app).add_systems(
            PhysicsSchedule,
            prepare_bodies.in_set(PhysicsSystems::Prepare),
        );
    }
}
/// Validates every body, quarantines bad ones (logging an error that names the entity), keeps
/// mass properties up to date and packs the solver bodies. A collider without a `RigidBody` is
/// static, unless it is on a descendant of a body: then it is a part of that body (see
/// [`ColliderOf`](crate::collision::collider::ColliderOf) and `resolve_hierarchy`).
///
/// A sleeping body is read only when something may have touched it (a component it depends
/// on changed or was removed, or it was just put to sleep); the others keep their record in
/// the [`SleepingSet`](crate::dynamics::sleep::SleepingSet) and sit out the step, unless the
/// broad phase finds an awake body's box over theirs or their island wakes.
#[allow(clippy::too_many_arguments)]
pub fn prepare_bodies(
    mut commands: Commands,
    ticks: SystemChangeTick,
    settings: StepSettings,
    mut state: ResMut<PhysicsState>,
    mut awake: Query<BodyData, AwakeBodies>,
    mut sleeping: SleepingBodies,
    mut removals: BodyRemovals,
    hierarchy: HierarchyData,
) {
    let state = &mut *state;
    validate_settings(
        state,
        &settings.config,
        &settings.narrow,
        &settings.gravity,
        &settings.sleep,
        &settings.unit,
        &settings.clock,
        settings.time.delta_secs(),
    );
    let sleep_enabled = state.settings.sleep.enabled;
    begin_step(state);
    resolve_hierarchy(state, &mut commands, &hierarchy);
    // Bodies that lost their layers or sensor marker may now pair with bodies they were kept
    // from: they are active in this step.
    state.layers_removed.clear();
    state.layers_removed.extend(removals.layers.read());
    state.layers_removed.extend(removals.sensor.read());
    // A child collider's layers or sensor marker are its body's pairs'.
    let children: Vec<Entity> = state
        .layers_removed
        .iter()
        .filter_map(|&e| state.hierarchy.body_of(e))
        .collect();
    state.layers_removed.extend(children);
    state.layers_removed.sort_unstable();
    state.layers_removed.dedup();
    // `for_each` takes Bevy's table-by-table path, which builds each (large) item in place;
    // a `for` loop's `next` built and moved it, which cost more than most of the gathering.
    awake.iter_mut().for_each(|mut item| {
        if let Gathered::Quarantined = gather_body(state, &mut commands, &ticks, &mut item) {
            state.departed.push(item.entity);
        }
    });
    state.hierarchy.prune();
    // A disabled body leaves the step as a despawned one does: its pairs end.
    state.departed.extend(removals.disabled.iter());
    let read = sleepers_to_read(state, &mut sleeping, &mut removals);
    let mut query = sleeping.p1();
    for entity in read {
        let Ok(mut item) = query.get_mut(entity) else {
            continue;
        };
        gather_sleeper(state, &mut commands, &ticks, &mut item);
    }
    end_gathering(state);
    if !sleep_enabled {
        state.read_every_step.clear();
        return;
    }
    // Islands the user touched wake whole.
    let woken = std::mem::take(&mut state.woken);
    wake_islands(state, &woken);
    mark_awake_active(state);
}

/// Starts a step's arrays: empty, the step counted.
fn begin_step(state: &mut PhysicsState) {
    state.dt = state.settings.dt;
    state.step = state.step.wrapping_add(1);
    state.entities.clear();
    state.bodies.clear();
    // `local_com`, `shapes` and `radius` keep the last step's entries while the bodies are
    // gathered, which keep each one that is unchanged (see `bodies::put_shape`); then they are
    // cut to the step's bodies (see `end_gathering`).
    state.poses.clear();
    state.restitution.clear();
    state.friction.clear();
    state.combine.clear();
    state.layers.clear();
    state.reporting.clear();
    state.parts.clear();
    state.reach.clear();
    state.spin_reach.clear();
    state.aabbs.clear();
    state.active.clear();
    state.collides.clear();
    state.motion.clear();
    state.asleep.clear();
    state.asleep_twins.clear();
    state.woken.clear();
    state.entered.clear();
    state.departed.clear();
}

/// Ends the gathering: the arrays kept from the last step (see `begin_step`) are cut to the
/// bodies of this step, before anything else is appended to them.
fn end_gathering(state: &mut PhysicsState) {
    let n = state.entities.len();
    state.local_com.truncate(n);
    state.shapes.truncate(n);
    state.radius.truncate(n);
}
