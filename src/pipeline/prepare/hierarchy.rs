//! The entity hierarchy: colliders on child entities (the parts of a compound body), parented
//! bodies and static colliders at their world poses.

use bevy::ecs::entity::{EntityHashMap, EntityHashSet};
use bevy::ecs::system::SystemParam;
use bevy::prelude::*;

use crate::collision::Collider;
use crate::collision::collider::ColliderOf;
use crate::dynamics::validation::body_label;
use crate::dynamics::{CombineRules, RigidBody, RigidBodyDisabled};

use super::super::PhysicsState;
use super::parts::PartInfo;
use super::scale::{BuiltBody, ChildPart, same_parts};
use super::validation::warn_on_coefficient_change;

/// Most ancestors walked up from one entity: Bevy's hierarchy has no cycles, so the bound only
/// keeps a broken one from hanging the step.
const MAX_ANCESTORS: usize = 4096;

/// What the prepare stage knows of the entity hierarchy: rebuilt each step by
/// [`resolve_hierarchy`] (the child colliders, the world poses of parented entities), and kept
/// across steps (each body's built shape, until its inputs change).
#[derive(Default)]
pub(in crate::pipeline) struct HierarchyState {
    /// The colliders that are parts of another entity's body in this step, `(body, part)`,
    /// sorted by body, then in the order of the body's descendants (depth first, each entity's
    /// `Children` in their order: the order of `Collider::compound`'s parts when they were
    /// spawned in that order).
    pub(super) parts: Vec<(Entity, ChildPart)>,
    /// Scratch: the depth-first position of each descendant of the bodies with parts, sorted
    /// by entity.
    order: Vec<(Entity, u32)>,
    /// The entities of those colliders, sorted: they are not bodies of their own.
    attached: Vec<Entity>,
    /// The world pose of each gathered entity with a parent, sorted by entity.
    world: Vec<(Entity, Transform)>,
    /// The world pose of the parent of each body that has one, at the start of the step,
    /// sorted by entity: the write-back turns the solved world pose into a local `Transform`.
    parent_frames: Vec<(Entity, Transform)>,
    /// The bodies whose ancestors or child colliders changed since the last step, sorted: read
    /// (and woken) even when asleep.
    pub(super) disturbed: Vec<Entity>,
    /// The bodies whose child colliders changed since the last step (were added, removed,
    /// moved, or changed shape, density or mass), sorted: their mass properties are recomputed.
    reshaped: Vec<Entity>,
    /// The shape and parts built for each body with child colliders or a scale.
    pub(super) built: EntityHashMap<BuiltBody>,
    /// The entities a warning has been logged for (a scale their shape cannot take, a child
    /// collider that cannot be a part of its body): each is warned about once.
    pub(super) warned: EntityHashSet,
}

impl HierarchyState {
    /// The colliders of `body` that sit on other entities.
    pub(super) fn parts_of(&self, body: Entity) -> &[(Entity, ChildPart)] {
        parts_in(&self.parts, body)
    }

    /// The body that collider `entity` is a part of in this step, if it is one.
    pub(super) fn body_of(&self, entity: Entity) -> Option<Entity> {
        if !self.is_attached(entity) {
            return None;
        }
        self.parts
            .iter()
            .find(|(_, p)| p.collider == entity)
            .map(|(b, _)| *b)
    }

    pub(super) fn has_parts(&self, body: Entity) -> bool {
        !self.parts_of(body).is_empty()
    }

    /// Whether `entity` is a collider that is a part of another entity's body in this step.
    pub(super) fn is_attached(&self, entity: Entity) -> bool {
        sorted_contains(&self.attached, entity)
    }

    /// The world pose of `entity` if it has a parent.
    pub(super) fn world_pose(&self, entity: Entity) -> Option<Transform> {
        pose_in(&self.world, entity)
    }

    pub(super) fn is_disturbed(&self, entity: Entity) -> bool {
        sorted_contains(&self.disturbed, entity)
    }

    pub(super) fn is_reshaped(&self, entity: Entity) -> bool {
        sorted_contains(&self.reshaped, entity)
    }

    /// Whether a shape is kept for `entity` from an earlier step.
    pub(super) fn was_built(&self, entity: Entity) -> bool {
        !self.built.is_empty() && self.built.contains_key(&entity)
    }

