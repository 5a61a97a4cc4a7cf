//! Colliders, the broad phase and the narrow phase.

pub mod broad_phase;
pub mod collider;
pub mod narrow_phase;

pub use collider::{Collider, ColliderDisabled};
pub use narrow_phase::{ContactPair, ContactPairs};

use bevy::prelude::*;

use crate::messages::{CollisionEnded, CollisionStarted};

/// Colliders and contact pairs: the [`ContactPairs`] resource and the `CollisionStarted` /
/// `CollisionEnded` messages. The broad and narrow phase systems are
/// [`crate::pipeline`]'s stages.
pub struct CollisionPlugin;

impl Plugin for CollisionPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<ContactPairs>()
            .register_type::<ColliderDisabled>()
            .add_message::<CollisionStarted>()
            .add_message::<CollisionEnded>();
    }
}
