//! The broad phase: candidate pairs from bounding boxes swept along each body's motion in the
//! step, found through the persistent [`BroadPhaseTree`], and the wake of sleeping bodies an
//! awake body's box reaches.

use bevy::prelude::*;

use crate::collision::ContactPairs;
use crate::collision::broad_phase::{BroadPhaseTree, TREE_MARGIN};
use crate::dynamics::sleep::{islands_woken, wakes_sleepers};
use crate::dynamics::solver::Motion;
use crate::schedule::{PhysicsSchedule, PhysicsSystems};

use super::{
    CandidatePairs, PairKind, PhysicsState, bring_in_overlapped, init_stage_state,
    mark_awake_active, wake_islands,
};

/// Adds [`update_broad_phase`] to [`PhysicsSystems::BroadPhase`].
pub struct BroadPhasePlugin;

impl Plugin for BroadPhasePlugin {
    fn build(&self, app: &mut App) {
        init_stage_state(app).add_systems(
            PhysicsSchedule,
            update_broad_phase.in_set(PhysicsSystems::BroadPhase),
        );
    }
}

/// Brings the [`BroadPhaseTree`] up to date with the step's bodies (removing those that left)
/// and finds the candidate pairs through it: every pair of overlapping boxes with an active
/// body, kept where at least one body is dynamic or sleeping, and the pairs of two inactive
/// bodies carried over from the last step.
pub fn update_broad_phase(
    mut state: ResMut<PhysicsState>,
    mut tree: ResMut<BroadPhaseTree>,
    mut pairs: ResMut<ContactPairs>,
    mut candidates: ResMut<CandidatePairs>,
) {
    let state = &mut *state;
    let tree = &mut *tree;
    for &entity in &state.departed {
        tree.remove(entity);
    }
    let margin = TREE_MARGIN * state.settings.length_unit;
    wake_overlapped_islands(state, tree, margin);
    tree.optimize();
    revive_resting_pairs(state, &mut pairs);
    carry_inactive_pairs(state, &mut pairs);
    let state: &PhysicsState = state;
    candidates.set(
        state,
        state
            .index_pairs
            .iter()
            .map(|&(i, j)| (i as usize, j as usize)),
    );
}

/// An awake body (dynamic, or kinematic and moving) overlapping a sleeping one wakes its
/// island now, so that the contact is solved with the sleeper's real mass; repeat until no
/// more islands wake (a woken island may overlap another sleeping one).
fn wake_overlapped_islands(state: &mut PhysicsState, tree: &mut BroadPhaseTree, margin: f32) {
    loop {
        bring_in_overlapped(state);
        tree.sync(&state.entities, &state.aabbs, margin);
        tree.pairs_with_active(&state.aabbs, &state.active, &mut state.index_pairs);
        let islands = islands_woken(
            &state.index_pairs,
            |k| state.asleep[k],
            |k| wakes_sleepers(&state.bodies[k]),
            |i, j| state.pair_kind(i, j) == Some(PairKind::Solved),
        );
        if islands.is_empty() || !wake_islands(state, &islands) {
            break;
        }
        // The woken bodies are active now: search their pairs too.
        mark_awake_active(state);
    }
}

/// Resting pairs set aside while their sleeping bodies sat out come back among the
/// candidates when one of their bodies is in the step again, when the other body (static)
/// changed, or when it is gone. (`pairs` is the `ResMut`, so that it is marked changed only
/// when some come back.)
fn revive_resting_pairs(state: &PhysicsState, pairs: &mut ResMut<ContactPairs>) {
    if pairs.has_resting() {
        let mut back: Vec<Entity> = state.entered.clone();
        back.extend(state.departed.iter().copied());
        back.extend(
            state
                .entities
                .iter()
                .zip(&state.active)
                .zip(&state.bodies)
                .filter(|&((_, &active), body)| active && body.motion == Motion::Static)
                .map(|((&e, _), _)| e),
        );
        if !back.is_empty() {
            back.sort_unstable();
            pairs.revive(|p| back.binary_search(&p.a).is_ok() || back.binary_search(&p.b).is_ok());
        }
    }
}

/// Pairs of two inactive bodies cannot have changed since the last step (neither moved):
/// carry them over instead of searching every sleeping and static body each step. A pair of
/// which a body sits out the step asleep, the other sitting out too or inactive, is set
/// aside as it is. (`pairs` is the `ResMut`, so that it is marked changed only when some are
/// set aside.)
fn carry_inactive_pairs(state: &mut PhysicsState, pairs: &mut ResMut<ContactPairs>) {
    if !pairs.candidates().is_empty()
        && (state.active.iter().any(|a| !a) || !state.sleepers.is_empty())
    {
        state.index_of.clear();
        state.index_of.extend(
            state
                .entities
                .iter()
                .enumerate()
                .map(|(i, &e)| (e, i as u32)),
        );
        state.index_of.sort_unstable();
        let find = |e: Entity| {
            state
                .index_of
                .binary_search_by_key(&e, |&(e, _)| e)
                .ok()
                .map(|k| state.index_of[k].1)
        };
        let mut aside = Vec::new();
        for (k, p) in pairs.candidates().iter().enumerate() {
            match (find(p.a), find(p.b)) {
                (Some(i), Some(j)) => {
                    if !state.active[i as usize] && !state.active[j as usize] {
                        state.index_pairs.push((i.min(j), i.max(j)));
                    }
                }
                (i, j) => {
                    let resting = |e: Entity, i: Option<u32>| match i {
                        Some(i) => !state.active[i as usize],
                        None => state.sleepers.get(e).is_some(),
                    };
                    if resting(p.a, i) && resting(p.b, j) {
                        aside.resize(pairs.candidates().len(), false);
                        aside[k] = true;
                    }
                }
            }
        }
        if !aside.is_empty() {
            aside.resize(pairs.candidates().len(), false);
            pairs.set_aside(&aside);
        }
    }
}
