//! The [`SpatialQuery`] system parameter: rays, shape casts, point projection and intersection
//! tests against the colliders of the last physics step.

use std::cell::{Cell, RefCell};

use bevy::ecs::system::SystemParam;
use bevy::prelude::*;
use parry3d::bounding_volume::{Aabb, BoundingVolume};
use parry3d::math::Pose;
use parry3d::query::{PointQuery, Ray, RayCast, ShapeCastOptions};
use parry3d::shape::Shape;

use super::SpatialQueryFilter;
use super::colliders::{QueryCollider, SpatialQueryColliders, slack};
use super::exact;
use super::{ColliderAabb, PointProjection, RayHitData, ShapeCastConfig, ShapeHitData};
use crate::collision::{BroadPhaseTree, Collider, ColliderDisabled};
use crate::dynamics::{Quarantined, RigidBodyDisabled};

/// Ray casts, shape casts, point projection and intersection tests against the colliders of
/// the last physics step (avian3d 0.7's system parameter: the same methods, arguments and
/// results, in metres, with `Vec3` and `Quat`).
///
/// # What a query sees
///
/// Each body's collider as the last physics step left it: the shape the step collided with
/// (compound shapes, half-spaces, triangle meshes and heightfields included; whatever
/// [`PhysicsLengthUnit`](crate::dynamics::PhysicsLengthUnit), which changes nothing here), at
/// the pose the step wrote to the body's `Transform`, with the body's
/// [`CollisionLayers`](crate::collision::CollisionLayers) of that step. The colliders are
/// recorded at the end of each step ([`PhysicsSystems::SpatialQuery`]) and found through the
/// broad phase's [`BroadPhaseTree`], so a query from `Update`, from `PhysicsSystems::Last` or
/// from any system between two steps sees the same world, consistent with the tree: a body
/// spawned, moved, or given a new collider or new layers since is seen as it is after the next
/// step (the step reads it then); a body interpolated for drawing
/// ([`TransformInterpolation`](crate::interpolation::TransformInterpolation)) is hit at its
/// physics pose, not where it is drawn. A body despawned since, or given
/// [`ColliderDisabled`], [`RigidBodyDisabled`] or [`Quarantined`] since, or whose collider was
/// removed, is not hit at once. Disabled and quarantined colliders are never hit; sensors are,
/// like any collider (leave their layers out of the filter's mask to skip them). (With a
/// replacement broad phase the tree stays empty: every body of the last step is then tested
/// directly, and a sleeping body that sat that step out is not found.)
///
/// # Order and determinism
///
/// A query's answer does not depend on the tree's shape: where several hits are returned they
/// are sorted by distance, then by entity (intersection tests by entity); the closest hit is the
/// one of least distance, of least entity among equals; callbacks are called in that order. Each
/// collider is tested exactly with parry ([`RayCast`], [`parry3d::query::cast_shapes`],
/// [`PointQuery`], [`parry3d::query::intersection_test`]) with the query's own arguments, so the
/// answer is the one a loop over every collider would give, bit for bit.
///
/// # Bad input
///
/// A non-finite origin, point or position, a direction that is zero or not finite (a direction
/// not of unit length is normalised), a negative or NaN distance, a rotation that is not a
/// finite non-zero quaternion (it is normalised), or a cast shape whose collider carries an
/// error, gives no hit: `None` or an empty list, and no callback. An infinite maximum distance
/// means no limit. Nothing panics. ([`RayCaster`](super::RayCaster) and
/// [`ShapeCaster`](super::ShapeCaster) log such input once per caster.)
///
/// [`PhysicsSystems::SpatialQuery`]: crate::schedule::PhysicsSystems::SpatialQuery
///
/// # Examples
///
/// ```
/// use bevy::prelude::*;
/// use impact3d::prelude::*;
///
/// /// The ground below `point`, if any within 10 m, and how far.
/// fn ground_below(query: &SpatialQuery, point: Vec3) -> Option<(Entity, f32)> {
///     query
///         .cast_ray(point, Dir3::NEG_Y, 10.0, true, &SpatialQueryFilter::default())
///         .map(|hit| (hit.entity, hit.distance))
/// }
///
/// let mut app = impact3d::scenes::headless_app(60.0);
/// let ground = app
///     .world_mut()
///     .spawn((RigidBody::Static, Collider::half_space(Vec3::Y)))
///     .id();
/// impact3d::scenes::run_steps(&mut app, 1);
/// let found = app
///     .world_mut()
///     .run_system_cached(|query: SpatialQuery| ground_below(&query, Vec3::new(1.0, 2.5, 0.0)))
///     .unwrap();
/// assert_eq!(found, Some((ground, 2.5)));
/// ```
#[derive(SystemParam)]
pub struct SpatialQuery<'w, 's> {
    tree: Res<'w, BroadPhaseTree>,
    colliders: Res<'w, SpatialQueryColliders>,
    /// The bodies that still have a collider, enabled and not quarantined.
    live: Query<'w, 's, (), Live>,
}

