//! [`RayCaster`]: a ray cast every physics step from its entity, its hits kept in
//! [`RayHits`].

use bevy::prelude::*;
use parry3d::query::Ray;

use super::super::system_param::{ray_input, sort_hits};
use super::super::{RayHitData, SpatialQuery, SpatialQueryFilter};
use super::{Caster, CasterData, ReportedErrors, caster_filter, update_casters};

/// Casts a ray every physics step from its entity and keeps the hits in [`RayHits`] (avian3d
/// 0.7's component: the same fields and defaults).
///
/// The ray starts at `origin` and runs along `direction`, both in the frame of the entity's
/// `Transform` (its translation and rotation; scale is ignored; an entity without a `Transform`
/// casts in the world frame). A caster on a child entity is placed by its own `Transform`, as
/// colliders are. It is cast right after each physics step
/// ([`SpatialQuerySystems`](crate::spatial_query::SpatialQuerySystems), before
/// `PhysicsSystems::Last`), against the colliders of that step (see [`SpatialQuery`]), from the
/// pose the step gave its entity: on a moving body it moves with the body.
///
/// Bad input (an origin or `Transform` that is not finite, a zero or non-finite direction, a
/// negative or NaN `max_distance`) gives no hits and is logged once as an error naming the
/// entity (by its `Name`), again only after it has been valid.
///
/// # Examples
///
/// ```
/// use bevy::prelude::*;
/// use impact3d::prelude::*;
///
/// let mut app = impact3d::scenes::headless_app(60.0);
/// let ground = app
///     .world_mut()
///     .spawn((RigidBody::Static, Collider::half_space(Vec3::Y)))
///     .id();
/// // A sensor 2 m up looking down.
/// let eye = app
///     .world_mut()
///     .spawn((RayCaster::new(Vec3::ZERO, Dir3::NEG_Y), Transform::from_xyz(0.0, 2.0, 0.0)))
///     .id();
/// impact3d::scenes::run_steps(&mut app, 1);
/// let hits = app.world().get::<RayHits>(eye).unwrap();
/// assert_eq!(hits[0].entity, ground);
/// assert_eq!(hits[0].distance, 2.0);
/// ```
#[derive(Component, Clone, Debug, PartialEq, Reflect)]
#[reflect(Component, Debug, PartialEq)]
#[require(RayHits)]
pub struct RayCaster {
    /// Casts while true. Default true.
    pub enabled: bool,
    /// Where the ray starts, in the entity's frame, m. Default zero.
    pub origin: Vec3,
    /// Where the ray runs, in the entity's frame. Default `Dir3::X`.
    pub direction: Dir3,
    /// How many hits are kept: the nearest ones. Default `u32::MAX` (all).
    pub max_hits: u32,
    /// How far the ray reaches, m. Default `f32::MAX` (no limit).
    pub max_distance: f32,
    /// A ray starting inside a collider hits it at distance 0 (true), or where it leaves it
    /// (false). Default true.
    pub solid: bool,
    /// The entity's own collider is not hit. Default true.
    pub ignore_self: bool,
    /// Which colliders are considered. Default all.
    pub query_filter: SpatialQueryFilter,
    /// The world-frame origin of the last cast.
    global_origin: Vec3,
    /// The world-frame direction of the last cast.
    global_direction: Dir3,
}

impl Default for RayCaster {
    fn default() -> Self {
        RayCaster {
            enabled: true,
            origin: Vec3::ZERO,
            direction: Dir3::X,
            max_hits: u32::MAX,
            max_distance: f32::MAX,
            solid: true,
            ignore_self: true,
            query_filter: SpatialQueryFilter::DEFAULT,
            global_origin: Vec3::ZERO,
            global_direction: Dir3::X,
        }
    }
}

impl RayCaster {
    /// A ray from `origin` along `direction` (entity frame), with the other defaults.
    pub fn new(origin: Vec3, direction: Dir3) -> Self {
        RayCaster {
            origin,
            direction,
            ..default()
        }
    }

    /// This caster with `origin` (entity frame, m).
    pub fn with_origin(mut self, origin: Vec3) -> Self {
        self.origin = origin;
        self
    }

