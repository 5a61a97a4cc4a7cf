//! The sleeping bodies of a step: which are read again (something may have touched them), what
//! becomes of each one read, and how a sleeping body enters the step.

use bevy::ecs::change_detection::Tick;
use bevy::ecs::system::SystemChangeTick;
use bevy::prelude::*;

use crate::dynamics::RigidBody;
use crate::dynamics::sleep::Sleeper;
use crate::dynamics::solver::{Motion, SolverBody};

use super::super::PhysicsState;
use super::bodies::{Gathered, gather_body};
use super::query::{BodyDataItem, BodyRemovals, SleepingBodies};

/// The sleeping bodies to read in this step, sorted: the disturbed ones, those that lost a
/// component, and those that must be read every step (quarantined, or not dynamic); all of
/// them when sleeping is off. Those that lost their collider (or were despawned) depart, and
/// leave the sleeping set with those read again.
pub(super) fn sleepers_to_read(
    state: &mut PhysicsState,
    sleeping: &mut SleepingBodies,
    removals: &mut BodyRemovals,
) -> Vec<Entity> {
    let sleep_enabled = state.settings.sleep.enabled;
    let mut read: Vec<Entity> = std::mem::take(&mut state.read_every_step);
    state.departed.extend(removals.collider.read());
    for entity in removals.sleeping.read() {
        state.sleepers.remove(entity);
    }
    let removed = [
        removals.body.read().collect::<Vec<_>>(),
        removals.transform.read().collect(),
        removals.linear.read().collect(),
        removals.angular.read().collect(),
        removals.restitution.read().collect(),
        removals.friction.read().collect(),
        removals.restitution_combine.read().collect(),
        removals.friction_combine.read().collect(),
        removals.mass.read().collect(),
        removals.density.read().collect(),
        removals.computed.read().collect(),
        removals.locked.read().collect(),
        state.layers_removed.clone(),
    ];
    state.hierarchy.forget(&removed[0]);
    for entity in removed.into_iter().flatten() {
        if state.sleepers.get(entity).is_some() {
            state.sleepers.remove(entity);
            read.push(entity);
        }
    }
    // A sleeping body no longer disabled is not in the set: it is read again like those that
    // lost a component of `MotionData` (an awake one is read anyway, and the sleeping query
    // skips it).
    for entity in removals.motion.read() {
        if state.sleepers.get(entity).is_some() {
            state.sleepers.remove(entity);
        }
        read.push(entity);
    }
    // Bodies whose ancestors moved or whose child colliders changed are read (and woken).
    for &entity in &state.hierarchy.disturbed {
        if state.sleepers.get(entity).is_some() {
            state.sleepers.remove(entity);
        }
        read.push(entity);
    }
    // The shapes built for bodies that left are dropped (rebuilt if they come back).
    state.hierarchy.forget(&state.departed);
    let departed = state.departed.clone();
    for &entity in &departed {
        state.sleepers.remove(entity);
    }
    if sleep_enabled {
        read.extend(sleeping.p0().iter());
    } else {
        state.sleepers.clear();
        read.extend(sleeping.p1().iter().map(|item| item.entity));
    }
    read.sort_unstable();
    read.dedup();
    state
        .sleepers
        .set_margin(state.settings.narrow.contact_margin);
    read
}

/// Reads one sleeping body: still asleep, it joins the step and the sleeping set keeps its
/// record; quarantined, it departs; awake (or not dynamic), it is read every step.
pub(super) fn gather_sleeper(
    state: &mut PhysicsState,
    commands: &mut Commands,
    ticks: &SystemChangeTick,
    item: &mut BodyDataItem,
) {
    let entity = item.entity;
    match gather_body(state, commands, ticks, item) {
        Gathered::Asleep => {
            let i = state.entities.len() - 1;
            let island = state.asleep[i].expect("gathered asleep");
            let body = state.asleep_twins.last().expect("gathered asleep").1;
            state.sleepers.insert(
                Sleeper {
                    entity,
                    island,
                    body,
                    local_com: state.local_com[i],
                    shape: state.shapes[i].clone(),
                    pose: state.poses[i],
                    restitution: state.restitution[i],
                    friction: state.friction[i],
                    combine: state.combine[i],
                    layers: state.layers[i],
                    reporting: state.reporting[i],
                    parts: state.parts[i].clone(),
                    radius: state.radius[i],
                    motion: state
                        .motion
                        .last()
                        .filter(|&&(k, _, _)| k == i)
                        .map(|&(_, m, _)| m),
                    collides: state.collides[i],
                },
                state.step,
            );
            state.entered.push(entity);
        }
        Gathered::Quarantined => {
            state.sleepers.remove(entity);
            state.departed.push(entity);
            state.read_every_step.push(entity);
        }
        Gathered::Awake => {
            state.sleepers.remove(entity);
            state.read_every_step.push(entity);
        }
        Gathered::Skipped => {
            state.sleepers.remove(entity);
        }
    }
}

/// How body `i` of the step (its solver body just pushed) enters it: a sleeping dynamic body
/// enters as static, its dynamic solver body kept with the island it sleeps with, to be swapped
/// back if woken (sleeping on); any other as it is. Pushes its entry of the step's `asleep`
/// array and says whether it entered asleep. The island is queued to wake when the body was
/// touched since it fell asleep (its pose or velocity set, or `nudged`: pushed, or its ancestors
/// or child colliders changed) before tick `now`.
pub(super) fn enter_asleep(
    state: &mut PhysicsState,
    i: usize,
    item: &BodyDataItem,
    kind: RigidBody,
    now: Tick,
    nudged: bool,
) -> bool {
    let marker = match item.sleeping.as_ref() {
        Some(marker) if kind == RigidBody::Dynamic && state.settings.sleep.enabled => marker,
        _ => {
            state.asleep.push(None);
            return false;
        }
    };
    let since = marker.added();
    let touched = item.transform.last_changed().is_newer_than(since, now)
        || item
            .linear_velocity
            .as_ref()
            .is_some_and(|v| v.last_changed().is_newer_than(since, now))
        || item
            .angular_velocity
            .as_ref()
            .is_some_and(|w| w.last_changed().is_newer_than(since, now))
        || nudged;
    let island = if marker.island == Entity::PLACEHOLDER {
        item.entity
    } else {
        marker.island
    };
    if touched {
        state.woken.push(island);
    }
    let body = state.bodies[i];
    state.bodies[i] = SolverBody::new(Motion::Static, body.position, body.rotation);
    state.asleep.push(Some(island));
    state.asleep_twins.push((i, body));
    true
}
