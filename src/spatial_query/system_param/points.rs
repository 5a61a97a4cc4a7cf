//! [`SpatialQuery`]'s point queries: the nearest projection of a point and the colliders that
//! contain it.

use bevy::prelude::*;
use parry3d::query::PointQuery;

use super::super::{PointProjection, SpatialQueryFilter};
use super::{Projected, SpatialQuery, check_point};

impl SpatialQuery<'_, '_> {
    /// The closest point to `point` (m) on the colliders `filter` admits (of least entity among
    /// equally close ones). With `solid`, a point inside a collider is its own projection;
    /// otherwise it is projected on the collider's surface.
    pub fn project_point(
        &self,
        point: Vec3,
        solid: bool,
        filter: &SpatialQueryFilter,
    ) -> Option<PointProjection> {
        self.project_point_predicate(point, solid, filter, &|_| true)
    }

    /// [`project_point`](Self::project_point) on the colliders `filter` admits and for whose
    /// entity `predicate` is true.
    pub fn project_point_predicate(
        &self,
        point: Vec3,
        solid: bool,
        filter: &SpatialQueryFilter,
        predicate: &dyn Fn(Entity) -> bool,
    ) -> Option<PointProjection> {
        check_point("point", point).ok()?;
        // A point's distance to a box is a lower bound on its distance to anything inside.
        self.nearest_hit(
            filter,
            predicate,
            f32::INFINITY,
            |aabb, _| Some(aabb.distance_to_local_point(point, true)),
            |c| {
                let projection = c.shape.project_point(&c.pose, point, solid);
                Some(Projected(
                    projection.point.distance(point),
                    PointProjection {
                        entity: c.entity,
                        point: projection.point,
                        is_inside: projection.is_inside,
                    },
                ))
            },
        )
        .map(|Projected(_, projection)| projection)
    }

    /// The colliders `filter` admits that contain `point` (m), by entity.
    pub fn point_intersections(&self, point: Vec3, filter: &SpatialQueryFilter) -> Vec<Entity> {
        let mut found = Vec::new();
        if check_point("point", point).is_err() {
            return found;
        }
        self.colliders.candidates(
            &self.tree,
            |aabb| aabb.contains_local_point(point),
            |c| {
                if self.accepts(c, filter) && c.shape.contains_point(&c.pose, point) {
                    found.push(c.entity);
                }
            },
        );
        found.sort_unstable();
        found
    }

    /// Calls `callback` with every collider `filter` admits that contains `point` (m), by
    /// entity, until it returns false.
    pub fn point_intersections_callback(
        &self,
        point: Vec3,
        filter: &SpatialQueryFilter,
        mut callback: impl FnMut(Entity) -> bool,
    ) {
        for entity in self.point_intersections(point, filter) {
            if !callback(entity) {
                break;
            }
        }
    }
}
