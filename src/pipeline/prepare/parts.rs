//! A child collider as a part of its body: what the prepare stage reads of it
//! ([`PartInfo`]) and what its body's contacts see of it ([`compound_parts`]).

use std::sync::Arc;

use bevy::prelude::*;

use crate::collision::collider::ColliderOf;
use crate::collision::parts::{CompoundParts, PartMaterial};
use crate::collision::{
    ColliderDisabled, CollidingEntities, CollisionEventsEnabled, CollisionLayers, Sensor,
};
use crate::dynamics::{
    CombineRules, Density, Friction, FrictionCombine, Mass, Restitution, RestitutionCombine,
};

use super::super::PhysicsState;
use super::query::BodyDataItem;
use super::scale::BuiltBody;
use super::validation::clamp_coefficient;

/// What a child collider adds to its body: its density, mass, name, whether it is disabled, the
/// body it was marked a part of, and what its contacts take from it ([`PartContacts`]).
pub(super) type PartInfo = (
    Option<&'static Density>,
    Option<&'static Mass>,
    Option<&'static Name>,
    Has<ColliderDisabled>,
    Option<&'static ColliderOf>,
    PartContacts,
);

/// What a child collider's contacts take from it: its material and combine rules, layers,
/// sensor marker, and whether it asks for reports.
pub(super) type PartContacts = (
    Option<Ref<'static, Restitution>>,
    Option<Ref<'static, Friction>>,
    Option<&'static RestitutionCombine>,
    Option<&'static FrictionCombine>,
    Option<Ref<'static, CollisionLayers>>,
    Option<Ref<'static, Sensor>>,
    Has<CollisionEventsEnabled>,
    Has<CollidingEntities>,
);

/// The colliders of a body with child colliders (`built`: its built shape) as its contacts
/// see them (see [`CompoundParts`]): its own collider, if it has one, with the body's
/// material, layers and sensor marker, then each enabled child collider with its own, the
/// body's where it has none (a child of a sensor body is a sensor); and whether a child
/// collider asks for reports.
pub(super) fn compound_parts(
    state: &PhysicsState,
    item: &BodyDataItem,
    built: &BuiltBody,
) -> Option<(Arc<CompoundParts>, bool)> {
    let restitution = item.restitution.as_deref().map(|r| r.0);
    let friction = item.friction.as_deref().map(|f| f.0);
    let own = PartMaterial {
        collider: item.entity,
        restitution: clamp_coefficient(restitution, 1.0),
        friction: clamp_coefficient(friction, f32::INFINITY),
        combine: CombineRules {
            restitution: item.restitution_combine.map(|c| c.0),
            friction: item.friction_combine.map(|c| c.0),
        },
        layers: item.layers.as_deref().copied().unwrap_or_default(),
        sensor: item.sensor.is_some(),
    };
    let mut parts = Vec::with_capacity(built.parts.len());
    if item.collider.is_some() {
        parts.push(own);
    }
    let mut reports = false;
    for (_, child) in state.hierarchy.parts_of(item.entity) {
        if child.disabled {
            continue;
        }
        reports |= child.reports;
        parts.push(PartMaterial {
            collider: child.collider,
            restitution: clamp_coefficient(child.restitution.or(restitution), 1.0),
            friction: clamp_coefficient(child.friction.or(friction), f32::INFINITY),
            combine: CombineRules {
                restitution: child.combine.restitution.or(own.combine.restitution),
                friction: child.combine.friction.or(own.combine.friction),
            },
            layers: child.layers.unwrap_or(own.layers),
            sensor: child.sensor || own.sensor,
        });
    }
    // The parts are those the shape was built from, in its order.
    if parts.is_empty() || parts.len() != built.parts.len() {
        return None;
    }
    Some((
        Arc::new(CompoundParts::new(parts, built.leaves.clone())),
        reports,
    ))
}
