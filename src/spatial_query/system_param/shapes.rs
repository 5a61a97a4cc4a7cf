//! [`SpatialQuery`]'s shape casts: the nearest hit and all hits of a shape swept along a
//! direction.

use bevy::prelude::*;
use parry3d::bounding_volume::Aabb;
use parry3d::math::Pose;
use parry3d::query::{Ray, RayCast, ShapeCastOptions};
use parry3d::shape::Shape;

use super::super::colliders::{QueryCollider, slack};
use super::super::exact;
use super::super::{ShapeCastConfig, ShapeHitData, SpatialQueryFilter};
use super::{Cast, SpatialQuery, check_distance, shape_pose, unit_direction};
use crate::collision::Collider;

impl SpatialQuery<'_, '_> {
    /// The first collider `shape` hits when it moves from `origin` (m), turned by
    /// `shape_rotation`, along `direction`, within `config.max_distance` (m), among those
    /// `filter` admits.
    pub fn cast_shape(
        &self,
        shape: &Collider,
        origin: Vec3,
        shape_rotation: Quat,
        direction: Dir3,
        config: &ShapeCastConfig,
        filter: &SpatialQueryFilter,
    ) -> Option<ShapeHitData> {
        self.cast_shape_predicate(
            shape,
            origin,
            shape_rotation,
            direction,
            config,
            filter,
            &|_| true,
        )
    }

    /// [`cast_shape`](Self::cast_shape) on the colliders `filter` admits and for whose entity
    /// `predicate` is true.
    #[allow(clippy::too_many_arguments)]
    pub fn cast_shape_predicate(
        &self,
        shape: &Collider,
        origin: Vec3,
        shape_rotation: Quat,
        direction: Dir3,
        config: &ShapeCastConfig,
        filter: &SpatialQueryFilter,
        predicate: &dyn Fn(Entity) -> bool,
    ) -> Option<ShapeHitData> {
        let cast = ShapeCast::new(shape, origin, shape_rotation, direction.as_vec3(), config);
        self.nearest_cast(cast, filter, predicate)
    }

    /// Every collider `shape` hits when cast (see [`cast_shape`](Self::cast_shape)), nearest
    /// first (then by entity), at most `max_hits` of them: the nearest ones.
    #[allow(clippy::too_many_arguments)]
    pub fn shape_hits(
        &self,
        shape: &Collider,
        origin: Vec3,
        shape_rotation: Quat,
        direction: Dir3,
        max_hits: u32,
        config: &ShapeCastConfig,
        filter: &SpatialQueryFilter,
    ) -> Vec<ShapeHitData> {
        let cast = ShapeCast::new(shape, origin, shape_rotation, direction.as_vec3(), config);
        let mut hits = self.sorted_hits(cast, filter);
        hits.truncate(max_hits as usize);
        hits
    }

    /// Calls `callback` with every collider `shape` hits when cast (see
    /// [`cast_shape`](Self::cast_shape)), nearest first (then by entity), until it returns
    /// false.
    #[allow(clippy::too_many_arguments)]
    pub fn shape_hits_callback(
        &self,
        shape: &Collider,
        origin: Vec3,
        shape_rotation: Quat,
        direction: Dir3,
        config: &ShapeCastConfig,
        filter: &SpatialQueryFilter,
        mut callback: impl FnMut(ShapeHitData) -> bool,
    ) {
        let cast = ShapeCast::new(shape, origin, shape_rotation, direction.as_vec3(), config);
        for hit in self.sorted_hits(cast, filter) {
            if !callback(hit) {
                break;
            }
        }
    }
}

/// A shape cast's checked input, and its box sweep.
struct ShapeCast<'a> {
    shape: &'a dyn Shape,
    pose: Pose,
    direction: Vec3,
    options: ShapeCastOptions,
    /// The ray of the centre of the cast shape's box.
    center_ray: Ray,
    /// Half the size of the cast shape's box, widened by the target distance and the slack.
    reach: Vec3,
}

impl<'a> ShapeCast<'a> {
    /// Checks the input of a shape cast (see [`SpatialQuery`]'s "Bad input").
    fn new(
        shape: &'a Collider,
        origin: Vec3,
        rotation: Quat,
        direction: Vec3,
        config: &ShapeCastConfig,
    ) -> Result<Self, String> {
        let pose = shape_pose(shape, origin, rotation)?;
        let direction = unit_direction(direction)?;
        let max = check_distance("max distance", config.max_distance)?;
        let target = check_distance("target distance", config.target_distance)?;
        let aabb = shape.shape().compute_aabb(&pose);
        // An unbounded cast shape (a turned half-space) has an infinite box: it sweeps every box.
        let (center, reach) = if aabb.mins.is_finite() && aabb.maxs.is_finite() {
            let half = 0.5 * (aabb.maxs - aabb.mins);
            (aabb.center(), half + Vec3::splat(target + slack(&aabb)))
        } else {
            (pose.translation, Vec3::INFINITY)
        };
        Ok(ShapeCast {
            shape: shape.shape().as_ref(),
            pose,
            direction,
            options: ShapeCastOptions {
                max_time_of_impact: max,
                target_distance: target,
                stop_at_penetration: !config.ignore_origin_penetration,
                compute_impact_geometry_on_penetration: config.compute_contact_on_penetration,
            },
            center_ray: Ray::new(center, direction),
            reach,
        })
    }
}

impl Cast for ShapeCast<'_> {
    type Hit = ShapeHitData;

    fn max(&self) -> f32 {
        self.options.max_time_of_impact
    }

    /// How far the cast shape's box travels before it meets `aabb` (or comes within the
    /// target distance of it), if it does within `max` (m): where the centre's ray enters
    /// `aabb` grown by the box's half size. No hit inside `aabb` is nearer.
    fn entry(&self, aabb: &Aabb, max: f32) -> Option<f32> {
        Aabb::new(aabb.mins - self.reach, aabb.maxs + self.reach).cast_local_ray(
            &self.center_ray,
            max,
            true,
        )
    }

    /// The cast's hit on `c`, exactly (see [`exact::cast_shape`]).
    fn hit(&self, c: &QueryCollider) -> Option<ShapeHitData> {
        let hit = exact::cast_shape(
            &c.pose,
            c.shape.as_ref(),
            &self.pose,
            self.direction,
            self.shape,
            &self.options,
        )?;
        Some(ShapeHitData {
            entity: c.entity,
            distance: hit.distance,
            point1: hit.point1,
            point2: hit.point2,
            normal1: hit.normal1,
            normal2: hit.normal2,
        })
    }
}
