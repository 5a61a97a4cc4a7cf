//! [`SpatialQuery`]'s ray casts: the nearest hit, all hits, and the box test the tree walk
//! prunes with.

use bevy::prelude::*;
use parry3d::bounding_volume::Aabb;
use parry3d::query::Ray;

use super::super::colliders::QueryCollider;
use super::super::exact;
use super::super::{RayHitData, SpatialQueryFilter};
use super::{Cast, SpatialQuery, ray_input};

impl SpatialQuery<'_, '_> {
    /// The first hit of a ray from `origin` (m) along `direction` within `max_distance` (m), on
    /// the colliders `filter` admits. With `solid`, a ray starting inside a collider hits it at
    /// distance 0; otherwise colliders are hollow and it hits where it leaves.
    pub fn cast_ray(
        &self,
        origin: Vec3,
        direction: Dir3,
        max_distance: f32,
        solid: bool,
        filter: &SpatialQueryFilter,
    ) -> Option<RayHitData> {
        self.cast_ray_predicate(origin, direction, max_distance, solid, filter, &|_| true)
    }

    /// [`cast_ray`](Self::cast_ray) on the colliders `filter` admits and for whose entity
    /// `predicate` is true.
    pub fn cast_ray_predicate(
        &self,
        origin: Vec3,
        direction: Dir3,
        max_distance: f32,
        solid: bool,
        filter: &SpatialQueryFilter,
        predicate: &dyn Fn(Entity) -> bool,
    ) -> Option<RayHitData> {
        let cast = CheckedRay::new(origin, direction, max_distance, solid);
        self.nearest_cast(cast, filter, predicate)
    }

    /// Every hit of a ray (see [`cast_ray`](Self::cast_ray)), nearest first (then by entity),
    /// at most `max_hits` of them: the nearest ones.
    pub fn ray_hits(
        &self,
        origin: Vec3,
        direction: Dir3,
        max_distance: f32,
        max_hits: u32,
        solid: bool,
        filter: &SpatialQueryFilter,
    ) -> Vec<RayHitData> {
        let cast = CheckedRay::new(origin, direction, max_distance, solid);
        let mut hits = self.sorted_hits(cast, filter);
        hits.truncate(max_hits as usize);
        hits
    }

    /// Calls `callback` with every hit of a ray (see [`cast_ray`](Self::cast_ray)), nearest
    /// first (then by entity), until it returns false.
    pub fn ray_hits_callback(
        &self,
        origin: Vec3,
        direction: Dir3,
        max_distance: f32,
        solid: bool,
        filter: &SpatialQueryFilter,
        mut callback: impl FnMut(RayHitData) -> bool,
    ) {
        let cast = CheckedRay::new(origin, direction, max_distance, solid);
        for hit in self.sorted_hits(cast, filter) {
            if !callback(hit) {
                break;
            }
        }
    }
}

/// A ray cast's checked input (see [`SpatialQuery`]'s "Bad input"), and its box test.
struct CheckedRay {
    ray: Ray,
    max: f32,
    solid: bool,
    slab: Slab,
}

impl CheckedRay {
    fn new(origin: Vec3, direction: Dir3, max_distance: f32, solid: bool) -> Result<Self, String> {
        let (ray, max) = ray_input(origin, direction.as_vec3(), max_distance)?;
        let slab = Slab::new(&ray);
        Ok(CheckedRay {
            ray,
            max,
            solid,
            slab,
        })
    }
}

impl Cast for CheckedRay {
    type Hit = RayHitData;

    fn max(&self) -> f32 {
        self.max
    }

    fn entry(&self, aabb: &Aabb, max: f32) -> Option<f32> {
        self.slab.entry(aabb, max)
    }

    /// The ray's hit on `c` within its reach, exactly (see [`exact::cast_ray`]).
    fn hit(&self, c: &QueryCollider) -> Option<RayHitData> {
        let ray = &self.ray;
        let hit = exact::cast_ray(c.shape.as_ref(), &c.pose, ray, self.max, self.solid)?;
        Some(RayHitData {
            entity: c.entity,
            distance: hit.time_of_impact,
            normal: hit.normal,
            point: ray.point_at(hit.time_of_impact),
        })
    }
}

/// A ray prepared for box tests: its origin and the reciprocals of its direction's components.
struct Slab {
    origin: Vec3,
    inverse: Vec3,
}

impl Slab {
    fn new(ray: &Ray) -> Self {
        Slab {
            origin: ray.origin,
            inverse: ray.dir.recip(),
        }
    }

    /// Where the ray enters `aabb` (0 when it starts inside), if it does within `max` (m): the
    /// slab test, the latest entry into the three pairs of planes before the earliest exit.
    /// A component of the direction that is zero gives infinite slab times, or NaN for an
    /// origin on one of that axis's planes, which `min`/`max` pass over: the box then counts
    /// as entered along that axis, which can only enter a box early, never late (so the
    /// nearest-hit search never prunes a box holding a hit). parry's `cast_local_ray` gives the
    /// same entry with a clipping step per box (it was 35 % of a query's time; parry's own
    /// tree cast uses this test).
    #[inline]
    fn entry(&self, aabb: &Aabb, max: f32) -> Option<f32> {
        let a = (aabb.mins - self.origin) * self.inverse;
        let b = (aabb.maxs - self.origin) * self.inverse;
        let (near, far) = (a.min(b), a.max(b));
        let enter = near.max_element().max(0.0);
        let exit = far.min_element().min(max);
        (enter <= exit).then_some(enter)
    }
}
