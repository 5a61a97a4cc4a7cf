//! The [`MoveAndSlide`] system parameter: move a shape along a motion, sliding along what it
//! hits (avian3d 0.7's API, on impact3d's [`SpatialQuery`]).

use std::time::Duration;

use bevy::ecs::system::SystemParam;
use bevy::prelude::*;

use super::config::{DepenetrationConfig, MoveAndSlideConfig, check_input, check_vector};
use super::hits::{MoveAndSlideHitData, MoveAndSlideHitResponse, MoveAndSlideOutput, MoveHitData};
use super::project::{add_plane, project_velocity};
use crate::collision::{BroadPhaseTree, Collider, ColliderDisabled, Sensor};
use crate::dynamics::{PhysicsLengthUnit, Quarantined, RigidBodyDisabled};
use crate::spatial_query::{
    ShapeCastConfig, SpatialQuery, SpatialQueryColliders, SpatialQueryFilter,
};

/// Below this `cos` of the angle between a motion and a surface the skin's pull-back is capped
/// (at `skin / DOT_EPSILON`): a motion grazing a surface is not pulled back without bound.
const DOT_EPSILON: f32 = 0.005;

/// A move shorter than this (length units) is not cast: it is done.
pub(crate) const MIN_MOVE: f32 = 1e-5;

/// Moves a shape along a motion, sliding along the colliders it hits: move and slide (also
/// called collide and slide), the core of a kinematic character controller, with avian3d 0.7's
/// names and meanings: [`move_and_slide`](Self::move_and_slide),
/// [`cast_move`](Self::cast_move), [`depenetrate`](Self::depenetrate),
/// [`depenetrate_intersections`](Self::depenetrate_intersections),
/// [`intersections`](Self::intersections) and [`project_velocity`](Self::project_velocity).
/// [`move_character`](Self::move_character) adds steps, slopes, snapping and ground detection
/// (see [`CharacterConfig`](super::CharacterConfig)).
///
/// # Algorithm
///
/// Push the shape out of anything it starts in ([`depenetrate`](Self::depenetrate)); then, up
/// to [`MoveAndSlideConfig::move_and_slide_iterations`] times: cast the shape along the motion
/// left ([`cast_move`](Self::cast_move), the exact shape casts of [`SpatialQuery`]); move it up
/// to the first hit less the skin; gather the planes it touches (the hit's, and the contacts
/// within twice the skin); project the motion left onto all of them at once
/// ([`project_velocity`]: along a wall, along the crease of two, stopped in a corner); until
/// nothing is hit or nothing is left. Then depenetrate again.
///
/// # What it sees
///
/// What a [`SpatialQuery`] sees: the colliders as the last physics step left them, filtered by
/// the given [`SpatialQueryFilter`] (exclude the moving entity itself). Sensors are not hit.
/// The skin and the depenetration tolerances are in units of [`PhysicsLengthUnit`] (as in
/// avian3d); motions are in metres.
///
/// # Bad input
///
/// A position, rotation, velocity or time that is not finite, or a configuration that fails
/// [`MoveAndSlideConfig::validate`], moves nothing: the shape stays where it is, with a zero
/// projected velocity. Nothing panics. ([`KinematicCharacter`](super::KinematicCharacter) logs
/// such input, naming the entity.)
///
/// # Examples
///
/// ```
/// use bevy::prelude::*;
/// use impact3d::prelude::*;
///
/// #[derive(Component)]
/// struct Walker {
///     velocity: Vec3,
/// }
///
/// fn walk(
///     mut walkers: Query<(Entity, &Collider, &mut Walker, &mut Transform)>,
///     move_and_slide: MoveAndSlide,
///     time: Res<Time>,
/// ) {
///     for (entity, collider, mut walker, mut transform) in &mut walkers {
///         let filter = SpatialQueryFilter::from_excluded_entities([entity]);
///         let out = move_and_slide.move_and_slide(
///             collider,
///             transform.translation,
///             transform.rotation,
///             walker.velocity,
///             time.delta(),
///             &MoveAndSlideConfig::default(),
///             &filter,
///             |_hit| MoveAndSlideHitResponse::Accept,
///         );
///         transform.translation = out.position;
///         walker.velocity = out.projected_velocity;
///     }
/// }
/// # bevy::ecs::system::assert_is_system(walk);
/// ```
#[derive(SystemParam)]
pub struct MoveAndSlide<'w, 's> {
    /// The spatial queries the casts go through.
    pub spatial_query: SpatialQuery<'w, 's>,
    /// The colliders queries see, for the contacts of [`intersections`](Self::intersections).
    pub(super) colliders: Res<'w, SpatialQueryColliders>,
    pub(super) tree: Res<'w, BroadPhaseTree>,
    /// The bodies a query may hit (as [`SpatialQuery`] decides).
    pub(super) live: Query<'w, 's, (), Live>,
    /// Sensors, which nothing here collides with.
    sensors: Query<'w, 's, (), With<Sensor>>,
    /// Scales the skin and the depenetration tolerances (as in avian3d).
    pub length_unit: Res<'w, PhysicsLengthUnit>,
}

