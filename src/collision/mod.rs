//! Colliders, the broad phase and the narrow phase.

pub mod broad_phase;
pub mod collider;
pub mod narrow_phase;

pub use collider::Collider;
pub use narrow_phase::{ContactPair, ContactPairs};

use bevy::prelude::*;

use crate::messages::{CollisionEnded, CollisionStarted};
use crate::pipeline;
use crate::schedule::{PhysicsSchedule, PhysicsSystems};

/// Broad and narrow phase: candidate pairs, persistent contact manifolds, and the
/// `CollisionStarted` / `CollisionEnded` messages.
pub struct CollisionPlugin;

impl Plugin for CollisionPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<ContactPairs>()
            .add_message::<CollisionStarted>()
            .add_message::<CollisionEnded>()
            .add_systems(
                PhysicsSchedule,
                (
                    pipeline::update_broad_phase.in_set(PhysicsSystems::BroadPhase),
                    pipeline::update_narrow_phase.in_set(PhysicsSystems::NarrowPhase),
                ),
            );
    }
}