/// A body that still has a collider, enabled and not quarantined.
type Live = (
    With<Collider>,
    Without<ColliderDisabled>,
    Without<RigidBodyDisabled>,
    Without<Quarantined>,
);

impl SpatialQuery<'_, '_> {
    /// Whether `c` passes `filter` and is still a live collider.
    fn accepts(&self, c: &QueryCollider, filter: &SpatialQueryFilter) -> bool {
        filter.test(c.entity, c.layers) && self.live.contains(c.entity)
    }

    /// The nearest hit (of least entity among equally near ones) of a cast, or the nearest
    /// projection of a point, on the colliders `filter` and `predicate` admit: `hit` tests one
    /// collider, `entry(aabb, bound)` gives a lower bound (m) on the distance of anything in a
    /// box (where the cast enters it, the point's distance to it), if it is within `bound`,
    /// which shrinks to the nearest hit so far (see
    /// [`SpatialQueryColliders::nearest_candidates`]).
    fn nearest_hit<H: Hit>(
        &self,
        filter: &SpatialQueryFilter,
        predicate: &dyn Fn(Entity) -> bool,
        max: f32,
        entry: impl Fn(&Aabb, f32) -> Option<f32>,
        hit: impl Fn(&QueryCollider) -> Option<H>,
    ) -> Option<H> {
        let bound = Cell::new(max);
        let best: RefCell<Option<H>> = RefCell::new(None);
        self.colliders
            .nearest_candidates(&self.tree, &bound, entry, |c| {
                if !self.accepts(c, filter) || !predicate(c.entity) {
                    return;
                }
                if let Some(h) = hit(c) {
                    let mut best = best.borrow_mut();
                    if best.as_ref().is_none_or(|b| {
                        let ((d, e), (bd, be)) = (h.order(), b.order());
                        closer(d, e, bd, be)
                    }) {
                        bound.set(h.order().0);
                        *best = Some(h);
                    }
                }
            });
        best.into_inner()
    }

