//! The colliders of a compound body as its contacts see them: a body with colliders on child
//! entities (see [`ColliderOf`](super::ColliderOf)) is one compound shape in the step, and
//! each of its subshapes belongs to one of those colliders, with that collider's material,
//! layers and sensor flag.

use bevy::prelude::*;

use super::layers::{CollisionLayers, LayerMask};
use crate::dynamics::{CoefficientCombine, CombineRules};

/// One collider of a body as its contacts see it: its entity, its material (restitution,
/// friction and combine rules, clamped, the body's where the collider has none of its own),
/// its collision layers and whether it is a sensor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PartMaterial {
    /// The collider's entity (the body's own for the body's own collider).
    pub collider: Entity,
    /// Restitution coefficient, in `[0, 1]`.
    pub restitution: f32,
    /// Friction coefficient, `>= 0`.
    pub friction: f32,
    /// The combine rules it asks for.
    pub combine: CombineRules,
    /// Its collision layers.
    pub layers: CollisionLayers,
    /// It only detects contacts, never pushes.
    pub sensor: bool,
}

/// What a contact between two colliders does (see [`PartMaterial::contact`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PartContact {
    /// Solved, with the pair's combined restitution and friction.
    Solved {
        /// Combined restitution.
        restitution: f32,
        /// Combined friction.
        friction: f32,
    },
    /// Detected only (a sensor in it): touching state and events, no contact rows.
    Sensor,
    /// Their layers do not interact: nothing at all.
    Filtered,
}

impl PartMaterial {
    /// What a contact of this collider with `other` does: nothing when their layers do not
    /// interact (both ways, [`CollisionLayers::interacts_with`]), detection only when either is
    /// a sensor, else a solved contact with each coefficient combined by the pair's rule (as
    /// for two bodies: `Max` unless one asks for another).
    pub fn contact(&self, other: &PartMaterial) -> PartContact {
        if !self.layers.interacts_with(other.layers) {
            PartContact::Filtered
        } else if self.sensor || other.sensor {
            PartContact::Sensor
        } else {
            PartContact::Solved {
                restitution: CoefficientCombine::of_pair(
                    self.combine.restitution,
                    other.combine.restitution,
                )
                .mix(self.restitution, other.restitution),
                friction: CoefficientCombine::of_pair(
                    self.combine.friction,
                    other.combine.friction,
                )
                .mix(self.friction, other.friction),
            }
        }
    }
}

/// The colliders of a body with child colliders, and which of them each subshape of the
/// body's compound shape belongs to.
///
/// ```
/// use bevy::prelude::*;
/// use impact3d::collision::CollisionLayers;
/// use impact3d::collision::parts::{CompoundParts, PartContact, PartMaterial};
/// use impact3d::dynamics::CombineRules;
///
/// let part = |collider, restitution, sensor| PartMaterial {
///     collider,
///     restitution,
///     friction: 0.5,
///     combine: CombineRules::default(),
///     layers: CollisionLayers::DEFAULT,
///     sensor,
/// };
/// let (a, b) = (Entity::from_raw_u32(1).unwrap(), Entity::from_raw_u32(2).unwrap());
/// // Part `a` made of two subshapes (a compound child), then part `b`.
/// let parts = CompoundParts::new(vec![part(a, 1.0, false), part(b, 0.0, true)], vec![0, 0, 1]);
/// assert_eq!(parts.of_subshape(1).collider, a);
/// assert_eq!(parts.of_subshape(2).collider, b);
/// assert!(!parts.all_sensors() && !parts.plain());
/// let ground = part(Entity::from_raw_u32(3).unwrap(), 0.0, false);
/// assert_eq!(
///     parts.of_subshape(0).contact(&ground),
///     PartContact::Solved { restitution: 1.0, friction: 0.5 }
/// );
/// assert_eq!(parts.of_subshape(2).contact(&ground), PartContact::Sensor);
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct CompoundParts {
    /// Each collider, in the order of the body's parts (its own collider first, if it has
    /// one, then its enabled child colliders).
    parts: Vec<PartMaterial>,
    /// For each subshape of the body's shape, the index of its collider in `parts`.
    leaves: Vec<u32>,
    /// No part is a sensor and all have the same layers: every subshape pairs with another
    /// body as the whole body does.
    plain: bool,
}

impl CompoundParts {
    /// The colliders `parts` (at least one) and, for each subshape of the body's shape, the
    /// index of its collider in `parts` (a subshape past the end belongs to the first).
    pub fn new(parts: Vec<PartMaterial>, leaves: Vec<u32>) -> Self {
        assert!(!parts.is_empty(), "a compound body has at least one part");
        let plain = parts
            .iter()
            .all(|p| !p.sensor && p.layers == parts[0].layers);
        CompoundParts {
            parts,
            leaves,
            plain,
        }
    }

    /// The colliders, in the order of the body's parts.
    pub fn parts(&self) -> &[PartMaterial] {
        &self.parts
    }

    /// The collider subshape `subshape` of the body's shape belongs to.
    pub fn of_subshape(&self, subshape: u32) -> &PartMaterial {
        let i = self.leaves.get(subshape as usize).copied().unwrap_or(0);
        &self.parts[i as usize]
    }

    /// Whether every collider is a sensor: the body then only detects, as a sensor body.
    pub fn all_sensors(&self) -> bool {
        self.parts.iter().all(|p| p.sensor)
    }

    /// Whether no collider is a sensor and all have the same layers, so that every contact of
    /// the body with another is of one kind.
    pub fn plain(&self) -> bool {
        self.plain
    }

    /// The layers of the body as a whole: the union of its colliders' memberships and of their
    /// filters, so that two bodies pair whenever any two of their colliders may interact.
    pub fn layers(&self) -> CollisionLayers {
        let (mut memberships, mut filters) = (LayerMask(0), LayerMask(0));
        for p in &self.parts {
            memberships |= p.layers.memberships;
            filters |= p.layers.filters;
        }
        CollisionLayers {
            memberships,
            filters,
        }
    }
}
