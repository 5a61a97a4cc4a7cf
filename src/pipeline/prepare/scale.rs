//! The shape of a body with child colliders or a world scale: its own collider and its parts,
//! each scaled and placed in the body's frame, built once and kept until its inputs change.

use bevy::prelude::*;
use parry3d::math::Pose;
use parry3d::shape::SharedShape;

use crate::collision::Collider;
use crate::collision::CollisionLayers;
use crate::collision::collider::{BodyPart, Scaling, body_leaves, body_shape, scaled_shape};
use crate::dynamics::validation::body_label;
use crate::dynamics::{CombineRules, Density};

use super::super::PhysicsState;
use super::hierarchy::parts_in;
use super::query::BodyDataItem;
use super::validation::MIN_ROTATION_LENGTH_SQUARED;

/// A collider on a descendant of a body, as [`resolve_hierarchy`](super::resolve_hierarchy)
/// found it: the input of a body's built shape.
#[derive(Clone)]
pub(super) struct ChildPart {
    pub(super) collider: Entity,
    /// Its shape, unscaled (kept, so that its address identifies it while it lives).
    pub(super) shape: SharedShape,
    pub(super) error: Option<String>,
    /// Its pose and scale relative to the body's frame (the body's world pose without scale):
    /// the body's world scale, then the `Transform`s from the body down to the collider.
    pub(super) relative: Transform,
    pub(super) density: Option<f32>,
    pub(super) mass: Option<f32>,
    pub(super) disabled: bool,
    pub(super) name: Option<Name>,
    /// Its own restitution and friction (as given; clamped when its contacts use them) and
    /// combine rules: where it has none, its body's are used.
    pub(super) restitution: Option<f32>,
    pub(super) friction: Option<f32>,
    pub(super) combine: CombineRules,
    /// Its own collision layers (its body's without them).
    pub(super) layers: Option<CollisionLayers>,
    /// It has a `Sensor` (so does every part of a body that has one).
    pub(super) sensor: bool,
    /// It has `CollisionEventsEnabled` or `CollidingEntities`.
    pub(super) reports: bool,
}

impl ChildPart {
    /// The same collider with the same inputs (the same shape allocation, bit-equal numbers).
    fn same(&self, other: &ChildPart) -> bool {
        let bits = |t: &Transform| {
            (
                t.translation.to_array().map(f32::to_bits),
                t.rotation.to_array().map(f32::to_bits),
                t.scale.to_array().map(f32::to_bits),
            )
        };
        self.collider == other.collider
            && std::sync::Arc::ptr_eq(&self.shape.0, &other.shape.0)
            && bits(&self.relative) == bits(&other.relative)
            && self.density.map(f32::to_bits) == other.density.map(f32::to_bits)
            && self.mass.map(f32::to_bits) == other.mass.map(f32::to_bits)
            && self.disabled == other.disabled
    }
}

/// Whether the parts a body was built from are the parts it has now: the same colliders, in
/// the same order, with the same inputs.
pub(super) fn same_parts(built: &[ChildPart], now: &[(Entity, ChildPart)]) -> bool {
    built.len() == now.len() && built.iter().zip(now).all(|(a, (_, b))| a.same(b))
}

/// The shape built for a body with child colliders or a scale, and the inputs it was built
/// from.
pub(in crate::pipeline) struct BuiltBody {
    /// The body's own collider shape, unscaled.
    own: Option<SharedShape>,
    /// The body's world scale, as bits.
    scale: [u32; 3],
    /// The body's density (for its own collider and children without one), as bits.
    density: u32,
    pub(super) children: Vec<ChildPart>,
    /// The colliders, scaled and placed in the body's frame.
    pub(super) parts: Vec<BodyPart>,
    /// The shape of the step: the lone scaled collider, or the compound of all.
    pub(super) shape: SharedShape,
    /// For each subshape of `shape`, the index of its part in `parts` (see [`body_leaves`]).
    pub(super) leaves: Vec<u32>,
    /// Visited in this step or still needed (see [`HierarchyState::prune`]).
    ///
    /// [`HierarchyState::prune`]: super::HierarchyState::prune
    pub(super) needed: bool,
}

impl BuiltBody {
    /// Whether it was built from these inputs: the same own collider (the same shape
    /// allocation), scale and density bits, and the same parts.
    fn built_from(
        &self,
        own: Option<&Collider>,
        scale: [u32; 3],
        density: f32,
        children: &[(Entity, ChildPart)],
    ) -> bool {
        self.scale == scale
            && self.density == density.to_bits()
            && match (&self.own, own) {
                (Some(a), Some(b)) => std::sync::Arc::ptr_eq(&a.0, &b.shape().0),
                (None, None) => true,
                _ => false,
            }
            && same_parts(&self.children, children)
    }
}

