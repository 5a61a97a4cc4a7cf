//! [`SpatialQuery`]'s intersection tests: the colliders whose boxes meet a box, and those
//! that meet a shape.

use bevy::prelude::*;
use parry3d::bounding_volume::{Aabb, BoundingVolume};

use super::super::colliders::slack;
use super::super::{ColliderAabb, SpatialQueryFilter};
use super::{SpatialQuery, check_point, shape_pose};
use crate::collision::Collider;

impl SpatialQuery<'_, '_> {
    /// The colliders whose bounding boxes (the box of the collider's shape at its pose)
    /// overlap `aabb`, faces touching included, by entity. Disabled and quarantined colliders
    /// are left out; as in avian3d there is no filter.
    pub fn aabb_intersections_with_aabb(&self, aabb: ColliderAabb) -> Vec<Entity> {
        let mut found = Vec::new();
        if check_point("box corner", aabb.min).is_err()
            || check_point("box corner", aabb.max).is_err()
        {
            return found;
        }
        let query = Aabb::from(aabb);
        self.colliders.candidates(
            &self.tree,
            |b| b.intersects(&query),
            |c| {
                if self.is_live(c) && c.aabb.intersects(&query) {
                    found.push(c.entity);
                }
            },
        );
        found.sort_unstable();
        found
    }

    /// Calls `callback` with every collider whose box overlaps `aabb` (see
    /// [`aabb_intersections_with_aabb`](Self::aabb_intersections_with_aabb)), by entity, until
    /// it returns false.
    pub fn aabb_intersections_with_aabb_callback(
        &self,
        aabb: ColliderAabb,
        mut callback: impl FnMut(Entity) -> bool,
    ) {
        for entity in self.aabb_intersections_with_aabb(aabb) {
            if !callback(entity) {
                break;
            }
        }
    }

    /// The colliders `filter` admits that `shape` at `shape_position` (m), turned by
    /// `shape_rotation`, touches or overlaps, by entity. A pair of shapes parry cannot test (two
    /// triangle meshes) counts as not intersecting.
    pub fn shape_intersections(
        &self,
        shape: &Collider,
        shape_position: Vec3,
        shape_rotation: Quat,
        filter: &SpatialQueryFilter,
    ) -> Vec<Entity> {
        let mut found = Vec::new();
        let Ok(pose) = shape_pose(shape, shape_position, shape_rotation) else {
            return found;
        };
        let query = shape.shape().compute_aabb(&pose);
        let amount = slack(&query);
        let query = if amount.is_finite() {
            query.loosened(amount)
        } else {
            query
        };
        self.colliders.candidates(
            &self.tree,
            |b| b.intersects(&query),
            |c| {
                if self.accepts(c, filter)
                    && parry3d::query::intersection_test(
                        &c.pose,
                        c.shape.as_ref(),
                        &pose,
                        shape.shape().as_ref(),
                    )
                    .unwrap_or(false)
                {
                    found.push(c.entity);
                }
            },
        );
        found.sort_unstable();
        found
    }

    /// Calls `callback` with every collider `filter` admits that `shape` intersects (see
    /// [`shape_intersections`](Self::shape_intersections)), by entity, until it returns false.
    pub fn shape_intersections_callback(
        &self,
        shape: &Collider,
        shape_position: Vec3,
        shape_rotation: Quat,
        filter: &SpatialQueryFilter,
        mut callback: impl FnMut(Entity) -> bool,
    ) {
        for entity in self.shape_intersections(shape, shape_position, shape_rotation, filter) {
            if !callback(entity) {
                break;
            }
        }
    }
}
