//! Spatial queries: ray casts, shape casts, point projection and intersection tests against the
//! colliders of the last physics step, with avian3d 0.7's names.
//!
//! - [`SpatialQuery`], a system parameter: [`cast_ray`](SpatialQuery::cast_ray),
//!   [`ray_hits`](SpatialQuery::ray_hits), [`cast_shape`](SpatialQuery::cast_shape),
//!   [`shape_hits`](SpatialQuery::shape_hits), [`project_point`](SpatialQuery::project_point),
//!   [`point_intersections`](SpatialQuery::point_intersections),
//!   [`shape_intersections`](SpatialQuery::shape_intersections),
//!   [`aabb_intersections_with_aabb`](SpatialQuery::aabb_intersections_with_aabb), and their
//!   predicate and callback forms; which colliders it considers is a [`SpatialQueryFilter`].
//! - [`RayCaster`] and [`ShapeCaster`], components that cast from their entity after every
//!   step, their hits in [`RayHits`] and [`ShapeHits`].
//!
//! Queries see each body's collider at the pose the last step wrote to its `Transform`,
//! recorded at the end of the step ([`SpatialQueryColliders`]) and found through the broad
//! phase's [`BroadPhaseTree`](crate::collision::BroadPhaseTree); see [`SpatialQuery`] for what
//! that means for bodies spawned or changed between steps, the order of hits and bad input.

mod casters;
mod colliders;
pub mod exact;
mod hits;
mod plugin;
mod query_filter;
mod system_param;

pub use casters::{
    RayCaster, RayHits, ReportedErrors, ShapeCaster, ShapeHits, update_ray_casters,
    update_shape_casters,
};
pub use colliders::{SpatialQueryColliders, update_query_colliders};
pub use hits::{ColliderAabb, PointProjection, RayHitData, ShapeCastConfig, ShapeHitData};
pub use plugin::{SpatialQueryPlugin, SpatialQuerySystems};
pub use query_filter::SpatialQueryFilter;
pub use system_param::SpatialQuery;
