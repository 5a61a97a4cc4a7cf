//! Colliders, collision layers, sensors, the broad phase and the narrow phase.

pub mod broad_phase;
pub mod collider;
pub mod constructor;
pub mod layers;
pub mod narrow_phase;
pub mod parts;
pub mod sensor;

pub use broad_phase::BroadPhaseTree;
pub use collider::{Collider, ColliderDisabled, ColliderOf};
pub use constructor::{
    ColliderConstructor, ColliderConstructorHierarchy, ColliderConstructorHierarchyConfig,
    ColliderConstructorHierarchyReady, ColliderConstructorReady,
};
pub use layers::{CollisionLayers, LayerMask, PhysicsLayer};
pub use narrow_phase::{ContactPair, ContactPairs, NarrowPhaseConfig};
pub use sensor::{CollidingEntities, CollisionEventsEnabled, Sensor};

use bevy::prelude::*;

use crate::messages::{CollisionEnd, CollisionEnded, CollisionStart, CollisionStarted};

/// Colliders and contact pairs: the [`ContactPairs`] resource, the `CollisionStarted` /
/// `CollisionEnded` and `CollisionStart` / `CollisionEnd` messages, the layer and sensor
/// components, and the systems that replace [`ColliderConstructor`] and
/// [`ColliderConstructorHierarchy`] with colliders (in `PreUpdate`). The broad and narrow phase systems are [`crate::pipeline`]'s stages.
pub struct CollisionPlugin;

impl Plugin for CollisionPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<ContactPairs>()
            .register_type::<ColliderDisabled>()
            .register_type::<ColliderOf>()
            .add_message::<CollisionStarted>()
            .add_message::<CollisionEnded>()
            .add_message::<CollisionStart>()
            .add_message::<CollisionEnd>()
            .register_type::<CollisionLayers>()
            .register_type::<LayerMask>()
            .register_type::<Sensor>()
            .register_type::<CollisionEventsEnabled>()
            .register_type::<CollidingEntities>()
            .register_type::<ColliderConstructor>()
            .register_type::<ColliderConstructorHierarchy>()
            .add_systems(
                PreUpdate,
                (
                    constructor::build_collider_constructors,
                    constructor::build_collider_constructor_hierarchies,
                ),
            );
    }
}
