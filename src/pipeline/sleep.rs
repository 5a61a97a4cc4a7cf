//! Sleep: resting islands fall asleep, woken islands lose their marker.

use bevy::prelude::*;

use crate::collision::ContactPairs;
use crate::dynamics::sleep::{
    SleepConfig, SleepTimer, Sleeping, SleepingDisabled, island_links, islands_to_sleep,
};
use crate::dynamics::solver::Motion;
use crate::dynamics::{AngularVelocity, LinearVelocity};
use crate::schedule::{PhysicsSchedule, PhysicsSystems};

use super::{CandidatePairs, PhysicsState, init_stage_state};

/// Adds [`update_sleep`] to [`PhysicsSystems::Sleep`].
pub struct SleepPlugin;

impl Plugin for SleepPlugin {
    fn build(&self, app: &mut App) {
        init_stage_state(app)
            .add_systems(PhysicsSchedule, update_sleep.in_set(PhysicsSystems::Sleep));
    }
}

/// What [`update_sleep`] reads and writes of each body.
type SleepData = (
    Option<&'static mut SleepTimer>,
    Option<&'static mut LinearVelocity>,
    Option<&'static mut AngularVelocity>,
    Has<SleepingDisabled>,
);

/// Puts resting islands to sleep and wakes the islands woken in this step (see
/// [`crate::dynamics::sleep`]): updates each awake dynamic body's [`SleepTimer`], groups
/// touching bodies into islands, and marks every body of an island whose bodies have all been
/// slow for the configured time, zeroing its velocities.
pub fn update_sleep(
    mut commands: Commands,
    state: Res<PhysicsState>,
    pairs: Res<ContactPairs>,
    candidates: Res<CandidatePairs>,
    mut bodies: Query<SleepData>,
    sleepers: Query<(Entity, &Sleeping)>,
) {
    let config = &state.settings.sleep;
    if !config.enabled {
        for (entity, _) in &sleepers {
            commands.entity(entity).remove::<Sleeping>();
        }
        return;
    }
    wake_woken_islands(&mut commands, &state, &sleepers);
    let timers = update_sleep_timers(&state, &mut bodies, config);
    let links = island_links(
        &state.bodies,
        pairs
            .candidates()
            .iter()
            .zip(candidates.indices())
            .zip(candidates.detect_only())
            // A sensor's touch holds nothing up: it does not join islands.
            .filter(|((pair, _), detect_only)| pair.touching && !**detect_only)
            .map(|((_, &pair), _)| pair),
    );
    for (i, island) in islands_to_sleep(&timers, &links, config.time_to_sleep)
        .into_iter()
        .enumerate()
    {
        let Some(root) = island else { continue };
        let entity = state.entities[i];
        if let Ok((_, linear, angular, _)) = bodies.get_mut(entity) {
            if let Some(mut v) = linear {
                v.0 = Vec3::ZERO;
            }
            if let Some(mut w) = angular {
                w.0 = Vec3::ZERO;
            }
        }
        commands.entity(entity).insert(Sleeping {
            island: state.entities[root as usize],
        });
    }
}

/// Wakes the islands woken in this step (by the prepare stage or the broad phase) and those of
/// the sleeping bodies that lost a contact: every body of such an island loses its
/// [`Sleeping`].
fn wake_woken_islands(
    commands: &mut Commands,
    state: &PhysicsState,
    sleepers: &Query<(Entity, &Sleeping)>,
) {
    let island_of = |entity: Entity, marker: &Sleeping| {
        if marker.island == Entity::PLACEHOLDER {
            entity
        } else {
            marker.island
        }
    };
    let mut woken = state.woken.clone();
    for &entity in &state.lost {
        if let Ok((entity, marker)) = sleepers.get(entity) {
            woken.push(island_of(entity, marker));
        }
    }
    if !woken.is_empty() {
        woken.sort_unstable();
        woken.dedup();
        let woken = |island: Entity| woken.binary_search(&island).is_ok();
        // Every body of a woken island: those of the sleeping set (in the step or not), and
        // the sleeping-marked ones read every step.
        for s in state.sleepers.records() {
            if woken(s.island) {
                commands.entity(s.entity).remove::<Sleeping>();
            }
        }
        for &entity in &state.read_every_step {
            if let Ok((entity, marker)) = sleepers.get(entity)
                && woken(island_of(entity, marker))
            {
                commands.entity(entity).remove::<Sleeping>();
            }
        }
    }
}

/// Updates each awake dynamic body's [`SleepTimer`] (its slow time, s) and returns it by body
/// (`None` for a body that is not dynamic, has no timer, or has `SleepingDisabled`).
fn update_sleep_timers(
    state: &PhysicsState,
    bodies: &mut Query<SleepData>,
    config: &SleepConfig,
) -> Vec<Option<f32>> {
    let mut timers: Vec<Option<f32>> = vec![None; state.bodies.len()];
    for (i, (body, slot)) in state.bodies.iter().zip(timers.iter_mut()).enumerate() {
        if body.motion != Motion::Dynamic {
            continue;
        }
        let Ok((Some(mut timer), _, _, awake)) = bodies.get_mut(state.entities[i]) else {
            continue;
        };
        if awake {
            // `SleepingDisabled`: no slow time, so neither it nor its island sleeps.
            timer.set_if_neq(SleepTimer(0.0));
            continue;
        }
        let speed =
            body.linear_velocity.length() + body.angular_velocity.length() * state.radius[i];
        timer.0 = if speed < config.linear_threshold {
            timer.0 + state.dt
        } else {
            0.0
        };
        *slot = Some(timer.0);
    }
    timers
}
