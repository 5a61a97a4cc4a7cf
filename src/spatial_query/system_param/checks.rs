//! The checks every query's input passes (finite points, unit directions, distances,
//! rotations, a usable cast shape) before it is used.

use bevy::prelude::*;
use parry3d::math::Pose;
use parry3d::query::Ray;

use crate::collision::Collider;

/// `p` if it is finite.
pub(crate) fn check_point(what: &str, p: Vec3) -> Result<Vec3, String> {
    if p.is_finite() {
        Ok(p)
    } else {
        Err(format!("{what} {p} is not finite"))
    }
}

/// `d` as a unit vector: as it is when its length is within 1e-4 of 1 (a `Dir3`), normalised
/// otherwise; an error when it is zero or not finite.
pub(crate) fn unit_direction(d: Vec3) -> Result<Vec3, String> {
    let len2 = d.length_squared();
    if !(len2.is_finite() && len2 > 0.0) {
        return Err(format!("direction {d} is zero or not finite"));
    }
    Ok(if (len2 - 1.0).abs() <= 1e-4 {
        d
    } else {
        d / len2.sqrt()
    })
}

/// A distance (m) of at least 0; infinity (no limit) becomes `f32::MAX`.
pub(crate) fn check_distance(what: &str, d: f32) -> Result<f32, String> {
    if d >= 0.0 {
        Ok(d.min(f32::MAX))
    } else {
        Err(format!("{what} {d} is negative or NaN"))
    }
}

/// `q` normalised, if it is a finite quaternion of non-zero length.
pub(crate) fn check_rotation(q: Quat) -> Result<Quat, String> {
    let norm = q.length_squared();
    if norm.is_finite() && norm >= 1e-12 {
        Ok(q.normalize())
    } else {
        Err(format!("rotation {q} is not a finite, non-zero quaternion"))
    }
}

/// The pose of a query shape, or why it cannot be used.
pub(crate) fn shape_pose(shape: &Collider, position: Vec3, rotation: Quat) -> Result<Pose, String> {
    if let Some(error) = shape.error() {
        return Err(format!("the cast shape is invalid: {error}"));
    }
    let position = check_point("shape position", position)?;
    let rotation = check_rotation(rotation)?;
    Ok(Pose::from_parts(position, rotation))
}

/// A ray from `origin` along `direction` (normalised) and its maximum distance, or why not.
pub(crate) fn ray_input(origin: Vec3, direction: Vec3, max: f32) -> Result<(Ray, f32), String> {
    check_point("origin", origin)?;
    let direction = unit_direction(direction)?;
    let max = check_distance("max distance", max)?;
    Ok((Ray::new(origin, direction), max))
}