    /// Every hit of a cast on the colliders `filter` admits, sorted by distance then entity:
    /// `hit` tests one collider, `reaches` whether the cast enters a box.
    fn sorted_hits<H: Hit>(
        &self,
        filter: &SpatialQueryFilter,
        reaches: impl Fn(&Aabb) -> bool,
        hit: impl Fn(&QueryCollider) -> Option<H>,
    ) -> Vec<H> {
        let mut hits = Vec::new();
        self.colliders.candidates(&self.tree, reaches, |c| {
            if self.accepts(c, filter)
                && let Some(h) = hit(c)
            {
                hits.push(h);
            }
        });
        hits.sort_by(|a, b| {
            let ((da, ea), (db, eb)) = (a.order(), b.order());
            da.total_cmp(&db).then(ea.cmp(&eb))
        });
        hits
    }

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
        let (ray, max) = ray_input(origin, direction.as_vec3(), max_distance).ok()?;
        let slab = Slab::new(&ray);
        self.nearest_hit(
            filter,
            predicate,
            max,
            |aabb, bound| slab.entry(aabb, bound),
            |c| ray_hit(c, &ray, max, solid),
        )
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
        let mut hits = self.all_ray_hits(origin, direction, max_distance, solid, filter);
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
        for hit in self.all_ray_hits(origin, direction, max_distance, solid, filter) {
            if !callback(hit) {
                break;
            }
        }
    }

    /// Every hit of a ray, sorted by distance then entity.
    fn all_ray_hits(
        &self,
        origin: Vec3,
        direction: Dir3,
        max_distance: f32,
        solid: bool,
        filter: &SpatialQueryFilter,
    ) -> Vec<RayHitData> {
        let Ok((ray, max)) = ray_input(origin, direction.as_vec3(), max_distance) else {
            return Vec::new();
        };
        let slab = Slab::new(&ray);
        self.sorted_hits(
            filter,
            |aabb| slab.entry(aabb, max).is_some(),
            |c| ray_hit(c, &ray, max, solid),
        )
    }

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
        let cast =
            ShapeCast::new(shape, origin, shape_rotation, direction.as_vec3(), config).ok()?;
        self.nearest_hit(
            filter,
            predicate,
            cast.options.max_time_of_impact,
            |aabb, bound| cast.entry(aabb, bound),
            |c| cast.hit(c),
        )
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
        let mut hits =
            self.all_shape_hits(shape, origin, shape_rotation, direction, config, filter);
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
        for hit in self.all_shape_hits(shape, origin, shape_rotation, direction, config, filter) {
            if !callback(hit) {
                break;
            }
        }
    }

    /// Every hit of a shape cast, sorted by distance then entity.
    fn all_shape_hits(
        &self,
        shape: &Collider,
        origin: Vec3,
        shape_rotation: Quat,
        direction: Dir3,
        config: &ShapeCastConfig,
        filter: &SpatialQueryFilter,
    ) -> Vec<ShapeHitData> {
        let Ok(cast) = ShapeCast::new(shape, origin, shape_rotation, direction.as_vec3(), config)
        else {
            return Vec::new();
        };
        let max = cast.options.max_time_of_impact;
        self.sorted_hits(
            filter,
            |aabb| cast.entry(aabb, max).is_some(),
            |c| cast.hit(c),
        )
    }

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
                if self.live.contains(c.entity) && c.aabb.intersects(&query) {
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

/// A cast's hit, ordered by distance (m) then entity.
trait Hit {
    fn order(&self) -> (f32, Entity);
}

impl Hit for RayHitData {
    fn order(&self) -> (f32, Entity) {
        (self.distance, self.entity)
    }
}

impl Hit for ShapeHitData {
    fn order(&self) -> (f32, Entity) {
        (self.distance, self.entity)
    }
}

/// A point's projection on a collider and its distance from the point (m), ordered as a hit.
struct Projected(f32, PointProjection);

impl Hit for Projected {
    fn order(&self) -> (f32, Entity) {
        (self.0, self.1.entity)
    }
}

/// Whether a hit at `distance` on `entity` comes before one at `best` on `best_entity`: nearer,
/// or as near and of a smaller entity.
fn closer(distance: f32, entity: Entity, best: f32, best_entity: Entity) -> bool {
    distance < best || (distance == best && entity < best_entity)
}

/// `c`'s hit by `ray` within `max` (m), exactly (see [`exact::cast_ray`]).
fn ray_hit(c: &QueryCollider, ray: &Ray, max: f32, solid: bool) -> Option<RayHitData> {
    let hit = exact::cast_ray(c.shape.as_ref(), &c.pose, ray, max, solid)?;
    Some(RayHitData {
        entity: c.entity,
        distance: hit.time_of_impact,
        normal: hit.normal,
        point: ray.point_at(hit.time_of_impact),
    })
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

/// A ray from `origin` along `direction` (normalised) and its maximum distance, or why not.
pub(crate) fn ray_input(origin: Vec3, direction: Vec3, max: f32) -> Result<(Ray, f32), String> {
    check_point("origin", origin)?;
    let direction = unit_direction(direction)?;
    let max = check_distance("max distance", max)?;
    Ok((Ray::new(origin, direction), max))
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
