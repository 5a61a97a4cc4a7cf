//! The sleeping set's wake fixpoint, shared by the prepare stage and the broad phase: bringing
//! sleeping bodies into the step's arrays and waking their islands.

use bevy::prelude::*;

use super::PhysicsState;
use crate::dynamics::solver::{Motion, SolverBody};

/// Marks every body that is not static in the solve (a woken sleeper) as active.
pub(super) fn mark_awake_active(state: &mut PhysicsState) {
    for (active, body) in state.active.iter_mut().zip(&state.bodies) {
        *active |= body.motion != Motion::Static;
    }
}

/// Swaps the bodies of the given islands back in as dynamic bodies (bringing in those that sat
/// out the step) and records the islands as woken (their `Sleeping` markers are removed at the
/// end of the step). Returns whether any body woke.
pub(super) fn wake_islands(state: &mut PhysicsState, islands: &[Entity]) -> bool {
    if islands.is_empty() {
        return false;
    }
    let mut sorted = islands.to_vec();
    sorted.sort_unstable();
    let members: Vec<u32> = (0..state.sleepers.len() as u32)
        .filter(|&i| {
            !state.sleepers.in_step(i, state.step)
                && sorted
                    .binary_search(&state.sleepers.record(i).island)
                    .is_ok()
        })
        .collect();
    for i in members {
        bring_in(state, i);
    }
    let mut any = false;
    for &(i, body) in &state.asleep_twins {
        if let Some(island) = state.asleep[i]
            && islands.contains(&island)
        {
            state.bodies[i] = body;
            state.asleep[i] = None;
            any = true;
            if !state.woken.contains(&island) {
                state.woken.push(island);
            }
        }
    }
    any
}

/// Puts sleeping body `i` of the [`SleepingSet`](crate::dynamics::sleep::SleepingSet) into the
/// step's arrays, as it was gathered: a static body that becomes its dynamic self if its island
/// wakes.
fn bring_in(state: &mut PhysicsState, i: u32) {
    state.sleepers.mark_in_step(i, state.step);
    let s = state.sleepers.record(i);
    state.entities.push(s.entity);
    state.bodies.push(SolverBody::new(
        Motion::Static,
        s.body.position,
        s.body.rotation,
    ));
    state.local_com.push(s.local_com);
    state.shapes.push(s.shape.clone());
    state.poses.push(s.pose);
    state.restitution.push(s.restitution);
    state.friction.push(s.friction);
    state.combine.push(s.combine);
    state.layers.push(s.layers);
    state.reporting.push(s.reporting);
    state.parts.push(s.parts.clone());
    state.reach.push(0.0);
    state.spin_reach.push(0.0);
    state.aabbs.push(state.sleepers.aabb(i));
    state.active.push(false);
    state.radius.push(s.radius);
    state.collides.push(s.collides);
    if let Some(motion) = s.motion {
        let index = state.bodies.len() - 1;
        state.motion.push((index, motion, s.body.position));
    }
    state.asleep.push(Some(s.island));
    state.asleep_twins.push((state.bodies.len() - 1, s.body));
    state.entered.push(s.entity);
}

/// Brings in every sleeping body whose box an active body's box overlaps, so that the pair
/// search finds their pairs as if every sleeping body were in the arrays.
pub(super) fn bring_in_overlapped(state: &mut PhysicsState) {
    if state.sleepers.is_empty() {
        return;
    }
    let mut found = Vec::new();
    for i in 0..state.bodies.len() {
        if state.active[i] {
            state.sleepers.overlapping(&state.aabbs[i], &mut found);
        }
    }
    for k in found {
        if !state.sleepers.in_step(k, state.step) {
            bring_in(state, k);
        }
    }
}