    /// This caster with `direction` (entity frame).
    pub fn with_direction(mut self, direction: Dir3) -> Self {
        self.direction = direction;
        self
    }

    /// This caster with `solid` (see the field).
    pub fn with_solidness(mut self, solid: bool) -> Self {
        self.solid = solid;
        self
    }

    /// This caster with `ignore_self` (see the field).
    pub fn with_ignore_self(mut self, ignore: bool) -> Self {
        self.ignore_self = ignore;
        self
    }

    /// This caster with `max_distance` (m).
    pub fn with_max_distance(mut self, max_distance: f32) -> Self {
        self.max_distance = max_distance;
        self
    }

    /// This caster with `max_hits`.
    pub fn with_max_hits(mut self, max_hits: u32) -> Self {
        self.max_hits = max_hits;
        self
    }

    /// This caster with `query_filter`.
    pub fn with_query_filter(mut self, query_filter: SpatialQueryFilter) -> Self {
        self.query_filter = query_filter;
        self
    }

    /// Starts casting.
    pub fn enable(&mut self) {
        self.enabled = true;
    }

    /// Stops casting (its hits are cleared at the next step).
    pub fn disable(&mut self) {
        self.enabled = false;
    }

    /// The world-frame origin of the last cast, m.
    pub fn global_origin(&self) -> Vec3 {
        self.global_origin
    }

    /// The world-frame direction of the last cast.
    pub fn global_direction(&self) -> Dir3 {
        self.global_direction
    }

    /// The point `distance` (m) along the ray, entity frame.
    pub fn get_point(&self, distance: f32) -> Vec3 {
        self.origin + self.direction * distance
    }

    /// The point `distance` (m) along the last cast, world frame.
    pub fn get_global_point(&self, distance: f32) -> Vec3 {
        self.global_origin + self.global_direction * distance
    }
}

/// The hits of a [`RayCaster`]'s last cast, nearest first (then by entity), at most its
/// `max_hits`.
#[derive(Component, Clone, Debug, Default, Deref, DerefMut, PartialEq, Reflect)]
#[reflect(Component, Debug, Default, PartialEq)]
pub struct RayHits(pub Vec<RayHitData>);

impl RayHits {
    /// The hits in order of distance (they are kept in that order: this is a sorted copy, for
    /// avian3d's API).
    pub fn iter_sorted(&self) -> std::vec::IntoIter<RayHitData> {
        let mut hits = self.0.clone();
        sort_hits(&mut hits);
        hits.into_iter()
    }
}

/// The components [`update_ray_casters`] reads and writes.
type RayCasterData = CasterData<RayCaster, RayHits>;

impl Caster for RayCaster {
    type Hit = RayHitData;
    type Input = (Ray, f32);
    const WHAT: &'static str = "ray caster";

    fn enabled(&self) -> bool {
        self.enabled
    }

    fn input(&self, translation: Vec3, rotation: Quat) -> Result<(Ray, f32), String> {
        let origin = translation + rotation * self.origin;
        let direction = rotation * self.direction.as_vec3();
        ray_input(origin, direction, self.max_distance)
    }

    fn cast(
        &mut self,
        (ray, max): (Ray, f32),
        entity: Entity,
        query: &SpatialQuery,
    ) -> Vec<RayHitData> {
        // `ray_input` gave a unit direction: the `Dir3` is valid.
        let direction = Dir3::new_unchecked(ray.dir);
        self.global_origin = ray.origin;
        self.global_direction = direction;
        let filter = caster_filter(&self.query_filter, self.ignore_self, entity);
        if self.max_hits == 1 {
            query
                .cast_ray(ray.origin, direction, max, self.solid, &filter)
                .into_iter()
                .collect()
        } else {
            query.ray_hits(
                ray.origin,
                direction,
                max,
                self.max_hits,
                self.solid,
                &filter,
            )
        }
    }
}

/// Casts every enabled [`RayCaster`] from its entity's pose and stores its hits in its
/// [`RayHits`] (cleared for a disabled caster or bad input, which is logged once per caster).
pub fn update_ray_casters(
    casters: Query<RayCasterData>,
    query: SpatialQuery,
    reported: Local<ReportedErrors>,
) {
    update_casters(casters, query, reported);
}