    /// The world pose of the parent of body `entity`, if it has one.
    pub(in crate::pipeline) fn parent_frame(&self, entity: Entity) -> Option<Transform> {
        pose_in(&self.parent_frames, entity)
    }

    /// Drops the shapes built for `entities` (bodies that left the step).
    pub(super) fn forget(&mut self, entities: &[Entity]) {
        if self.built.is_empty() {
            return;
        }
        for entity in entities {
            self.built.remove(entity);
        }
    }

    /// Drops the shapes built for bodies that neither have child colliders nor were built in
    /// this step (no longer scaled, or asleep and scaled: rebuilt, to the same shape, when
    /// read again).
    pub(super) fn prune(&mut self) {
        self.built.retain(|_, b| b.needed);
    }

    /// Empties what a step finds afresh; the built shapes and the warnings are kept.
    fn begin(&mut self) {
        self.parts.clear();
        self.attached.clear();
        self.world.clear();
        self.parent_frames.clear();
        self.disturbed.clear();
        self.reshaped.clear();
    }
}

/// Whether the sorted `entities` hold `entity`.
pub(super) fn sorted_contains(entities: &[Entity], entity: Entity) -> bool {
    !entities.is_empty() && entities.binary_search(&entity).is_ok()
}

/// The pose of `entity` in `poses` (sorted by entity), if it is there.
fn pose_in(poses: &[(Entity, Transform)], entity: Entity) -> Option<Transform> {
    if poses.is_empty() {
        return None;
    }
    let i = poses.binary_search_by_key(&entity, |(e, _)| *e).ok()?;
    Some(poses[i].1)
}

/// The entries of `body` in `parts` (sorted by body).
pub(super) fn parts_in(parts: &[(Entity, ChildPart)], body: Entity) -> &[(Entity, ChildPart)] {
    if parts.is_empty() {
        return &[];
    }
    let start = parts.partition_point(|(b, _)| *b < body);
    let end = start + parts[start..].partition_point(|(b, _)| *b == body);
    &parts[start..end]
}

/// The entity hierarchy the prepare stage reads.
#[derive(SystemParam)]
pub struct HierarchyData<'w, 's> {
    /// Every entity's transform and parent, to walk up the tree.
    nodes: Query<'w, 's, HierarchyNode>,
    /// The entities with a parent that a step may gather: bodies and colliders.
    parented: Query<'w, 's, ParentedEntity, ParentedFilter>,
    /// What a child collider adds to its body.
    info: Query<'w, 's, PartInfo>,
    /// The colliders marked as parts of a body.
    marked: Query<'w, 's, Entity, With<ColliderOf>>,
    /// Each entity's children, in order: a body's parts are ordered as its descendants are.
    children: Query<'w, 's, &'static Children>,
}

/// The world transform of `entity` (its `Transform` composed with its ancestors', as Bevy's
/// `GlobalTransform` holds after propagation, here as it is at the step) and whether any of
/// them, or a parent link on the way, changed since the last step.
fn world_of(nodes: &Query<HierarchyNode>, entity: Entity) -> (Transform, bool) {
    let mut world: Option<Transform> = None;
    let mut changed = false;
    let mut e = entity;
    // Bevy's hierarchy has no cycles; the bound only keeps a broken one from hanging the step.
    for _ in 0..MAX_ANCESTORS {
        let Ok((transform, parent, _, _)) = nodes.get(e) else {
            break;
        };
        if let Some(t) = transform {
            changed |= t.is_changed();
            world = Some(match world {
                Some(below) => t.mul_transform(below),
                None => *t,
            });
        }
        match parent {
            Some(p) => {
                changed |= p.is_changed();
                e = p.parent();
            }
            None => break,
        }
    }
    (world.unwrap_or_default(), changed)
}

/// An entity with a parent that a step may gather: its parent, whether it is a body, its
/// collider.
type ParentedEntity = (
    Entity,
    &'static ChildOf,
    Has<RigidBody>,
    Option<&'static Collider>,
);

/// Bodies and colliders, not disabled.
type ParentedFilter = (
    Or<(With<RigidBody>, With<Collider>)>,
    Without<RigidBodyDisabled>,
);

/// The item [`HierarchyData::nodes`] reads.
type HierarchyNode = (
    Option<Ref<'static, Transform>>,
    Option<Ref<'static, ChildOf>>,
    Option<&'static RigidBody>,
    Option<&'static Collider>,
);

