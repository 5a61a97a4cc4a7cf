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

/// Writes the step's `Impact`, `CollisionStarted` and `CollisionEnded` messages (every pair of
/// bodies); `CollisionStart` and `CollisionEnd` messages for the pairs of colliders (see
/// [`StepEvents::colliders_started`]) of which a collider or its body has
/// [`CollisionEventsEnabled`], triggered as entity events on each such collider (with it as
/// `collider1` and its body as `body1`, the pair's bodies in entity order); and updates
/// [`CollidingEntities`] (a newly inserted one is filled from the pairs touching now).
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
        // A collider asks for events with `CollisionEventsEnabled` on itself or on its body.
        let enabled = |c: Entity, b: Entity| {
            reporters.events.contains(c) || (b != c && reporters.events.contains(b))
        };
        for p in &events.colliders_started {
            let ((c1, c2), (b1, b2)) = (p.colliders, p.bodies);
            let (on_a, on_b) = (enabled(c1, b1), enabled(c2, b2));
            if !(on_a || on_b) {
                continue;
            }
            let start = |c1: Entity, c2: Entity, b1: Entity, b2: Entity| CollisionStart {
                collider1: c1,
                collider2: c2,
                body1: Some(b1),
                body2: Some(b2),
            };
            writers.start.write(start(c1, c2, b1, b2));
            if on_a {
                commands.trigger(start(c1, c2, b1, b2));
            }
            if on_b {
                commands.trigger(start(c2, c1, b2, b1));
            }
        }
        for p in &events.colliders_ended {
            let ((c1, c2), (b1, b2)) = (p.colliders, p.bodies);
            let (on_a, on_b) = (enabled(c1, b1), enabled(c2, b2));
            if !(on_a || on_b) {
                continue;
            }
            let end = |c1: Entity, c2: Entity, b1: Entity, b2: Entity| CollisionEnd {
                collider1: c1,
                collider2: c2,
                body1: Some(b1),
                body2: Some(b2),
            };
            writers.end.write(end(c1, c2, b1, b2));
            if on_a {
                commands.trigger(end(c1, c2, b1, b2));
            }
            if on_b {
                commands.trigger(end(c2, c1, b2, b1));
            }
        }
    }
    update_colliding_entities(&events, &pairs, &mut reporters);
}

/// Brings every [`CollidingEntities`] up to date with the step's touching transitions between
/// colliders ([`StepEvents::colliders_started`] and `colliders_ended`: a body's own collider
/// is named by the body, a child collider by its own entity), as avian3d's, which is a
/// collider's; a newly inserted one is filled from every pair of colliders touching now (the
/// resting pairs of sleeping bodies included).
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
    let mut update = |(a, b): (Entity, Entity), touching: bool, only_fresh: bool| {
        for (me, other) in [(a, b), (b, a)] {
            if fresh(me) == only_fresh
                && let Ok((_, mut set)) = reporters.colliding.get_mut(me)
            {
                if touching {
                    set.insert(other);
                } else {
                    set.remove(&other);
                }
            }
        }
    };
    if !inserted.is_empty() {
        for pair in pairs.iter().filter(|p| p.touching) {
            if pair.compound {
                for &colliders in &pair.part_touching {
                    update(colliders, true, true);
                }
            } else {
                update((pair.a, pair.b), true, true);
            }
        }
    }
    for p in &events.colliders_started {
        update(p.colliders, true, false);
    }
    for p in &events.colliders_ended {
        update(p.colliders, false, false);
    }
}
