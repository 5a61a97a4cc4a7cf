//! [`RayCaster`] and [`ShapeCaster`]: components that cast every physics step, relative to their
//! entity, and keep their hits in [`RayHits`] and [`ShapeHits`].

use bevy::ecs::entity::EntityHashMap;
use bevy::prelude::*;

use super::system_param::{check_point, check_rotation};

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