/// Finds, for this step, the colliders that are parts of a body (each collider without a
/// `RigidBody` under an entity with one: the nearest such ancestor, avian3d's rule), their poses
/// relative to their bodies, and the world poses of parented bodies and static colliders; keeps
/// [`ColliderOf`] on the parts; and marks the bodies whose ancestors or parts changed. A
/// collider with no body above it is a static collider at its world pose.
pub(in crate::pipeline) fn resolve_hierarchy(
    state: &mut PhysicsState,
    commands: &mut Commands,
    h: &HierarchyData,
) {
    let (hs, departed) = (&mut state.hierarchy, &mut state.departed);
    hs.begin();
    for (entity, child_of, is_body, collider) in h.parented.iter() {
        let parent = child_of.parent();
        if is_body {
            place_body(hs, h, entity, parent);
        } else if let Some(collider) = collider {
            place_collider(hs, h, commands, departed, entity, parent, collider);
        }
    }
    hs.attached.sort_unstable();
    for entity in h.marked.iter() {
        if hs.attached.binary_search(&entity).is_err() {
            commands.entity(entity).remove::<ColliderOf>();
        }
    }
    order_parts(hs, h);
    hs.world.sort_unstable_by_key(|(e, _)| *e);
    hs.parent_frames.sort_unstable_by_key(|(e, _)| *e);
    find_reshaped(hs);
    hs.disturbed.extend_from_slice(&hs.reshaped);
    hs.disturbed.sort_unstable();
    hs.disturbed.dedup();
}

/// A body with a parent: its world pose and its parent's, and whether they moved.
fn place_body(hs: &mut HierarchyState, h: &HierarchyData, entity: Entity, parent: Entity) {
    let (frame, moved) = world_of(&h.nodes, parent);
    let (own, up) = match h.nodes.get(entity) {
        Ok((t, up, _, _)) => (t.map_or(Transform::IDENTITY, |t| *t), up),
        Err(_) => (Transform::IDENTITY, None),
    };
    hs.world.push((entity, frame.mul_transform(own)));
    hs.parent_frames.push((entity, frame));
    if moved || up.is_some_and(|p| p.is_changed()) {
        hs.disturbed.push(entity);
    }
}

/// A collider with a parent and no body of its own: a part of the nearest body above it (its
/// pose relative to that body, scaled by the body's world scale), marked with [`ColliderOf`];
/// or, with no body above it or a shape that cannot be a part, a static collider at its world
/// pose. One that was a static collider of its own until now `departed`: its pairs end.
fn place_collider(
    hs: &mut HierarchyState,
    h: &HierarchyData,
    commands: &mut Commands,
    departed: &mut Vec<Entity>,
    entity: Entity,
    parent: Entity,
    collider: &Collider,
) {
    // Long (about 90 lines) on purpose: the two outcomes of one look-up (a part of the body
    // above, or a static collider of its own), each a few steps over the same query item; the
    // part's material, layers and sensor flag are read where the part is built from them.
    let (mut relative, body) = body_above(h, entity, parent);
    let Ok((density, mass, name, disabled, marked, contacts)) = h.info.get(entity) else {
        return;
    };
    let (
        restitution,
        friction,
        restitution_combine,
        friction_combine,
        layers,
        sensor,
        events,
        colliding,
    ) = contacts;
    let composable = |c: Option<&Collider>| c.is_none_or(|c| !c.is_unbounded_or_hollow());
    match body {
        Some((b, _, own)) if composable(Some(collider)) && composable(own) => {
            let scale = world_of(&h.nodes, b).0.scale;
            if scale != Vec3::ONE {
                relative = Transform::from_scale(scale).mul_transform(relative);
            }
            // A bad coefficient is clamped, with a warning naming the collider, as a body's is.
            let label = || format!("child collider {}", body_label(entity, name));
            warn_on_coefficient_change(&label, restitution.as_ref(), "restitution", 1.0);
            warn_on_coefficient_change(&label, friction.as_ref(), "friction", f32::INFINITY);
            // New layers or a new sensor marker change the pairs its body may have.
            if layers.as_ref().is_some_and(|l| l.is_changed())
                || sensor.as_ref().is_some_and(|s| s.is_added())
            {
                hs.disturbed.push(b);
            }
            hs.parts.push((
                b,
                ChildPart {
                    collider: entity,
                    shape: collider.shape().clone(),
                    error: collider.error().map(str::to_string),
                    relative,
                    density: density.map(|d| d.0),
                    mass: mass.map(|m| m.0),
                    disabled,
                    name: name.cloned(),
                    restitution: restitution.map(|r| r.0),
                    friction: friction.map(|f| f.0),
                    combine: CombineRules {
                        restitution: restitution_combine.map(|c| c.0),
                        friction: friction_combine.map(|c| c.0),
                    },
                    layers: layers.map(|l| *l),
                    sensor: sensor.is_some(),
                    reports: events || colliding,
                },
            ));
            hs.attached.push(entity);
            if marked.map(|m| m.body) != Some(b) {
                commands.entity(entity).insert(ColliderOf { body: b });
                // It may have been a static collider of its own until now: its pairs end.
                departed.push(entity);
            }
        }
        found => {
            if let Some((_, kind, _)) = found
                && kind != RigidBody::Static
                && hs.warned.insert(entity)
            {
                log::warn!(
                    "impact3d: {} is a triangle mesh, heightfield or half-space (or its \
                     body's own collider is one) and cannot be a part of its {kind:?} body; \
                     it stays a static collider at its pose",
                    body_label(entity, name)
                );
            }
            let (world, moved) = world_of(&h.nodes, entity);
            hs.world.push((entity, world));
            if moved {
                hs.disturbed.push(entity);
            }
        }
    }
}

