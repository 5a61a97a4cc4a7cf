//! What spatial queries take and give: hits, projections, the shape cast settings, boxes.

use bevy::prelude::*;
use parry3d::bounding_volume::Aabb;

/// A ray's hit on a collider (avian3d 0.7's type, with the hit point added).
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
#[reflect(Debug, PartialEq)]
pub struct RayHitData {
    /// The body whose collider the ray hit.
    pub entity: Entity,
    /// How far the ray travelled, m: from its origin to the hit point (0 when a solid cast starts
    /// inside the collider).
    pub distance: f32,
    /// The outward surface normal at the hit point, world frame, unit length (zero when a solid
    /// cast starts inside the collider).
    pub normal: Vec3,
    /// The hit point, world frame, m: `origin + distance * direction`.
    pub point: Vec3,
}

/// A shape cast's hit on a collider (avian3d 0.7's type).
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
#[reflect(Debug, PartialEq)]
pub struct ShapeHitData {
    /// The body whose collider the shape hit.
    pub entity: Entity,
    /// How far the shape travelled before the hit, m (0 when it starts touching or
    /// penetrating).
    pub distance: f32,
    /// The point on the collider that was hit, world frame, m.
    pub point1: Vec3,
    /// The point on the cast shape, at its pose at the hit, world frame, m (the same as `point1`
    /// unless the shapes penetrate or a `target_distance` is set).
    pub point2: Vec3,
    /// The outward normal of the hit collider at `point1`, world frame.
    pub normal1: Vec3,
    /// The outward normal of the cast shape at `point2`, world frame.
    pub normal2: Vec3,
}

/// The projection of a point on the closest collider (avian3d 0.7's type).
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
#[reflect(Debug, PartialEq)]
pub struct PointProjection {
    /// The body of the closest collider.
    pub entity: Entity,
    /// The closest point on that collider, world frame, m (the point itself when it is inside
    /// and the query is solid).
    pub point: Vec3,
    /// Whether the point is inside the collider.
    pub is_inside: bool,
}

/// How a shape cast runs (avian3d 0.7's type).
#[derive(Clone, Debug, PartialEq, Reflect)]
#[reflect(Debug, PartialEq)]
pub struct ShapeCastConfig {
    /// How far the shape may travel, m, at least 0. Default `f32::MAX` (no limit).
    pub max_distance: f32,
    /// The separation, m, at which the shapes count as touching, at least 0. Default 0: when
    /// they first touch.
    pub target_distance: f32,
    /// Whether points and normals are computed when the shape starts touching or penetrating
    /// (distance 0). Default true.
    pub compute_contact_on_penetration: bool,
    /// When the shape starts penetrating a collider and moves out of it, that collider is not
    /// hit. Default false: a shape starting inside a collider hits it at distance 0.
    pub ignore_origin_penetration: bool,
}

impl Default for ShapeCastConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl ShapeCastConfig {
    /// No distance limit, hits on touching, contacts computed on penetration.
    pub const DEFAULT: Self = Self {
        max_distance: f32::MAX,
        target_distance: 0.0,
        compute_contact_on_penetration: true,
        ignore_origin_penetration: false,
    };

    /// The default with `max_distance` (m).
    pub const fn from_max_distance(max_distance: f32) -> Self {
        Self {
            max_distance,
            ..Self::DEFAULT
        }
    }

    /// The default with `target_distance` (m).
    pub const fn from_target_distance(target_distance: f32) -> Self {
        Self {
            target_distance,
            ..Self::DEFAULT
        }
    }

    /// This configuration with `max_distance` (m).
    pub const fn with_max_distance(mut self, max_distance: f32) -> Self {
        self.max_distance = max_distance;
        self
    }

    /// This configuration with `target_distance` (m).
    pub const fn with_target_distance(mut self, target_distance: f32) -> Self {
        self.target_distance = target_distance;
        self
    }
}

/// An axis-aligned box, world frame, m, for
/// [`SpatialQuery::aabb_intersections_with_aabb`](super::SpatialQuery::aabb_intersections_with_aabb)
/// (avian3d 0.7's name and constructors; here a plain value, not a component).
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
#[reflect(Debug, PartialEq)]
pub struct ColliderAabb {
    /// The lowest corner.
    pub min: Vec3,
    /// The highest corner.
    pub max: Vec3,
}

impl ColliderAabb {
    /// The box of `half_size` about `center`.
    pub fn new(center: Vec3, half_size: Vec3) -> Self {
        Self {
            min: center - half_size,
            max: center + half_size,
        }
    }

    /// The box from its corners.
    pub fn from_min_max(min: Vec3, max: Vec3) -> Self {
        Self { min, max }
    }

    /// The centre.
    pub fn center(self) -> Vec3 {
        0.5 * (self.min + self.max)
    }

    /// The full size along each axis.
    pub fn size(self) -> Vec3 {
        self.max - self.min
    }

    /// Whether the two boxes overlap (touching faces count).
    pub fn intersects(&self, other: &Self) -> bool {
        self.min.cmple(other.max).all() && other.min.cmple(self.max).all()
    }
}

impl From<Aabb> for ColliderAabb {
    fn from(aabb: Aabb) -> Self {
        Self::from_min_max(aabb.mins, aabb.maxs)
    }
}

impl From<ColliderAabb> for Aabb {
    fn from(aabb: ColliderAabb) -> Self {
        Aabb::new(aabb.min, aabb.max)
    }
}
