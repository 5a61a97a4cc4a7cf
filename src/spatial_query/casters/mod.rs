//! [`RayCaster`] and [`ShapeCaster`]: components that cast every physics step, relative to their
//! entity, and keep their hits in [`RayHits`] and [`ShapeHits`].

use std::ops::DerefMut;

use bevy::ecs::component::Mutable;
use bevy::ecs::entity::EntityHashMap;
use bevy::prelude::*;

use super::system_param::{check_point, check_rotation};
use super::{SpatialQuery, SpatialQueryFilter};

mod ray;
mod shape;

pub use ray::{RayCaster, RayHits, update_ray_casters};
pub use shape::{ShapeCaster, ShapeHits, update_shape_casters};

/// The caster entity's world pose (translation, normalised rotation), identity without a
/// `Transform`, or why it cannot be used.
fn caster_frame(transform: Option<&Transform>) -> Result<(Vec3, Quat), String> {
    let Some(t) = transform else {
        return Ok((Vec3::ZERO, Quat::IDENTITY));
    };
    let translation = check_point("Transform translation", t.translation)?;
    let rotation = check_rotation(t.rotation).map_err(|e| format!("Transform {e}"))?;
    Ok((translation, rotation))
}

/// Names a caster in a log line: `what "Name" (entity)`, or `what entity`.
fn caster_label(what: &str, entity: Entity, name: Option<&Name>) -> String {
    match name {
        Some(name) => format!("{what} {:?} ({entity})", name.as_str()),
        None => format!("{what} {entity}"),
    }
}

/// The errors logged for each caster last time it was cast: a caster's error is logged when
/// it first appears (or changes), not again while it stays.
#[derive(Default)]
pub struct ReportedErrors(EntityHashMap<String>);

impl ReportedErrors {
    /// Logs `error` for `label`'s caster unless it was logged last time, and keeps it in `next`.
    fn report(
        &self,
        next: &mut EntityHashMap<String>,
        entity: Entity,
        error: String,
        label: impl FnOnce() -> String,
    ) {
        if self.0.get(&entity) != Some(&error) {
            log::error!("impact3d: {} casts nothing: {error}", label());
        }
        next.insert(entity, error);
    }
}

/// A caster component, as [`update_casters`] casts it.
trait Caster: Component<Mutability = Mutable> {
    /// What it keeps for a collider it hits.
    type Hit: PartialEq;
    /// Its checked input in the world frame.
    type Input;
    /// What a log line calls it.
    const WHAT: &'static str;

    /// Whether it casts.
    fn enabled(&self) -> bool;

    /// Its input in the world frame of an entity at `translation`, turned by `rotation`, or why
    /// it cannot be cast.
    fn input(&self, translation: Vec3, rotation: Quat) -> Result<Self::Input, String>;

    /// Keeps `input` as its last cast and casts it from `entity` against `query`'s colliders.
    fn cast(&mut self, input: Self::Input, entity: Entity, query: &SpatialQuery) -> Vec<Self::Hit>;
}

/// The components [`update_casters`] reads and writes: a caster `C` and its hits `H`.
type CasterData<C, H> = (
    Entity,
    &'static mut C,
    &'static mut H,
    Option<&'static Transform>,
    Option<&'static Name>,
);

/// Casts every enabled caster `C` from its entity's pose and stores its hits in its `H`
/// (cleared for a disabled caster or bad input, which is logged once per caster).
fn update_casters<C, H>(
    mut casters: Query<CasterData<C, H>>,
    query: SpatialQuery,
    mut reported: Local<ReportedErrors>,
) where
    C: Caster,
    H: Component<Mutability = Mutable> + DerefMut<Target = Vec<C::Hit>>,
{
    let mut next = EntityHashMap::default();
    for (entity, mut caster, mut hits, transform, name) in &mut casters {
        if !caster.enabled() {
            if !hits.is_empty() {
                hits.clear();
            }
            continue;
        }
        let input = caster_frame(transform)
            .and_then(|(translation, rotation)| caster.input(translation, rotation));
        let found = match input {
            Ok(input) => caster.bypass_change_detection().cast(input, entity, &query),
            Err(error) => {
                reported.report(&mut next, entity, error, || {
                    caster_label(C::WHAT, entity, name)
                });
                Vec::new()
            }
        };
        if **hits != found {
            **hits = found;
        }
    }
    reported.0 = next;
}

/// The colliders a caster's `query_filter` admits, less the caster's own `entity` with
/// `ignore_self`.
fn caster_filter(
    query_filter: &SpatialQueryFilter,
    ignore_self: bool,
    entity: Entity,
) -> SpatialQueryFilter {
    let mut filter = query_filter.clone();
    if ignore_self {
        filter.excluded_entities.insert(entity);
    }
    filter
}