/// A body that still has a collider, enabled and not quarantined.
type Live = (
    With<Collider>,
    Without<ColliderDisabled>,
    Without<RigidBodyDisabled>,
    Without<Quarantined>,
);

impl MoveAndSlide<'_, '_> {
    /// The length unit, 1 when it is invalid (the step logs that).
    pub(crate) fn unit(&self) -> f32 {
        self.length_unit.validated(1.0).0
    }

    /// Whether `entity`'s collider is a sensor (nothing here collides with sensors).
    pub(crate) fn is_sensor(&self, entity: Entity) -> bool {
        self.sensors.contains(entity)
    }

    /// Moves `shape` from `shape_position`, turned by `shape_rotation`, along `velocity` for
    /// `delta_time`, sliding along what it hits (see [`MoveAndSlide`] for the algorithm). For
    /// each plane it meets, `on_hit` decides whether the motion slides along it, ignores it, or
    /// stops there; it may also change the hit's normal, the position and the velocity.
    #[allow(clippy::too_many_arguments)]
    #[must_use]
    pub fn move_and_slide(
        &self,
        shape: &Collider,
        shape_position: Vec3,
        shape_rotation: Quat,
        velocity: Vec3,
        delta_time: Duration,
        config: &MoveAndSlideConfig,
        filter: &SpatialQueryFilter,
        mut on_hit: impl FnMut(MoveAndSlideHitData) -> MoveAndSlideHitResponse,
    ) -> MoveAndSlideOutput {
        let dt = delta_time.as_secs_f32();
        let valid = check_input(shape, shape_position, shape_rotation)
            .and_then(|_| check_vector("velocity", velocity))
            .and_then(|_| config.validate());
        if valid.is_err() || !dt.is_finite() {
            return MoveAndSlideOutput {
                position: shape_position,
                projected_velocity: Vec3::ZERO,
            };
        }
        let rotation = shape_rotation.normalize();
        let skin = self.unit() * config.skin_width;
        let depenetration = DepenetrationConfig::from(config);
        let mut position = shape_position
            + self.depenetrate(shape, shape_position, rotation, &depenetration, filter);
        let fixed = Move {
            shape,
            rotation,
            config,
            filter,
            skin,
        };
        let mut velocity = velocity;
        let mut time_left = dt;
        for _ in 0..config.move_and_slide_iterations {
            let sweep = velocity * time_left;
            let length = sweep.length();
            if length < MIN_MOVE * self.unit() {
                break;
            }
            let Some(hit) = self.cast_move(shape, position, rotation, sweep, skin, filter) else {
                position += sweep;
                break;
            };
            position += sweep / length * hit.distance;
            time_left *= 1.0 - hit.distance / length;
            let slide = self.slide_planes(&fixed, &hit, &mut position, &mut velocity, &mut on_hit);
            let Some((planes, aborted)) = slide else {
                break;
            };
            velocity = project_velocity(velocity, &planes);
            if aborted {
                break;
            }
        }
        position += self.depenetrate(shape, position, rotation, &depenetration, filter);
        MoveAndSlideOutput {
            position,
            projected_velocity: velocity,
        }
    }

