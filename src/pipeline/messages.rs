//! Messages: the step's `Impact`, `CollisionStarted` and `CollisionEnded`.

use bevy::prelude::*;

use crate::messages::{CollisionEnded, CollisionStarted, Impact};
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

/// Writes the step's `Impact`, `CollisionStarted` and `CollisionEnded` messages.
pub fn send_messages(
    events: Res<StepEvents>,
    mut impacts: MessageWriter<Impact>,
    mut started: MessageWriter<CollisionStarted>,
    mut ended: MessageWriter<CollisionEnded>,
) {
    impacts.write_batch(events.impacts.iter().copied());
    started.write_batch(events.started.iter().map(|&(a, b)| CollisionStarted(a, b)));
    ended.write_batch(events.ended.iter().map(|&(a, b)| CollisionEnded(a, b)));
}
