//! Which colliders a spatial query considers.

use bevy::ecs::entity::EntityHashSet;
use bevy::prelude::*;

use crate::collision::{CollisionLayers, LayerMask};

/// Which colliders a spatial query considers (avian3d 0.7's type): those whose layers
/// ([`CollisionLayers::memberships`]) share a layer with `mask`, except `excluded_entities`.
///
/// A query is not a body: the colliders' own `filters` do not matter to it, so a body that
/// touches nothing ([`CollisionLayers::filters`] of [`LayerMask::NONE`]) is still hit by a ray
/// whose mask holds one of its layers. Sensors are hit like any collider; leave their layers out
/// of the mask to skip them.
///
/// # Examples
///
/// ```
/// use bevy::prelude::*;
/// use impact3d::prelude::*;
///
/// let player = Entity::from_raw_u32(7).unwrap();
/// // Layers 0, 1 and 3, never the player.
/// let filter = SpatialQueryFilter::from_mask(0b1011).with_excluded_entities([player]);
/// assert!(filter.test(Entity::from_raw_u32(8).unwrap(), CollisionLayers::new(0b1000, 0)));
/// assert!(!filter.test(Entity::from_raw_u32(8).unwrap(), CollisionLayers::new(0b0100, 0b1111)));
/// assert!(!filter.test(player, CollisionLayers::DEFAULT));
/// ```
#[derive(Clone, Debug, PartialEq, Reflect)]
#[reflect(Debug, PartialEq)]
pub struct SpatialQueryFilter {
    /// The layers whose members are considered. Default [`LayerMask::ALL`].
    pub mask: LayerMask,
    /// Colliders never considered, and bodies whose colliders are never considered. Default
    /// none.
    pub excluded_entities: EntityHashSet,
}

impl Default for SpatialQueryFilter {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl SpatialQueryFilter {
    /// Every layer, no entity excluded.
    pub const DEFAULT: Self = Self {
        mask: LayerMask::ALL,
        excluded_entities: EntityHashSet::new(),
    };

    /// A filter considering the members of the layers of `mask`.
    pub fn from_mask(mask: impl Into<LayerMask>) -> Self {
        Self {
            mask: mask.into(),
            ..Self::DEFAULT
        }
    }

    /// A filter considering every layer except `entities`.
    pub fn from_excluded_entities(entities: impl IntoIterator<Item = Entity>) -> Self {
        Self {
            excluded_entities: EntityHashSet::from_iter(entities),
            ..Self::DEFAULT
        }
    }

    /// This filter with `mask` in place of its mask.
    pub fn with_mask(mut self, mask: impl Into<LayerMask>) -> Self {
        self.mask = mask.into();
        self
    }

    /// This filter with `entities` in place of its excluded entities.
    pub fn with_excluded_entities(mut self, entities: impl IntoIterator<Item = Entity>) -> Self {
        self.excluded_entities = EntityHashSet::from_iter(entities);
        self
    }

    /// Whether a collider of `entity` with `layers` is considered: not excluded, and one of its
    /// memberships is in the mask.
    pub fn test(&self, entity: Entity, layers: CollisionLayers) -> bool {
        self.mask.intersects(layers.memberships) && !self.excluded_entities.contains(&entity)
    }
}