/// A body above a collider: its entity, its kind and its own collider.
type BodyAbove<'a> = (Entity, RigidBody, Option<&'a Collider>);

/// A body above the collider `entity`, found from its `parent` up (the nearest entity with a
/// `RigidBody`: its entity, kind and own collider), and the collider's `Transform` composed
/// with those of the entities between them.
fn body_above<'a>(
    h: &'a HierarchyData,
    entity: Entity,
    parent: Entity,
) -> (Transform, Option<BodyAbove<'a>>) {
    let mut relative = match h.nodes.get(entity) {
        Ok((Some(t), _, _, _)) => *t,
        _ => Transform::IDENTITY,
    };
    let mut e = parent;
    for _ in 0..MAX_ANCESTORS {
        let Ok((transform, up, rigid, own)) = h.nodes.get(e) else {
            break;
        };
        if let Some(kind) = rigid {
            return (relative, Some((e, *kind, own)));
        }
        if let Some(t) = transform {
            relative = t.mul_transform(relative);
        }
        match up {
            Some(p) => e = p.parent(),
            None => break,
        }
    }
    (relative, None)
}

/// Sorts the parts of each body in the order of its descendants (depth first, each entity's
/// children in their order).
fn order_parts(hs: &mut HierarchyState, h: &HierarchyData) {
    hs.order.clear();
    let mut bodies: Vec<Entity> = hs.parts.iter().map(|(b, _)| *b).collect();
    bodies.sort_unstable();
    bodies.dedup();
    let mut stack = Vec::new();
    for body in bodies {
        let mut n = 0u32;
        stack.clear();
        stack.push(body);
        while let Some(e) = stack.pop() {
            hs.order.push((e, n));
            n += 1;
            if let Ok(children) = h.children.get(e) {
                stack.extend(children.iter().rev());
            }
        }
    }
    hs.order.sort_unstable_by_key(|(e, _)| *e);
    let order = &hs.order;
    let position = |e: Entity| {
        order
            .binary_search_by_key(&e, |(k, _)| *k)
            .map_or(u32::MAX, |i| order[i].1)
    };
    hs.parts
        .sort_by_cached_key(|(body, part)| (*body, position(part.collider), part.collider));
}

/// Marks the bodies whose parts changed, and those that lost all of them, as reshaped (sorted);
/// the shapes built for bodies with parts are needed.
fn find_reshaped(hs: &mut HierarchyState) {
    for b in hs.built.values_mut() {
        b.needed = false;
    }
    let mut i = 0;
    while i < hs.parts.len() {
        let body = hs.parts[i].0;
        let n = hs.parts[i..].partition_point(|(b, _)| *b == body);
        let parts = &hs.parts[i..i + n];
        let same = hs.built.get_mut(&body).is_some_and(|built| {
            built.needed = true;
            same_parts(&built.children, parts)
        });
        if !same {
            hs.reshaped.push(body);
        }
        i += n;
    }
    for (&body, built) in hs.built.iter() {
        if !built.children.is_empty() && parts_in(&hs.parts, body).is_empty() {
            hs.reshaped.push(body);
        }
    }
    hs.reshaped.sort_unstable();
}
