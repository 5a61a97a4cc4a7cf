//! [`ShapeCaster`]: a shape cast every physics step from its entity, its hits kept in
//! [`ShapeHits`].

use bevy::prelude::*;

use super::super::system_param::{
    check_distance, check_point, shape_pose, sort_hits, unit_direction,
};
use super::super::{ShapeCastConfig, ShapeHitData, SpatialQuery, SpatialQueryFilter};
use super::{Caster, CasterData, ReportedErrors, caster_filter, update_casters};
use crate::collision::Collider;

/// Casts a shape every physics step from its entity and keeps the hits in [`ShapeHits`]
/// (avian3d 0.7's component: the same fields and defaults).
///
/// The shape starts at `origin`, turned by `shape_rotation`, and moves along `direction`, all in
/// the frame of the entity's `Transform` (as for [`RayCaster`](super::RayCaster), which says when
/// it is cast and how bad input is handled; an invalid `shape` is bad input too).
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
/// // A ball of 0.5 m dropped from 3 m touches the ground after 2.5 m.
/// let probe = app
///     .world_mut()
///     .spawn(ShapeCaster::new(
///         Collider::sphere(0.5),
///         Vec3::new(0.0, 3.0, 0.0),
///         Quat::IDENTITY,
///         Dir3::NEG_Y,
///     ))
///     .id();
/// impact3d::scenes::run_steps(&mut app, 1);
/// let hits = app.world().get::<ShapeHits>(probe).unwrap();
/// assert_eq!(hits[0].entity, ground);
/// assert!((hits[0].distance - 2.5).abs() < 1e-5);
/// ```
#[derive(Component, Clone, Debug)]
#[require(ShapeHits)]
pub struct ShapeCaster {
    /// Casts while true. Default true.
    pub enabled: bool,
    /// The shape cast. Default a point (a sphere of radius 0: the cast is a ray's).
    pub shape: Collider,
    /// Where the shape starts, in the entity's frame, m. Default zero.
    pub origin: Vec3,
    /// The shape's rotation in the entity's frame. Default none.
    pub shape_rotation: Quat,
    /// Where the shape moves, in the entity's frame. Default `Dir3::X`.
    pub direction: Dir3,
    /// How many hits are kept: the nearest ones. Default 1.
    pub max_hits: u32,
    /// How far the shape may move, m. Default `f32::MAX` (no limit).
    pub max_distance: f32,
    /// The separation, m, at which the shapes count as touching. Default 0.
    pub target_distance: f32,
    /// Points and normals are computed when the shape starts touching or penetrating. Default
    /// true.
    pub compute_contact_on_penetration: bool,
    /// A collider the shape starts in and moves out of is not hit. Default false.
    pub ignore_origin_penetration: bool,
    /// The entity's own collider is not hit. Default true.
    pub ignore_self: bool,
    /// Which colliders are considered. Default all.
    pub query_filter: SpatialQueryFilter,
    /// The world-frame origin of the last cast.
    global_origin: Vec3,
    /// The world-frame rotation of the shape in the last cast.
    global_shape_rotation: Quat,
    /// The world-frame direction of the last cast.
    global_direction: Dir3,
}

impl Default for ShapeCaster {
    fn default() -> Self {
        ShapeCaster {
            enabled: true,
            shape: Collider::point(),
            origin: Vec3::ZERO,
            shape_rotation: Quat::IDENTITY,
            direction: Dir3::X,
            max_hits: 1,
            max_distance: f32::MAX,
            target_distance: 0.0,
            compute_contact_on_penetration: true,
            ignore_origin_penetration: false,
            ignore_self: true,
            query_filter: SpatialQueryFilter::DEFAULT,
            global_origin: Vec3::ZERO,
            global_shape_rotation: Quat::IDENTITY,
            global_direction: Dir3::X,
        }
    }
}