/// Checks that a scale is usable: each component finite and > 0.
fn check_scale(what: &str, scale: Vec3) -> Result<(), String> {
    if scale.is_finite() && scale.min_element() > 0.0 {
        Ok(())
    } else {
        Err(format!(
            "{what} {scale} is not usable (each component must be finite and > 0)"
        ))
    }
}

/// Checks a body's child colliders: each valid, with a usable scale and a finite pose
/// relative to the body. The error names the first bad one.
fn check_parts(children: &[(Entity, ChildPart)]) -> Result<(), String> {
    for (_, part) in children {
        let label = || {
            format!(
                "child collider {}",
                body_label(part.collider, part.name.as_ref())
            )
        };
        if let Some(error) = &part.error {
            return Err(format!("{}: invalid collider: {error}", label()));
        }
        check_scale(&format!("{} has scale", label()), part.relative.scale)?;
        let norm = part.relative.rotation.length_squared();
        if !(part.relative.translation.is_finite()
            && norm.is_finite()
            && norm >= MIN_ROTATION_LENGTH_SQUARED)
        {
            return Err(format!(
                "{}: its pose relative to the body ({:?}) is not finite",
                label(),
                part.relative
            ));
        }
    }
    Ok(())
}

/// Builds (or keeps, when its inputs did not change) the shape of a body with child colliders
/// or a world scale `scale`: its own collider scaled by `scale`, and each part scaled and placed
/// relative to the body. `Ok(Some(changed))` when built (`changed`: in this step), `Ok(None)`
/// when the body has no collider left (every part disabled), `Err` naming a bad scale or
/// collider.
pub(super) fn build_body(
    state: &mut PhysicsState,
    item: &BodyDataItem,
    scale: Vec3,
) -> Result<Option<bool>, String> {
    let entity = item.entity;
    let hs = &mut state.hierarchy;
    let own = item.collider.as_deref();
    if let Some(error) = own.and_then(Collider::error) {
        return Err(format!("invalid collider: {error}"));
    }
    check_scale("scale", scale)?;
    let children = parts_in(&hs.parts, entity);
    check_parts(children)?;
    let density = item
        .density
        .as_deref()
        .map_or(Density::default().0, |d| d.0);
    let scale_bits = scale.to_array().map(f32::to_bits);
    if let Some(built) = hs.built.get_mut(&entity)
        && built.built_from(own, scale_bits, density, children)
    {
        built.needed = true;
        return Ok((!built.parts.is_empty()).then_some(false));
    }
    let (parts, nearest) = scaled_parts(entity, item.name, own, scale, density, children)?;
    for (collider, name, s) in nearest {
        if hs.warned.insert(collider) {
            log::warn!(
                "impact3d: {}'s shape cannot take the scale {s}; the nearest it can take is used \
                 (see `scaled_shape`)",
                body_label(collider, name.as_ref())
            );
        }
    }
    let shape = if parts.is_empty() {
        SharedShape::ball(1.0)
    } else {
        body_shape(&parts)
    };
    let empty = parts.is_empty();
    let leaves = body_leaves(&parts);
    hs.built.insert(
        entity,
        BuiltBody {
            own: own.map(|c| c.shape().clone()),
            scale: scale_bits,
            density: density.to_bits(),
            children: children.iter().map(|(_, p)| p.clone()).collect(),
            parts,
            shape,
            leaves,
            needed: true,
        },
    );
    Ok((!empty).then_some(true))
}

/// The colliders that took the nearest scale their shape can take, with their names and the
/// scale they were given.
type Nearest = Vec<(Entity, Option<Name>, Vec3)>;

/// The parts of body `entity` (named `name`): its own collider scaled by `scale` at its
/// origin, then each enabled child collider scaled and placed relative to it, those without a
/// density taking `density`; and the colliders that took the nearest scale they can.
fn scaled_parts(
    entity: Entity,
    name: Option<&Name>,
    own: Option<&Collider>,
    scale: Vec3,
    density: f32,
    children: &[(Entity, ChildPart)],
) -> Result<(Vec<BodyPart>, Nearest), String> {
    let mut parts = Vec::with_capacity(children.len() + 1);
    let mut nearest = Vec::new();
    if let Some(own) = own {
        let (shape, how) = scaled_shape(own.shape(), scale)?;
        if how == Scaling::Nearest {
            nearest.push((entity, name.cloned(), scale));
        }
        parts.push(BodyPart {
            shape,
            pose: Pose::IDENTITY,
            density,
            mass: None,
        });
    }
    for (_, part) in children.iter().filter(|(_, p)| !p.disabled) {
        let r = &part.relative;
        let (shape, how) = scaled_shape(&part.shape, r.scale)?;
        if how == Scaling::Nearest {
            nearest.push((part.collider, part.name.clone(), r.scale));
        }
        parts.push(BodyPart {
            shape,
            pose: Pose::from_parts(r.translation, r.rotation.normalize()),
            density: part.density.unwrap_or(density),
            mass: part.mass,
        });
    }
    Ok((parts, nearest))
}
