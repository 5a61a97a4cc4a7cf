//! The checks of one body's input: its collider, pose and velocities, its mass properties
//! (recomputed when their inputs changed), and its restitution and friction.

use bevy::prelude::*;

use crate::dynamics::validation::{
    MAX_ANGULAR_SPEED, MAX_COORDINATE, MAX_LINEAR_SPEED, body_label, check_length, within,
};
use crate::dynamics::{ComputedMass, Density, RigidBody};

use super::query::BodyDataItem;
use super::scale::BuiltBody;

/// Smallest squared length of a rotation quaternion accepted as a rotation (a length of
/// 1e-6): a shorter one is too close to zero to say which rotation it stands for once
/// normalised.
pub(super) const MIN_ROTATION_LENGTH_SQUARED: f32 = 1e-12;

/// Checks one body's input (at its world pose `t`) and refreshes its mass properties when
/// their inputs changed. `geometry`, for a body whose shape is built (child colliders or a
/// scale; already checked by [`build_body`](super::scale::build_body)), is that and whether it
/// changed in this step; `reshaped`: the body's child colliders changed (its mass properties
/// are recomputed).
pub(super) fn validate(
    item: &mut BodyDataItem,
    kind: RigidBody,
    t: &Transform,
    geometry: Option<(Option<&BuiltBody>, bool)>,
    reshaped: bool,
) -> Result<(), String> {
    if geometry.is_none()
        && let Some(error) = item.collider.as_ref().and_then(|c| c.error())
    {
        return Err(format!("invalid collider: {error}"));
    }
    if !within(t.translation.abs().max_element(), MAX_COORDINATE) {
        return Err(format!(
            "translation {} is not finite or beyond {MAX_COORDINATE:e} m",
            t.translation
        ));
    }
    let norm = t.rotation.length_squared();
    if !(norm.is_finite() && norm >= MIN_ROTATION_LENGTH_SQUARED) {
        return Err(format!(
            "invalid rotation {} (a quaternion of finite, non-zero length is needed)",
            t.rotation
        ));
    }
    if kind != RigidBody::Static {
        if let Some(v) = item.linear_velocity.as_deref() {
            check_length("linear velocity", v.0, MAX_LINEAR_SPEED)?;
        }
        if let Some(w) = item.angular_velocity.as_deref() {
            check_length("angular velocity", w.0, MAX_ANGULAR_SPEED)?;
        }
    }
    if kind == RigidBody::Dynamic {
        refresh_mass(item, geometry, reshaped)?;
    }
    Ok(())
}

/// Recomputes a dynamic body's [`ComputedMass`] when its inputs changed (see [`validate`]),
/// warning when someone else wrote it; an error when it cannot be computed or the component is
/// missing.
fn refresh_mass(
    item: &mut BodyDataItem,
    geometry: Option<(Option<&BuiltBody>, bool)>,
    reshaped: bool,
) -> Result<(), String> {
    // `ComputedMass` is the plugin's own: written by anyone else (its change tick is newer
    // than this system's last run, which is when the plugin last wrote it), it is
    // recomputed like any stale value.
    let written = item
        .computed
        .as_ref()
        .is_some_and(|c| c.is_changed() && !c.is_added());
    let changed = written
        || geometry.is_some_and(|(_, changed)| changed)
        || reshaped
        || item.computed.as_ref().is_some_and(|c| c.is_added())
        || item.collider.as_ref().is_some_and(|c| c.is_changed())
        || item.body.as_ref().is_some_and(|b| b.is_changed())
        || item.mass.as_ref().is_some_and(|m| m.is_changed())
        || item.density.as_ref().is_some_and(|d| d.is_changed())
        || item.quarantined.is_some()
        || item.computed.as_ref().is_none_or(|c| c.inverse_mass == 0.0);
    if changed {
        let density = item
            .density
            .as_deref()
            .map_or(Density::default().0, |d| d.0);
        let mass = item.mass.as_deref().map(|m| m.0);
        let computed = match (geometry, item.collider.as_deref()) {
            (Some((Some(built), _)), _) => ComputedMass::from_parts(&built.parts, mass)?,
            (None, Some(collider)) => ComputedMass::from_collider(collider, density, mass)?,
            _ => return Err("dynamic body has no collider".to_string()),
        };
        if let Some(mut c) = item.computed.take() {
            if written && *c != computed {
                log::warn!(
                    "impact3d: {} had its ComputedMass written ({:?}); it is read-only and \
                     was recomputed from the collider, Density and Mass",
                    body_label(item.entity, item.name),
                    *c
                );
            }
            c.set_if_neq(computed);
            item.computed = Some(c);
        }
    }
    if item.computed.is_none() {
        return Err("dynamic body has no ComputedMass component".to_string());
    }
    Ok(())
}

/// Warns, naming the entity, when a body's restitution is set outside `[0, 1]` or its
/// friction below 0, or either to NaN (they are clamped).
pub(super) fn warn_on_coefficients(item: &BodyDataItem) {
    let label = || body_label(item.entity, item.name);
    warn_on_coefficient_change(&label, item.restitution.as_ref(), "restitution", 1.0);
    warn_on_coefficient_change(&label, item.friction.as_ref(), "friction", f32::INFINITY);
}

/// Warns, naming the entity, when a coefficient is set outside `[0, max]` or to NaN.
pub(super) fn warn_on_coefficient_change<T: std::ops::Deref<Target = f32> + Component>(
    label: &dyn Fn() -> String,
    value: Option<&Ref<T>>,
    what: &str,
    max: f32,
) {
    let Some(value) = value.filter(|v| v.is_changed()) else {
        return;
    };
    let v = ***value;
    if !(0.0..=max).contains(&v) {
        log::warn!(
            "impact3d: {} has {what} {v}, outside [0, {max}]; it is clamped to {}",
            label(),
            clamp_coefficient(Some(v), max)
        );
    }
}

/// Clamps a coefficient into `[0, max]`; NaN and missing become 0.
pub(super) fn clamp_coefficient(value: Option<f32>, max: f32) -> f32 {
    match value {
        Some(v) if v.is_nan() => 0.0,
        Some(v) => v.clamp(0.0, max),
        None => 0.0,
    }
}