impl ShapeCaster {
    /// `shape` cast from `origin`, turned by `shape_rotation`, along `direction` (entity frame),
    /// with the other defaults.
    pub fn new(
        shape: impl Into<Collider>,
        origin: Vec3,
        shape_rotation: Quat,
        direction: Dir3,
    ) -> Self {
        ShapeCaster {
            shape: shape.into(),
            origin,
            shape_rotation,
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

    /// This caster with `target_distance` (m).
    pub fn with_target_distance(mut self, target_distance: f32) -> Self {
        self.target_distance = target_distance;
        self
    }

    /// This caster with `compute_contact_on_penetration` (see the field).
    pub fn with_compute_contact_on_penetration(mut self, compute: bool) -> Self {
        self.compute_contact_on_penetration = compute;
        self
    }

    /// This caster with `ignore_origin_penetration` (see the field).
    pub fn with_ignore_origin_penetration(mut self, ignore: bool) -> Self {
        self.ignore_origin_penetration = ignore;
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

    /// The world-frame rotation of the shape in the last cast.
    pub fn global_shape_rotation(&self) -> Quat {
        self.global_shape_rotation
    }

    /// The world-frame direction of the last cast.
    pub fn global_direction(&self) -> Dir3 {
        self.global_direction
    }

    /// The cast's settings.
    fn config(&self) -> ShapeCastConfig {
        ShapeCastConfig {
            max_distance: self.max_distance,
            target_distance: self.target_distance,
            compute_contact_on_penetration: self.compute_contact_on_penetration,
            ignore_origin_penetration: self.ignore_origin_penetration,
        }
    }
}

/// The hits of a [`ShapeCaster`]'s last cast, nearest first (then by entity), at most its
/// `max_hits`.
#[derive(Component, Clone, Debug, Default, Deref, DerefMut, PartialEq, Reflect)]
#[reflect(Component, Debug, Default, PartialEq)]
pub struct ShapeHits(pub Vec<ShapeHitData>);

impl ShapeHits {
    /// The hits in order of distance (they are kept in that order: this is a sorted copy, for
    /// avian3d's API).
    pub fn iter_sorted(&self) -> std::vec::IntoIter<ShapeHitData> {
        let mut hits = self.0.clone();
        sort_hits(&mut hits);
        hits.into_iter()
    }
}

/// The components [`update_shape_casters`] reads and writes.
type ShapeCasterData = CasterData<ShapeCaster, ShapeHits>;

impl Caster for ShapeCaster {
    type Hit = ShapeHitData;
    type Input = (Vec3, Vec3, Quat);
    const WHAT: &'static str = "shape caster";

    fn enabled(&self) -> bool {
        self.enabled
    }

    fn input(&self, translation: Vec3, rotation: Quat) -> Result<(Vec3, Vec3, Quat), String> {
        let origin = check_point("origin", translation + rotation * self.origin)?;
        let direction = unit_direction(rotation * self.direction.as_vec3())?;
        check_distance("max distance", self.max_distance)?;
        check_distance("target distance", self.target_distance)?;
        let pose = shape_pose(&self.shape, origin, rotation * self.shape_rotation)?;
        Ok((origin, direction, pose.rotation))
    }

    fn cast(
        &mut self,
        (origin, direction, shape_rotation): (Vec3, Vec3, Quat),
        entity: Entity,
        query: &SpatialQuery,
    ) -> Vec<ShapeHitData> {
        // `unit_direction` gave a unit vector: the `Dir3` is valid.
        let direction = Dir3::new_unchecked(direction);
        self.global_origin = origin;
        self.global_shape_rotation = shape_rotation;
        self.global_direction = direction;
        let filter = caster_filter(&self.query_filter, self.ignore_self, entity);
        let config = self.config();
        if self.max_hits == 1 {
            query
                .cast_shape(
                    &self.shape,
                    origin,
                    shape_rotation,
                    direction,
                    &config,
                    &filter,
                )
                .into_iter()
                .collect()
        } else {
            query.shape_hits(
                &self.shape,
                origin,
                shape_rotation,
                direction,
                self.max_hits,
                &config,
                &filter,
            )
        }
    }
}

/// Casts every enabled [`ShapeCaster`] from its entity's pose and stores its hits in its
/// [`ShapeHits`] (cleared for a disabled caster or bad input, which is logged once per caster).
pub fn update_shape_casters(
    casters: Query<ShapeCasterData>,
    query: SpatialQuery,
    reported: Local<ReportedErrors>,
) {
    update_casters(casters, query, reported);
}
