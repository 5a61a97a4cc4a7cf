//! Messages: the step's `Impact`, `CollisionStarted` and `CollisionEnded`; `CollisionStart` and
//! `CollisionEnd` (as messages and as entity events) for the bodies that ask for them; and each
//! `CollidingEntities` brought up to date.

use bevy::ecs::system::SystemParam;
use bevy::prelude::*;

use crate::collision::{CollidingEntities, CollisionEventsEnabled, ContactPairs};
use crate::messages::{CollisionEnd, CollisionEnded, CollisionStart, CollisionStarted, Impact};
use crate::schedule::{PhysicsSchedule, PhysicsSystems};

use super::{StepEvents, init_stage_state};

/// Adds [`send_messages`] to [`PhysicsSystems::Messages`].
pub struct MessagesPlugin;

impl Plugin for MessagesPlugin {
    fn build(&self, app: &mut App) {
        init_stage_state(app).add_systems(
            PhysicsSchedule,
            send_messages.in_set(PhysicsSystems::Messages),
        );
    }
}

/// The writers of the step's messages.
#[derive(SystemParam)]
pub struct StepWriters<'w> {
    impacts: MessageWriter<'w, Impact>,
    started: MessageWriter<'w, CollisionStarted>,
    ended: MessageWriter<'w, CollisionEnded>,
    start: MessageWriter<'w, CollisionStart>,
    end: MessageWriter<'w, CollisionEnd>,
}

/// The bodies that asked for reports: those with [`CollisionEventsEnabled`], and those with
/// [`CollidingEntities`].
#[derive(SystemParam)]
pub struct Reporters<'w, 's> {
    events: Query<'w, 's, (), With<CollisionEventsEnabled>>,
    colliding: Query<'w, 's, (Entity, &'static mut CollidingEntities)>,
}

/// Writes the step's `Impact`, `CollisionStarted` and `CollisionEnded` messages (every pair);
/// `CollisionStart` and `CollisionEnd` messages for the pairs of which a body has
/// [`CollisionEventsEnabled`], triggered as entity events on each such body (with it as
/// `collider1`, the pair's bodies in entity order); and updates [`CollidingEntities`] (a newly
/// inserted one is filled from the pairs touching now).
pub fn send_messages(
    mut commands: Commands,
    events: Res<StepEvents>,
    pairs: Res<ContactPairs>,
    mut writers: StepWriters,
    mut reporters: Reporters,
) {
    writers.impacts.write_batch(events.impacts.iter().copied());
    writers
        .started
        .write_batch(events.started.iter().map(|&(a, b)| CollisionStarted(a, b)));
    writers
        .ended
        .write_batch(events.ended.iter().map(|&(a, b)| CollisionEnded(a, b)));
    if !reporters.events.is_empty() {
        let enabled = |e: Entity| reporters.events.contains(e);
        for &(a, b) in &events.started {
            let (on_a, on_b) = (enabled(a), enabled(b));
            if !(on_a || on_b) {
                continue;
            }
            let start = |c1: Entity, c2: Entity| CollisionStart {
                collider1: c1,
                collider2: c2,
                body1: Some(c1),
                body2: Some(c2),
            };
            writers.start.write(start(a, b));
            if on_a {
                commands.trigger(start(a, b));
            }
            if on_b {
                commands.trigger(start(b, a));
            }
        }
        for &(a, b) in &events.ended {
            let (on_a, on_b) = (enabled(a), enabled(b));
            if !(on_a || on_b) {
                continue;
            }
            let end = |c1: Entity, c2: Entity| CollisionEnd {
                collider1: c1,
                collider2: c2,
                body1: Some(c1),
                body2: Some(c2),
            };
            writers.end.write(end(a, b));
            if on_a {
                commands.trigger(end(a, b));
            }
            if on_b {
                commands.trigger(end(b, a));
            }
        }
    }
    update_colliding_entities(&events, &pairs, &mut reporters);
}

/// Brings every [`CollidingEntities`] up to date with the step's touching transitions; a newly
/// inserted one is filled from every pair touching now (the resting pairs of sleeping bodies
/// included).
fn update_colliding_entities(events: &StepEvents, pairs: &ContactPairs, reporters: &mut Reporters) {
    if reporters.colliding.is_empty() {
        return;
    }
    let mut inserted = Vec::new();
    for (e, mut set) in reporters.colliding.iter_mut() {
        if set.is_added() {
            set.clear();
            inserted.push(e);
        }
    }
    inserted.sort_unstable();
    let fresh = |e: Entity| inserted.binary_search(&e).is_ok();
    if !inserted.is_empty() {
        for pair in pairs.iter().filter(|p| p.touching) {
            for (me, other) in [(pair.a, pair.b), (pair.b, pair.a)] {
                if fresh(me)
                    && let Ok((_, mut set)) = reporters.colliding.get_mut(me)
                {
                    set.insert(other);
                }
            }
        }
    }
    for &(a, b) in &events.started {
        for (me, other) in [(a, b), (b, a)] {
            if !fresh(me)
                && let Ok((_, mut set)) = reporters.colliding.get_mut(me)
            {
                set.insert(other);
            }
        }
    }
    for &(a, b) in &events.ended {
        for (me, other) in [(a, b), (b, a)] {
            if !fresh(me)
                && let Ok((_, mut set)) = reporters.colliding.get_mut(me)
            {
                set.remove(&other);
            }
        }
    }
}