    /// The planes a move slides along after `hit`: the configured ones, the hit's and those
    /// of the contacts within two skins, each as `on_hit` answers; also whether it asked to
    /// stop after them. `None` if it asked to stop at `hit` itself.
    fn slide_planes(
        &self,
        fixed: &Move,
        hit: &MoveHitData,
        position: &mut Vec3,
        velocity: &mut Vec3,
        on_hit: &mut impl FnMut(MoveAndSlideHitData) -> MoveAndSlideHitResponse,
    ) -> Option<(Vec<Dir3>, bool)> {
        let mut planes = fixed.config.planes.clone();
        let mut normal = Dir3::new(hit.normal1)
            .or(Dir3::new(-*velocity))
            .unwrap_or(Dir3::X);
        let response = on_hit(MoveAndSlideHitData {
            entity: hit.entity,
            distance: hit.distance,
            point: hit.point1,
            normal: &mut normal,
            position,
            velocity,
            collision_distance: hit.collision_distance,
        });
        match response {
            MoveAndSlideHitResponse::Accept => planes.push(normal),
            MoveAndSlideHitResponse::Ignore => {}
            MoveAndSlideHitResponse::Abort => return None,
        }
        let mut aborted = false;
        let at = *position;
        let near = 2.0 * fixed.skin;
        self.intersections(
            fixed.shape,
            at,
            fixed.rotation,
            near,
            fixed.filter,
            |entity, c, n| {
                let mut normal = n;
                let response = on_hit(MoveAndSlideHitData {
                    entity,
                    distance: 0.0,
                    point: c.point,
                    normal: &mut normal,
                    position,
                    velocity,
                    collision_distance: -c.penetration,
                });
                match response {
                    MoveAndSlideHitResponse::Accept => {
                        add_plane(&mut planes, normal.as_vec3(), *velocity, fixed.config);
                        true
                    }
                    MoveAndSlideHitResponse::Ignore => true,
                    MoveAndSlideHitResponse::Abort => {
                        aborted = true;
                        false
                    }
                }
            },
        );
        Some((planes, aborted))
    }

    /// Casts `shape` from `shape_position` along `movement` (its length is how far) and
    /// returns the first collider it would hit, with how far it can go and still keep
    /// `skin_width` (length units) from it ([`MoveHitData::distance`]); `None` if it can move
    /// the whole way (and the skin beyond). A shape starting inside a collider and moving out
    /// of it does not hit it; moving further in, it hits it at 0. A zero `movement` finds only
    /// what the shape starts in. Bad input (see [`MoveAndSlide`]) finds nothing.
    #[must_use]
    pub fn cast_move(
        &self,
        shape: &Collider,
        shape_position: Vec3,
        shape_rotation: Quat,
        movement: Vec3,
        skin_width: f32,
        filter: &SpatialQueryFilter,
    ) -> Option<MoveHitData> {
        let (direction, length) = Dir3::new_and_length(movement).unwrap_or((Dir3::X, 0.0));
        let distance = length + skin_width.max(0.0);
        let config = ShapeCastConfig {
            ignore_origin_penetration: true,
            ..ShapeCastConfig::from_max_distance(distance)
        };
        let hit = self.spatial_query.cast_shape_predicate(
            shape,
            shape_position,
            shape_rotation,
            direction,
            &config,
            filter,
            &|entity| !self.is_sensor(entity),
        )?;
        let facing = direction.dot(-hit.normal1).max(DOT_EPSILON);
        let safe = if length == 0.0 {
            0.0
        } else {
            (hit.distance - skin_width / facing).max(0.0)
        };
        Some(MoveHitData {
            entity: hit.entity,
            distance: safe,
            point1: hit.point1,
            point2: hit.point2,
            normal1: hit.normal1,
            normal2: hit.normal2,
            collision_distance: hit.distance,
        })
    }

    /// Projects `v` onto the planes of `normals` (see [`project_velocity`]).
    #[must_use]
    pub fn project_velocity(v: Vec3, normals: &[Dir3]) -> Vec3 {
        project_velocity(v, normals)
    }
}

/// The arguments that stay the same through one move.
struct Move<'a> {
    shape: &'a Collider,
    rotation: Quat,
    config: &'a MoveAndSlideConfig,
    filter: &'a SpatialQueryFilter,
    /// The skin, scaled by the length unit.
    skin: f32,
}
